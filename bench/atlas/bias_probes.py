#!/usr/bin/python3
"""The two bias estimates of common/render/error_estimate.h against the atlas's truth, on the
progressive photon mappers' series of cbox, caustic, sds and stage_crop.

    /usr/bin/python3 bench/atlas/bias_probes.py REFERENCE_DIR [--build build] [--scenes a,b]

REFERENCE_DIR holds the atlas's references (SCENE_ref.exr and its halves SCENE_ref_0.exr,
SCENE_ref_1.exr, as run_atlas.py writes them). For every scene it runs bench_atlas_render with
--bias-probes and prints one table row per pass count: the true error (the reference's own noise
taken out in quadrature), the noise-only estimate and each bias estimate, and truth / prediction
for noise only, noise + temporal bias and noise + two-radii bias.

Where the reference is itself a progressive photon map (caustic, sds, and stage_crop, whose pin
spot reaches the crop only through the disco ball's mirror facets, which path tracing cannot
follow to a delta light) it shares the bias left at its own pass count: against it only the
part of the bias that falls between n passes and the reference's N is measurable,
B(n) - B(N) = B(n) (1 - mean_{i<N} r_i^2 / mean_{i<n} r_i^2). The predictions are compared with
the truth after that correction (column "seen").
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
    parser.add_argument("references")
    parser.add_argument("--build", default=os.path.join(ROOT, "build"))
    parser.add_argument("--scenes", default="", help="comma-separated subset of the scenes")
    args = parser.parse_args()
    names = args.scenes.split(",") if args.scenes else list(SCENES)
    for name in names:
        if name not in SCENES:
            parser.error("unknown scene %s; the probes cover %s" % (name, ", ".join(SCENES)))
    tool = os.path.join(args.build, "bench", "bench_atlas_render")
    print("| scene | passes | truth | noise est. | bias temporal | bias two radii | "
          "truth / noise | truth / (noise + temporal) | truth / (noise + two radii) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name in names:
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
            noise = float(r["predicted_relative_rmse"])
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
