#!/usr/bin/python3
"""The two bias estimates of common/render/error_estimate.h against the atlas's truth, on the
progressive photon mappers' series of cbox, caustic, sds and stage_crop, and the film's own
two-radii estimate of the volumetric photon mapper on medium spheres and the spotlight in fog
and of vcm on cbox, caustic and sds.

    /usr/bin/python3 bench/atlas/bias_probes.py REFERENCE_DIR [--build build] [--scenes A,B]
    /usr/bin/python3 bench/atlas/bias_probes.py --order [--build build] [--scenes A,B]

REFERENCE_DIR holds the atlas's references (SCENE_ref.exr and its halves SCENE_ref_0.exr,
SCENE_ref_1.exr, as run_atlas.py writes them). For every scene it runs bench_atlas_render with
--bias-probes and prints one table row per pass count: the true error (the reference's own noise
taken out in quadrature), the noise-only estimate and each bias estimate, and truth / prediction
for noise only, noise + temporal bias and noise + two-radii bias.

The volume scenes (VOLUME_SCENES, unbiased references by volume_path_mis, named as above) and
photonmapper's progressive kNN on the Cornell box (KNN_SCENES, the atlas's cbox reference) need
no second render: the film of a progressive photon mapper keeps the smaller radii's image, so
each render prints its noise and its two-radii bias (bench_atlas_render's predicted_noise and
film_bias_two_radii columns); the table gives truth / noise and truth / (noise + two radii).
The volume references are made at the scenes' sizes here (60x45, 80x45: small, so that a
reference far less noisy than 256 passes is cheap), two halves of other seeds averaged:

    T=build/bench/bench_atlas_render
    $T render scenes/seed/medium_sphere_scatter.xml --size 60x45 --integrator volume_path_mis \
        --seed 101 --passes 2048 --write-exr DIR/medium_sphere_scatter_ref_0.exr   (and seed 102: _1)
    $T render scenes/seed/spotlight_fog.xml --size 80x45 --integrator volume_path_mis \
        --seed 101 --passes 8192 --write-exr DIR/spotlight_fog_ref_0.exr           (and seed 102: _1)
    $T average DIR/SCENE_ref_0.exr DIR/SCENE_ref_1.exr DIR/SCENE_ref.exr

--order measures the order p of the radius's bias, B(r) ~ r^p, without a reference: the film's
two-radii estimate at first radii r is 2 |Y(r) - Y(r/sqrt 2)|, which is (2 - 2^(1 - p/2)) B(r) in
truth; at first radii r/sqrt 2 it is 2^(-p/2) times that. So the ratio of the estimates of two
renders whose radii differ by sqrt 2 is 2^(-p/2): 1/2 for p = 2, the order the estimate assumes
(then it is exact), 0.71 for p = 1. Printed per scene: both estimates, their ratio and p.

vcm (VCM_SCENES) keeps the smaller radius's image in its film too (every merge within
r_i / sqrt 2, weighted as in the image): its rows come from the film's own estimate, as the
volume scenes'. The merge radius is the photon mapper series' first radius, at vcm's default
alpha 0.75, so that its bias stands out at 16-256 passes (the atlas's vcm runs at the scene
diagonal / 500, where merging is a small share of the error).

Where the reference is itself a progressive photon map (caustic, sds, and stage_crop, whose pin
spot reaches the crop only through the disco ball's mirror facets, which path tracing cannot
follow to a delta light) it shares the bias left at its own pass count: against it only the
part of the bias that falls between n passes and the reference's N is measurable,
B(n) - B(N) = B(n) (1 - mean_{i<N} r_i^2 / mean_{i<n} r_i^2). The predictions are compared with
the truth after that correction (column "seen"). For vcm against such a reference the radii are
the two methods' own (absolute, each with its alpha): where merging carries the light the
caustic's blur is the same kernel's, so the seen bias is B(n) (1 - mean_{i<N} r_ref,i^2 /
mean_{i<n} r_vcm,i^2).
"""
import argparse
import csv
import math
import os
import subprocess

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PPM = ["int:photonCount=200000", "float:surfacePhotonRadius=0.04", "bool:progressive=true",
       "float:alpha=0.5"]

# scene: file, size, crop, integrator, parameters, probed radii, ladder, reference passes (a
# progressive photon map's, or None for an unbiased reference).
SCENES = {
    "cbox": ("scenes/cbox/cbox.xml", "128x128", None, "photonmapper",
             ["int:photonCount=100000", "float:surfacePhotonRadius=0.05", "bool:progressive=true",
              "float:alpha=0.5"], "surfacePhotonRadius", "4,16,64", None),
    "caustic": ("scenes/caustic/caustic.xml", "192x144", None, "photonmapper", PPM,
                "surfacePhotonRadius", "16,64,256", 512),
    "sds": ("scenes/sds/sds.xml", "192x144", None, "photonmapper", PPM, "surfacePhotonRadius",
            "16,64,256", 256),
    "stage_crop": ("scenes/stage/stage.xml", "480x270", "160,60,320,180",
                   "volumetric_photonmapper",
                   PPM + ["float:volumePhotonRadius=0.1"],
                   "surfacePhotonRadius,volumePhotonRadius", "16,64", 128),
}


# The volumetric photon mapper, the film's own two radii (every surface disk and beam disk at half
# its area): scene: file, size, parameters, ladder. medium_sphere: the atlas's radii (0.05);
# medium_sphere_r0.2: a first volume radius four times larger, where its bias dominates
# (directLight "nee" keeps the floor's shadow off the surface radius's bias); spotlight_fog:
# fixed radii (the atlas's, and a volume radius of 0.4 where its bias shows) and the scene's own
# volume kNN radii (progressive, shrunk by the schedule).
VPM = ["int:photonCount=100000", "bool:progressive=true", "float:alpha=0.5"]
VOLUME_SCENES = {
    "medium_sphere_scatter": ("scenes/seed/medium_sphere_scatter.xml", "60x45",
                              VPM + ["float:surfacePhotonRadius=0.05",
                                     "float:volumePhotonRadius=0.05"], "16,64,256"),
    "medium_sphere_scatter_r0.2": ("scenes/seed/medium_sphere_scatter.xml", "60x45",
                                   VPM + ["float:surfacePhotonRadius=0.05",
                                          "float:volumePhotonRadius=0.2",
                                          "string:directLight=nee"], "16,64,256"),
    "spotlight_fog": ("scenes/seed/spotlight_fog.xml", "80x45",
                      VPM + ["float:surfacePhotonRadius=0.1", "float:volumePhotonRadius=0.1"],
                      "16,64,256"),
    "spotlight_fog_r0.4": ("scenes/seed/spotlight_fog.xml", "80x45",
                           VPM + ["float:surfacePhotonRadius=0.1",
                                  "float:volumePhotonRadius=0.4"], "16,64,256"),
    "spotlight_fog_knn": ("scenes/seed/spotlight_fog.xml", "80x45",
                          VPM + ["float:surfacePhotonRadius=0.1", "int:volumeK=10"],
                          "16,64,256"),
}
# Where each volume scene's reference lives under REFERENCE_DIR (run_atlas.py's names).
# photonmapper's progressive k nearest neighbours keep the two radii in their films too (the
# smaller disk: half the area of the shrunk kNN disk), measured on the Cornell box (the atlas's
# reference, path_mis at 128x128).
KNN_SCENES = {
    "cbox_knn": ("scenes/cbox/cbox.xml", "128x128",
                 ["int:photonCount=100000", "int:surfaceK=50", "bool:progressive=true",
                  "float:alpha=0.5", "string:directLight=photons"], "4,16,64"),
}
# vcm: scene, size, parameters, ladder, and (the reference's first radius, alpha, passes) for the
# seen correction, or None for an unbiased reference (path_mis on the Cornell box).
VCM_SCENES = {
    "cbox_vcm": ("scenes/cbox/cbox.xml", "128x128", ["float:radius=0.05"], "16,64,256", None),
    "caustic_vcm": ("scenes/caustic/caustic.xml", "192x144", ["float:radius=0.04"], "16,64,256",
                    (0.04, 0.5, 512)),
    "sds_vcm": ("scenes/sds/sds.xml", "192x144", ["float:radius=0.04"], "16,64,256",
                (0.04, 0.5, 256)),
}
VCM_ALPHA = 0.75
VOLUME_REFERENCES = {"cbox_vcm": "cbox", "caustic_vcm": "caustic", "sds_vcm": "sds",
                     "medium_sphere_scatter_r0.2": "medium_sphere_scatter", "cbox_knn": "cbox",
                     "spotlight_fog_r0.4": "spotlight_fog", "spotlight_fog_knn": "spotlight_fog"}
# --order: scene, size, parameters and passes; the radii named are divided by sqrt 2 in the
# second render (none named: volumeK divided by 2^(3/2)). Large first radii, so that the bias
# stands out of the noise at once; sigmaT r, the first volume radius in mean free paths, is
# where a medium's boundaries lower the order (docs/error-estimate.md).
ORDER_SCENES = {
    "medium_sphere_scatter: volume radius 0.3 (sigmaT r = 3)": (
        "scenes/seed/medium_sphere_scatter.xml", "60x45",
        ["int:photonCount=20000", "bool:progressive=true", "float:surfacePhotonRadius=0.02",
         "float:volumePhotonRadius=0.3", "string:directLight=nee"], ["volumePhotonRadius"], 64),
    "farm_vpm: volume radius 0.5 (sigmaT r = 0.6)": (
        "tests/integration/scenes/farm_vpm.xml", "64x48",
        ["int:photonCount=20000", "bool:progressive=true", "float:surfacePhotonRadius=0.02",
         "float:volumePhotonRadius=0.5", "string:directLight=nee"], ["volumePhotonRadius"], 64),
    "spotlight_fog: volume radius 0.4 (sigmaT r = 0.05)": (
        "scenes/seed/spotlight_fog.xml", "80x45",
        ["int:photonCount=20000", "bool:progressive=true", "float:surfacePhotonRadius=0.02",
         "float:volumePhotonRadius=0.4", "string:directLight=nee"], ["volumePhotonRadius"], 64),
    "spotlight_fog: volume kNN k = 40 (k = 14)": (
        "scenes/seed/spotlight_fog.xml", "80x45",
        ["int:photonCount=20000", "bool:progressive=true", "float:surfacePhotonRadius=0.02",
         "int:volumeK=40", "float:volumePhotonRadius=2", "string:directLight=nee"],
        [], 64),
}


def render(tool, path, size, integrator, params, passes, seed=1, reference=None, crop=None):
    command = [tool, "render", os.path.join(ROOT, path), "--size", size, "--integrator",
               integrator, "--seed", str(seed), "--passes", passes]
    if reference:
        command += ["--reference", reference]
    if crop:
        command += ["--crop", crop]
    for p in params:
        command += ["--set", p]
    return list(csv.DictReader(subprocess.run(command, check=True, capture_output=True,
                                              text=True).stdout.splitlines()))


def reference_noise(tool, references, name):
    halves = [os.path.join(references, "%s_ref_%d.exr" % (name, i)) for i in (0, 1)]
    between = float(subprocess.run([tool, "compare"] + halves, check=True,
                                   capture_output=True, text=True).stdout)
    return between / 2.0


def film_rows(tool, references, names):
    print("| scene | passes | truth | noise est. | bias two radii | seen | truth / noise | "
          "truth / (noise + two radii) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for name in names:
        seen_reference = None
        if name in VCM_SCENES:
            path, size, params, ladder, seen_reference = VCM_SCENES[name]
            integrator = "vcm"
        else:
            path, size, params, ladder = VOLUME_SCENES.get(name) or KNN_SCENES[name]
            integrator = "volumetric_photonmapper" if name in VOLUME_SCENES else "photonmapper"
        ref_name = VOLUME_REFERENCES.get(name, name)
        ref_noise = reference_noise(tool, references, ref_name)
        for r in render(tool, path, size, integrator, params, ladder,
                        reference=os.path.join(references, ref_name + "_ref.exr")):
            measured = float(r["relative_rmse"])
            truth = math.sqrt(max(0.0, measured ** 2 - ref_noise ** 2))
            noise = float(r["predicted_noise"])
            two = float(r["film_bias_two_radii"] or 0)
            seen = 1.0
            if seen_reference:
                ref_radius, ref_alpha, ref_passes = seen_reference
                radius = float(next(p for p in params if p.startswith("float:radius="))[13:])
                seen = 1.0 - (ref_radius ** 2 * mean_radius_squared(ref_passes, ref_alpha)) / (
                    radius ** 2 * mean_radius_squared(int(r["passes"]), VCM_ALPHA))
            print("| %s | %s | %.4f | %.4f | %.4f | %.2f | %.2f | %.2f |" % (
                name, r["passes"], truth, noise, two, seen, truth / noise,
                truth / math.hypot(noise, seen * two)), flush=True)
        print("(%s: reference noise %.4f)" % (name, ref_noise), flush=True)


def order_rows(tool, names):
    """For volume kNN radii (no radius parameter to divide) the second render's k is the
    first's divided by 2^(3/2): a volume photon's k-th neighbour in a locally uniform density
    lies at a distance proportional to k^(1/3), which then falls by sqrt 2."""
    print("| probe | passes | two-radii bias at r | at r / sqrt 2 | ratio | order p |")
    print("|---|---:|---:|---:|---:|---:|")
    for name in names:
        path, size, params, radii, passes = ORDER_SCENES[name]
        smaller = []
        for p in params:
            key, value = p.split("=")
            if key.startswith("float:") and key[6:] in radii:
                smaller.append("%s=%.9g" % (key, float(value) / math.sqrt(2.0)))
            elif not radii and key == "int:volumeK":
                smaller.append("%s=%d" % (key, round(int(value) / 2 ** 1.5)))
            else:
                smaller.append(p)
        first = render(tool, path, size, "volumetric_photonmapper", params, str(passes))[-1]
        second = render(tool, path, size, "volumetric_photonmapper", smaller, str(passes))[-1]
        b1, b2 = float(first["film_bias_two_radii"]), float(second["film_bias_two_radii"])
        if b1 > 0 and b2 > 0:
            ratio = b2 / b1
            print("| %s | %d | %.4f | %.4f | %.3f | %.2f |" % (
                name, passes, b1, b2, ratio, -2.0 * math.log2(ratio)), flush=True)
        else:  # a difference within its own noise: no order to measure
            print("| %s | %d | %.4f | %.4f | n/a | n/a |" % (name, passes, b1, b2), flush=True)


def radius_squared_ratio(n, alpha):
    """r^2(n) / r^2(1), passes counted from 1 (the product form of radius_schedule.h)."""
    ratio = 1.0
    for k in range(1, n):
        ratio *= (k + alpha) / (k + 1)
    return ratio


def mean_radius_squared(n, alpha):
    return sum(radius_squared_ratio(k, alpha) for k in range(1, n + 1)) / n


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("references", nargs="?")
    parser.add_argument("--build", default=os.path.join(ROOT, "build"))
    parser.add_argument("--scenes", help="comma-separated names (default: all of the mode's)")
    parser.add_argument("--order", action="store_true", help="measure the bias's order p")
    args = parser.parse_args()
    tool = os.path.join(args.build, "bench", "bench_atlas_render")
    chosen = args.scenes.split(",") if args.scenes else None
    known = list(ORDER_SCENES) if args.order else list(SCENES) + list(VOLUME_SCENES) + list(
        KNN_SCENES) + list(VCM_SCENES)
    for name in chosen or []:
        if name not in known:
            parser.error("unknown scene %s; the probes cover %s" % (name, ", ".join(known)))
    if args.order:
        order_rows(tool, chosen or list(ORDER_SCENES))
        return
    if not args.references:
        parser.error("REFERENCE_DIR is needed (except with --order)")
    surface = [n for n in SCENES if chosen is None or n in chosen]
    film = [n for n in list(VOLUME_SCENES) + list(KNN_SCENES) + list(VCM_SCENES)
            if chosen is None or n in chosen]
    if film:
        film_rows(tool, args.references, film)
    if not surface:
        return
    print("| scene | passes | truth | noise est. | bias temporal | bias two radii | "
          "truth / noise | truth / (noise + temporal) | truth / (noise + two radii) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name in surface:
        path, size, crop, integrator, params, probes, ladder, ref_passes = SCENES[name]
        ref = os.path.join(args.references, name + "_ref.exr")
        halves = [os.path.join(args.references, "%s_ref_%d.exr" % (name, i)) for i in (0, 1)]
        between = float(subprocess.run([tool, "compare"] + halves, check=True,
                                       capture_output=True, text=True).stdout)
        ref_noise = between / 2.0
        command = [tool, "render", os.path.join(ROOT, path), "--size", size, "--integrator",
                   integrator, "--seed", "1", "--passes", ladder, "--reference", ref,
                   "--bias-probes", probes]
        if crop:
            command += ["--crop", crop]
        for p in params:
            command += ["--set", p]
        rows = csv.DictReader(subprocess.run(command, check=True, capture_output=True,
                                             text=True).stdout.splitlines())
        for r in rows:
            n = int(r["passes"])
            measured = float(r["relative_rmse"])
            truth = math.sqrt(max(0.0, measured ** 2 - ref_noise ** 2))
            # The film of a progressive photon mapper keeps the smaller radius: its predicted
            # error holds the two-radii bias, its noise is printed apart.
            noise = float(r["predicted_noise"] or r["predicted_relative_rmse"])
            seen = 1.0
            if ref_passes:
                seen = 1.0 - mean_radius_squared(ref_passes, 0.5) / mean_radius_squared(n, 0.5)
            temporal = float(r["predicted_bias_temporal"] or 0)
            two = float(r["predicted_bias_two_radii"] or 0)
            print("| %s | %d | %.4f | %.4f | %.4f | %.4f | %.2f | %.2f | %.2f |" % (
                name, n, truth, noise, temporal, two, truth / noise,
                truth / math.hypot(noise, seen * temporal), truth / math.hypot(noise, seen * two)))


if __name__ == "__main__":
    main()
