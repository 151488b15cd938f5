#!/usr/bin/python3
"""The speed-vs-accuracy atlas: every applicable integrator on every atlas scene, relative RMSE
against a long reference at a ladder of pass counts, against CPU and wall time.

    /usr/bin/python3 bench/atlas/run_atlas.py [--build build] [--out bench/results/atlas]
                                              [--scenes cbox,caustic,...] [--quick --check]

Writes into --out: atlas.csv (one row per render), references.csv (each scene's reference and
its own noise), slopes.csv (fitted and theoretical slope per series), summary.md (the tables of
docs/accuracy.md) and one chart per scene, SCENE.png. --quick runs a seconds-long slice (the
Cornell box at 32 x 32: path_mis, the progressive photon mapper, bdpt and vcm) and --check then
asserts that the pipeline worked: every series present, errors finite and falling, predicted
errors filled, charts written (the CTest entry bench.atlas_slice).

Run it with Debian's /usr/bin/python3, which has matplotlib (tools/install-deps.sh).
"""
import argparse
import csv
import math
import os
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import FuncFormatter, LogLocator  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# Seeds: every series renders with SERIES_SEED, the two halves of a reference with the other two,
# so a reference never shares random numbers with what it measures.
SERIES_SEED = 1
REFERENCE_SEEDS = (1001, 1002)



def label_log_ticks(ax):
    """Tick values at 1, 2 and 5 of every decade on both log axes, so that a curve spanning less
    than a decade still has numbers beside it."""
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(LogLocator(base=10))
        axis.set_minor_locator(LogLocator(base=10, subs=(2, 5)))
        axis.set_major_formatter(FuncFormatter(lambda value, _: "%g" % value))
        axis.set_minor_formatter(FuncFormatter(lambda value, _: "%g" % value))

def progressive_slope(alpha):
    """The Knaus-Zwicker rate of relative RMSE against passes N (and time, each pass costing the
    same). Pass i gathers within r_i with r_i^2 ~ i^(alpha-1); a 2D kernel (surface gathers and
    the beam estimate through volume photons) has variance ~ 1/r_i^2 ~ i^(1-alpha), so the mean of
    N passes has variance ~ N^(-alpha) and bias ~ mean r_i^2 ~ N^(alpha-1). RMSE^2 ~ a N^(-alpha) +
    b N^(2 alpha - 2): the slope tends to -min(alpha/2, 1-alpha), -1/4 at alpha = 1/2."""
    return -min(alpha / 2.0, 1.0 - alpha)


def series(label, integrator, params, theory, why):
    """One curve of a chart: `params` are bench_atlas_render --set values; `theory` the slope
    expected at long times; `why` says where the expectation comes from."""
    return dict(label=label, integrator=integrator, params=params, theory=theory, why=why)


MC = "Monte Carlo, unbiased"
BIASED = "one photon map for all passes: converges to a biased image"


def surface_series(photons, radius, k, alpha=0.5, delta_lights=False, path_mis_theory=-0.5,
                   path_mis_why=MC):
    """path_mats, path_mis and the photon mapper fixed-radius, kNN and progressive, with the
    scene's photon count and radius. path_mats is left out where a delta light shines (it cannot
    reach one: the image would miss that light at any number of passes)."""
    common = ["int:photonCount=%d" % photons]
    out = []
    if not delta_lights:
        out.append(series("path_mats", "path_mats", [], -0.5, MC))
    out += [
        series("path_mis", "path_mis", [], path_mis_theory, path_mis_why),
        series("photonmapper fixed r=%g" % radius, "photonmapper",
               common + ["float:surfacePhotonRadius=%g" % radius], 0.0, BIASED),
        series("photonmapper kNN k=%d" % k, "photonmapper",
               common + ["int:surfaceK=%d" % k], 0.0, BIASED),
        series("photonmapper progressive r=%g a=%g" % (radius, alpha), "photonmapper",
               common + ["float:surfacePhotonRadius=%g" % radius, "bool:progressive=true",
                         "float:alpha=%g" % alpha], progressive_slope(alpha),
               "Knaus-Zwicker, alpha %g" % alpha),
    ]
    return out


def volume_series(photons, surface_radius, volume_radius, k, alpha=0.5, delta_lights=False,
                  progressive_volume_k=None, volume_path_mis_theory=-0.5,
                  volume_path_mis_why=MC):
    """volume_path_mats, volume_path_mis and the volumetric photon mapper fixed-radius, kNN and
    progressive (the progressive one as the scene's own _vpm file configures it: kNN volume radii
    where it uses them)."""
    common = ["int:photonCount=%d" % photons]
    out = []
    if not delta_lights:
        out.append(series("volume_path_mats", "volume_path_mats", [], -0.5, MC))
    progressive = common + ["float:surfacePhotonRadius=%g" % surface_radius,
                            "bool:progressive=true", "float:alpha=%g" % alpha]
    if progressive_volume_k:
        progressive.append("int:volumeK=%d" % progressive_volume_k)
        progressive_label = "vpm progressive r=%g k=%d a=%g" % (surface_radius,
                                                                progressive_volume_k, alpha)
    else:
        progressive.append("float:volumePhotonRadius=%g" % volume_radius)
        progressive_label = "vpm progressive r=%g/%g a=%g" % (surface_radius, volume_radius, alpha)
    out += [
        series("volume_path_mis", "volume_path_mis", [], volume_path_mis_theory,
               volume_path_mis_why),
        series("vpm fixed r=%g/%g" % (surface_radius, volume_radius), "volumetric_photonmapper",
               common + ["float:surfacePhotonRadius=%g" % surface_radius,
                         "float:volumePhotonRadius=%g" % volume_radius], 0.0, BIASED),
        series("vpm kNN k=%d" % k, "volumetric_photonmapper",
               common + ["int:surfaceK=%d" % k, "int:volumeK=%d" % k], 0.0, BIASED),
        series(progressive_label, "volumetric_photonmapper", progressive,
               progressive_slope(alpha), "Knaus-Zwicker, alpha %g" % alpha),
    ]
    # A volumetric photon pass costs several camera passes: twice the budget gives these series
    # enough points to fit a slope.
    for s in out[-3:]:
        s["budget_factor"] = 2
    return out


def bidirectional_series(vcm_params=(), merging_only_paths=False):
    """bdpt and vcm (surfaces only), each with twice the budget: a pass costs about 4x a
    path_mis pass, and the doubled budget gives their ladders enough points to fit a slope.
    vcm runs with its defaults (merge radius: scene diagonal / 500, alpha 0.75) unless the scene
    has its own vcm variant. `merging_only_paths`: the scene has light that only merging reaches
    (a point light's caustic seen through glass), which bdpt misses at any time and vcm gathers
    at the Knaus-Zwicker rate; elsewhere vcm's merging weight shrinks with the radius and both
    converge as Monte Carlo does."""
    vcm_label = "vcm" + "".join(" " + p.split(":")[1] for p in vcm_params)
    if merging_only_paths:
        bdpt_theory, bdpt_why = 0.0, "misses light only merging reaches (point light through glass)"
        vcm_theory, vcm_why = progressive_slope(0.75), "Knaus-Zwicker, alpha 0.75 (merged paths)"
    else:
        bdpt_theory, bdpt_why = -0.5, MC
        vcm_theory, vcm_why = -0.5, "merging's weight vanishes as the radius shrinks: Monte Carlo"
    out = [series("bdpt", "bdpt", [], bdpt_theory, bdpt_why),
           series(vcm_label, "vcm", list(vcm_params), vcm_theory, vcm_why)]
    for s in out:
        s["budget_factor"] = 2
    return out


PPM_CAUSTIC = ("photonmapper", ["int:photonCount=200000", "float:surfacePhotonRadius=0.04",
                                "bool:progressive=true", "float:alpha=0.5"])

# The stage's own photon mapper (stage.xml): progressive, 200 000 photon paths per pass, radii
# 0.04 on surfaces and 0.1 in the fog.
VPM_STAGE = ("volumetric_photonmapper", ["int:photonCount=200000",
                                         "float:surfacePhotonRadius=0.04",
                                         "float:volumePhotonRadius=0.1", "bool:progressive=true",
                                         "float:alpha=0.5"])

# Each scene: the file, the image size (--size) or crop, the reference (integrator and
# parameters; its two halves render with REFERENCE_SEEDS) and the series. Photon counts and radii
# are the scenes' own (their _ppm/_vpm files) where they have them.
SCENES = {
    "cbox": dict(
        title="Cornell box (mirror and glass spheres), 128 x 128",
        path="scenes/cbox/cbox.xml", size="128x128",
        reference=("path_mis", []),
        series=surface_series(100000, 0.05, 50) +
        # cbox_vcm.xml's merge radius.
        bidirectional_series(["float:radius=0.01"])),
    "cbox_glossy": dict(
        title="Glossy Cornell box (glossy floor, near-specular and rough spheres), 128 x 128",
        path="scenes/cbox/cbox_glossy.xml", size="128x128",
        reference=("path_mis", []),
        series=surface_series(100000, 0.05, 50) + bidirectional_series()),
    "caustic": dict(
        title="Caustic of a glass sphere under a small area light, 192 x 144",
        path="scenes/caustic/caustic.xml", size="192x144",
        # The caustic is bright against the mean and the reference's noise falls only as
        # N^(-1/4) (progressive, alpha 1/2): it needs a longer run than the others.
        reference=PPM_CAUSTIC, reference_budget_factor=4,
        series=surface_series(200000, 0.04, 50) + bidirectional_series()),
    "sds": dict(
        title="Specular-diffuse-specular: point-light caustic seen through glass, 192 x 144",
        path="scenes/sds/sds.xml", size="192x144",
        # Twice the budget keeps the reference at 256 passes per half since its photon-mapped
        # passes became dearer (about 2.2 path_mis passes each, from 1.6, in the 2026-12-02 runs).
        reference=PPM_CAUSTIC, reference_budget_factor=2,
        series=surface_series(100000, 0.04, 50, delta_lights=True, path_mis_theory=0.0,
                              path_mis_why="cannot connect a diffuse vertex to a point light "
                                           "through glass: misses the caustic") +
        bidirectional_series(merging_only_paths=True)),
    "veach": dict(
        title="Veach's MIS scene (glossy plates, four lights, a point light), 192 x 128",
        path="scenes/veach/veach_mis.xml", size="192x128",
        reference=("path_mis", []),
        series=surface_series(100000, 0.05, 50, delta_lights=True) + bidirectional_series()),
    "spotlight_fog": dict(
        title="Spotlight in homogeneous fog, 160 x 90",
        path="scenes/seed/spotlight_fog.xml", size="160x90",
        reference=("volume_path_mis", []),
        series=volume_series(100000, 0.1, 0.1, 10, delta_lights=True, progressive_volume_k=10)),
    "projector_fog": dict(
        title="Checkerboard projector in heterogeneous (Perlin) fog, 160 x 90",
        path="scenes/seed/projector_fog.xml", size="160x90",
        # Delta lights in textured fog: volume_path_mis needs a longer run for a usable reference.
        reference=("volume_path_mis", []), reference_budget_factor=4,
        series=volume_series(100000, 0.1, 0.1, 10, delta_lights=True, progressive_volume_k=10)),
    "medium_sphere_scatter": dict(
        title="Scattering medium sphere (sigmaS 10, isotropic) under an area light, 120 x 90",
        path="scenes/seed/medium_sphere_scatter.xml", size="120x90",
        reference=("volume_path_mis", []),
        series=volume_series(100000, 0.05, 0.05, 10)),
    "medium_sphere_chromatic_hg": dict(
        title="Chromatic medium sphere, Henyey-Greenstein phase, 120 x 90",
        path="scenes/seed/medium_sphere_chromatic_hg.xml", size="120x90",
        reference=("volume_path_mis", []),
        series=volume_series(100000, 0.05, 0.05, 10)),
    "medium_sphere_heterogeneous": dict(
        title="Heterogeneous (exponential density) medium sphere, 120 x 90",
        path="scenes/seed/medium_sphere_heterogeneous_exponential.xml", size="120x90",
        reference=("volume_path_mis", []),
        series=volume_series(100000, 0.05, 0.05, 10)),
    "stage_crop": dict(
        title="Stage: crop 160 x 120 of the 480 x 270 image (spotlights, projectors, fog)",
        path="scenes/stage/stage.xml", size="480x270", crop="160,60,320,180",
        # The pin spot lights nothing but the disco ball's mirror facets, which throw its light
        # onto the back wall (sparkles) and through the fog (beams): light from a delta light
        # after a specular bounce, which no path from the camera can reach (the next-event
        # estimate cannot aim through a mirror, and a mirror-reflected ray never hits a point).
        # volume_path_mis converges to the stage without that light, a quarter of the crop's
        # mean luminance; only photons carry it, so the reference is the stage's own progressive
        # photon mapper.
        reference=VPM_STAGE, reference_budget_factor=4,
        series=volume_series(200000, 0.04, 0.1, 10, delta_lights=True, volume_path_mis_theory=0.0,
                             volume_path_mis_why="cannot reach a delta light through a mirror: "
                                                 "misses the disco ball's reflections")),
}

QUICK_SCENES = {
    "cbox_quick": dict(
        title="Cornell box, 32 x 32 (the seconds-long slice of the test)",
        path="scenes/cbox/cbox.xml", size="32x32",
        reference=("path_mis", []),
        series=[s for s in surface_series(20000, 0.05, 50)
                if s["label"] == "path_mis" or s["label"].startswith("photonmapper progressive")] +
        bidirectional_series(["float:radius=0.01"])),
}

CSV_FIELDS = ["scene", "integrator", "passes", "wall_seconds", "cpu_seconds", "relative_rmse",
              "reference_noise", "predicted_relative_rmse"]


def run_helper(tool, scene, args):
    command = [tool, "render", os.path.join(ROOT, scene["path"]), "--size", scene["size"]]
    if scene.get("crop"):
        command += ["--crop", scene["crop"]]
    command += args
    print("  $ " + " ".join(os.path.relpath(c, ROOT) if c.startswith(ROOT) else c
                            for c in command), flush=True)
    output = subprocess.run(command, check=True, capture_output=True, text=True).stdout
    return list(csv.DictReader(output.splitlines()))


def integrator_args(integrator, params):
    args = ["--integrator", integrator]
    for p in params:
        args += ["--set", p]
    return args


def make_reference(tool, name, scene, work, cpu_budget):
    """Two independent halves; the reference is their mean. Its own relative RMSE is half the
    relative RMSE between the halves (each half has variance s^2, their difference 2 s^2, their
    mean s^2 / 2). This measures the reference's noise, not the bias of a photon-mapped one."""
    integrator, params = scene["reference"]
    half_a, half_b = (os.path.join(work, "%s_ref_%d.exr" % (name, i)) for i in (0, 1))
    ladder = ",".join(str(2 ** i) for i in range(1, 17))
    rows_a = run_helper(tool, scene, integrator_args(integrator, params) + [
        "--seed", str(REFERENCE_SEEDS[0]), "--passes", ladder, "--cpu-budget", str(cpu_budget),
        "--write-exr", half_a])
    passes = rows_a[-1]["passes"]
    rows_b = run_helper(tool, scene, integrator_args(integrator, params) + [
        "--seed", str(REFERENCE_SEEDS[1]), "--passes", passes, "--write-exr", half_b])
    reference = os.path.join(work, "%s_ref.exr" % name)
    subprocess.run([tool, "average", half_a, half_b, reference], check=True)
    between = float(subprocess.run([tool, "compare", half_a, half_b], check=True,
                                   capture_output=True, text=True).stdout)
    return reference, dict(scene=name, reference_integrator=integrator,
                           reference_parameters=" ".join(params),
                           passes_per_half=int(passes),
                           cpu_seconds=float(rows_a[-1]["cpu_seconds"]) +
                           float(rows_b[-1]["cpu_seconds"]),
                           relative_noise=between / 2.0)


def fit_slope(rows, noise):
    """Least-squares slope of log(error) against log(CPU seconds), over the points whose error is
    at least twice the reference's noise (below that the reference's own noise flattens the
    curve) and the measured error with that noise taken out in quadrature. The 1-pass render is
    left out: as the first of its process it also pays one-time set-up (the thread pool, lazily
    built structures), which can make it slower than the 2-pass one."""
    points = []
    for r in rows[1:]:
        error = float(r["relative_rmse"])
        if error >= 2 * noise and float(r["cpu_seconds"]) > 0:
            corrected = math.sqrt(error * error - noise * noise)
            points.append((math.log(float(r["cpu_seconds"])), math.log(corrected)))
    if len(points) < 3:
        return float("nan")
    mx = sum(p[0] for p in points) / len(points)
    my = sum(p[1] for p in points) / len(points)
    sxx = sum((p[0] - mx) ** 2 for p in points)
    sxy = sum((p[0] - mx) * (p[1] - my) for p in points)
    return sxy / sxx


def error_at(rows, cpu_seconds):
    """The error at a given CPU time, interpolated log-log between the ladder's points (None
    outside the measured range)."""
    pts = [(float(r["cpu_seconds"]), float(r["relative_rmse"])) for r in rows]
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if t0 <= cpu_seconds <= t1 and t0 > 0:
            f = (math.log(cpu_seconds) - math.log(t0)) / (math.log(t1) - math.log(t0))
            return math.exp(math.log(e0) + f * (math.log(e1) - math.log(e0)))
    return None


def equal_time(rows_by_label):
    """The CPU time every series reached (the smallest of their last times) and each series'
    error there."""
    common = min(float(rows[-1]["cpu_seconds"]) for rows in rows_by_label.values())
    return common, {label: error_at(rows, common) for label, rows in rows_by_label.items()}


def chart(path, name, scene, rows_by_label, series_by_label, slopes, reference):
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.2), sharey=True)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, key, xlabel in ((axes[0], "cpu_seconds", "CPU time (seconds, all threads)"),
                            (axes[1], "wall_seconds", "wall time (seconds, 2 cores, shared)")):
        any_predicted = False
        for i, (label, rows) in enumerate(rows_by_label.items()):
            colour = colours[i % len(colours)]
            x = [float(r[key]) for r in rows]
            y = [float(r["relative_rmse"]) for r in rows]
            s = series_by_label[label]
            theory = "%.2f" % s["theory"] if s["theory"] else "0: biased limit"
            fitted = "n/a" if math.isnan(slopes[label]) else "%.2f" % slopes[label]
            legend = "%s: slope %s (theory %s)" % (label, fitted, theory)
            ax.loglog(x, y, "o-", color=colour, label=legend, markersize=4)
            # The film's own error estimate, drawn beside the truth once it fills the column.
            predicted = [(float(r[key]), float(r["predicted_relative_rmse"])) for r in rows
                         if r.get("predicted_relative_rmse")]
            if predicted:
                ax.loglog([p[0] for p in predicted], [p[1] for p in predicted], ":",
                          color=colour, linewidth=1.5)
                any_predicted = True
        ax.axhline(reference["relative_noise"], color="grey", linestyle="--",
                   label="reference's own noise (%.3g)" % reference["relative_noise"])
        if any_predicted:
            # One legend entry for all the dotted lines: a second entry per series would double
            # a legend that already names every series.
            ax.plot([], [], ":", color="black", linewidth=1.5,
                    label="dotted, same colour: the film's own predicted error")
        ax.set_xlabel(xlabel)
        label_log_ticks(ax)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("relative RMSE of luminance (RMSE / mean)")
    axes[0].legend(fontsize=7, loc="lower left")
    fig.suptitle("%s\nrelative RMSE against a %s reference (%d + %d passes), ladder of pass "
                 "counts 1, 2, 4, ..." % (scene["title"], reference["reference_integrator"],
                                          reference["passes_per_half"],
                                          reference["passes_per_half"]), fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def without_noise(error, noise):
    """The error with the reference's own noise taken out in quadrature (its expectation adds
    noise^2 to the squared error of any series); None where the noise explains all of it."""
    return math.sqrt(error * error - noise * noise) if error > noise else None


def fmt(value, pattern="%.4f"):
    return pattern % value if value is not None else "n/a"


def summary(scenes, results, references, slopes_rows):
    lines = ["| scene | integrator | passes | CPU s | wall s | error at the last pass | "
             "error at equal CPU time | fitted slope | theory |",
             "|---|---|---|---|---|---|---|---|---|"]
    best = []
    for name in scenes:
        rows_by_label = results[name]
        noise = references[name]["relative_noise"]
        common, at_common = equal_time(rows_by_label)
        ranked = sorted((e, label) for label, e in at_common.items() if e is not None)
        for label, rows in rows_by_label.items():
            slope = next(s for s in slopes_rows if s["scene"] == name and s["integrator"] == label)
            last = rows[-1]
            fitted = slope["fitted_slope"]
            lines.append("| %s | %s | %s | %.2f | %.2f | %.4f | %s | %s | %s |" % (
                name, label, last["passes"], float(last["cpu_seconds"]),
                float(last["wall_seconds"]), float(last["relative_rmse"]),
                fmt(at_common[label]), "n/a" if math.isnan(fitted) else "%.2f" % fitted,
                "%.2f" % slope["theory_slope"] if slope["theory_slope"] else "0 (biased)"))
        if ranked:
            runner = ranked[1] if len(ranked) > 1 else (None, "")
            best.append("| %s | %.3g s | %s | %.4f (%s) | %s | %s (%s) | %.3g |" % (
                name, common, ranked[0][1], ranked[0][0], fmt(without_noise(ranked[0][0], noise)),
                runner[1], fmt(runner[0]), fmt(without_noise(runner[0], noise))
                if runner[0] is not None else "", noise))
    table = ["| scene | equal CPU time | best there | its error (reference noise removed) | "
             "runner-up | its error (noise removed) | reference noise |",
             "|---|---|---|---|---|---|---|"] + best
    return ("\n".join(table) + "\n\n" + "\n".join(lines) + "\n\n" +
            vcm_comparison(scenes, results, references) + "\n" +
            prediction_table(scenes, results, references, slopes_rows))


# The goals of vcm's equal-time comparison: on every scene within this factor of the best of
# bdpt, path_mis and the progressive photon mapper; on the Cornell box with its glass sphere at
# most this fraction of the better of path_mis and the progressive photon mapper.
VCM_WITHIN_BEST = 1.25
VCM_CBOX_FRACTION = 0.5


def vcm_comparison(scenes, results, references):
    """vcm against bdpt, path_mis and the progressive photon mapper at the CPU time all four
    reached, on every scene that has a vcm series."""
    lines = ["| scene | equal CPU time | vcm | bdpt | path_mis | progressive photon mapper | "
             "best other | vcm / best other (noise removed) | within %g x |" % VCM_WITHIN_BEST,
             "|---|---|---|---|---|---|---|---|---|"]
    cbox_lines = []
    for name in scenes:
        by_label = results[name]
        vcm = next((l for l in by_label if l.startswith("vcm")), None)
        ppm = next((l for l in by_label if l.startswith("photonmapper progressive")), None)
        if not vcm or "bdpt" not in by_label or "path_mis" not in by_label or not ppm:
            continue
        noise = references[name]["relative_noise"]
        compared = {"vcm": vcm, "bdpt": "bdpt", "path_mis": "path_mis", "ppm": ppm}
        common, at = equal_time({key: by_label[label] for key, label in compared.items()})
        clean = {key: without_noise(e, noise) if e is not None else None for key, e in at.items()}
        others = [(at[k], k) for k in ("bdpt", "path_mis", "ppm") if at[k] is not None]
        best_error, best_key = min(others)
        ratio = at["vcm"] / best_error
        clean_ratio = (clean["vcm"] / clean[best_key]
                       if clean["vcm"] is not None and clean[best_key] else None)
        names = {"bdpt": "bdpt", "path_mis": "path_mis", "ppm": "progressive PM"}
        cell = lambda k: "%s (%s)" % (fmt(at[k]), fmt(clean[k]))  # noqa: E731
        lines.append("| %s | %.3g s | %s | %s | %s | %s | %s | %.2f (%s) | %s |" % (
            name, common, cell("vcm"), cell("bdpt"), cell("path_mis"), cell("ppm"),
            names[best_key], ratio, fmt(clean_ratio, "%.2f"),
            "yes" if ratio <= VCM_WITHIN_BEST else "**no**"))
        if name == "cbox":
            better = min(at["path_mis"], at["ppm"])
            cbox_lines.append(
                "Cornell box with its glass sphere: vcm / better of path_mis and the progressive "
                "photon mapper = %.4f / %.4f = %.2f (goal at most %g: %s)." % (
                    at["vcm"], better, at["vcm"] / better, VCM_CBOX_FRACTION,
                    "met" if at["vcm"] / better <= VCM_CBOX_FRACTION else "**not met**"))
    if len(lines) == 2:
        return ""
    return ("vcm at equal CPU time (relative RMSE; in brackets with the reference's noise removed; "
            "the time is the smallest of the four series' last CPU times):\n\n" +
            "\n".join(lines) + "\n\n" + "\n".join(cbox_lines) + "\n")


UNBIASED = ("path_mats", "path_mis", "volume_path_mats", "volume_path_mis", "bdpt")


def prediction_table(scenes, results, references, slopes_rows):
    """The film's predicted relative RMSE against the true one (the measured error with the
    reference's noise taken out in quadrature), over the renders of 2 passes or more whose error
    is at least twice the reference's noise. Unbiased series are held to +-25%; for the others
    the estimate sees the noise only, and the table gives the factor it reaches."""
    lines = ["| scene | integrator | kind | points | predicted / true: median | range | "
             "at the last pass | verdict |",
             "|---|---|---|---|---|---|---|---|"]
    for name in scenes:
        noise = references[name]["relative_noise"]
        for label, rows in results[name].items():
            ratios, has_prediction = [], any(r.get("predicted_relative_rmse") for r in rows)
            for r in rows:
                if not r.get("predicted_relative_rmse"):
                    continue
                error = float(r["relative_rmse"])
                if error < 2 * noise:
                    continue
                ratios.append(float(r["predicted_relative_rmse"]) / without_noise(error, noise))
            theory = next(s["theory_slope"] for s in slopes_rows
                          if s["scene"] == name and s["integrator"] == label)
            unbiased = label in UNBIASED and theory != 0.0
            kind = "unbiased" if unbiased else "biased: noise-only estimate"
            if not ratios:
                lines.append("| %s | %s | %s | 0 | n/a | n/a | n/a | %s |" % (
                    name, label, kind, "no point above twice the reference's noise"
                    if has_prediction else "no prediction in the CSV (a run before the estimate)"))
                continue
            ordered = sorted(ratios)
            median = (ordered[len(ordered) // 2] if len(ordered) % 2 else
                      0.5 * (ordered[len(ordered) // 2 - 1] + ordered[len(ordered) // 2]))
            if unbiased:
                verdict = ("within +-25%" if all(0.75 <= q <= 1.25 for q in ratios) else
                           "**outside +-25%**")
            else:
                verdict = "truth = %.2f x predicted at the last pass" % (1.0 / ratios[-1])
            lines.append("| %s | %s | %s | %d | %.2f | %.2f-%.2f | %.2f | %s |" % (
                name, label, kind, len(ratios), median, ordered[0], ordered[-1], ratios[-1],
                verdict))
    return ("The film's predicted error against the truth:\n\n" + "\n".join(lines) + "\n")


def check(out, catalogue, scenes, results):
    """The test's assertions: every series of the catalogue has rows (a series whose renders
    failed is missing), finite positive errors, the error at the last point below 0.7 times the
    first (every atlas series falls from pass 1), CPU time growing with passes, a predicted
    error from 2 passes on, and every chart exists."""
    problems = []
    for name in scenes:
        chart_path = os.path.join(out, name + ".png")
        if not (os.path.exists(chart_path) and os.path.getsize(chart_path) > 0):
            problems.append("%s: no chart" % name)
        for s in catalogue[name]["series"]:
            if s["label"] not in results[name]:
                problems.append("%s %s: no rows (its renders failed)" % (name, s["label"]))
        for label, rows in results[name].items():
            errors = [float(r["relative_rmse"]) for r in rows]
            if len(rows) < 3:
                problems.append("%s %s: %d rows, expected at least 3" % (name, label, len(rows)))
            elif not all(math.isfinite(e) and e > 0 for e in errors):
                problems.append("%s %s: errors not finite and positive: %s" % (name, label, errors))
            elif not errors[-1] < 0.7 * errors[0]:
                problems.append("%s %s: the error does not fall with time: %s" % (name, label,
                                                                                  errors))
            if not all(r.get("predicted_relative_rmse") for r in rows if int(r["passes"]) >= 2):
                problems.append("%s %s: no predicted error at 2 passes or more" % (name, label))
            times = [float(r["cpu_seconds"]) for r in rows[1:]]  # (fit_slope: why not the first)
            if times != sorted(times):
                problems.append("%s %s: CPU time does not grow with passes" % (name, label))
    for p in problems:
        print("FAIL " + p)
    return not problems


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build", default=os.path.join(ROOT, "build"))
    parser.add_argument("--out", default=os.path.join(ROOT, "bench", "results", "atlas"))
    parser.add_argument("--work", default=os.path.join(ROOT, "out", "atlas"),
                        help="where the reference EXRs go (not kept in the repository)")
    parser.add_argument("--scenes", default="", help="comma-separated subset of the scenes")
    parser.add_argument("--series-cpu-budget", type=float, default=6.0,
                        help="CPU seconds for one integrator's ladder")
    parser.add_argument("--reference-cpu-budget", type=float, default=40.0,
                        help="CPU seconds for the first reference half's ladder")
    parser.add_argument("--max-passes", type=int, default=4096)
    parser.add_argument("--quick", action="store_true", help="the seconds-long test slice")
    parser.add_argument("--check", action="store_true", help="assert the pipeline worked")
    parser.add_argument("--series", default="",
                        help="comma-separated label prefixes: re-measure only these series of "
                        "the scenes, against the references already in --out and --work")
    parser.add_argument("--replot", action="store_true",
                        help="redraw charts and tables from the CSV files in --out")
    args = parser.parse_args()

    catalogue = QUICK_SCENES if args.quick else SCENES
    if args.quick:
        args.series_cpu_budget, args.reference_cpu_budget, args.max_passes = 0.6, 1.0, 64
    names = args.scenes.split(",") if args.scenes else list(catalogue)
    for name in names:
        if name not in catalogue:
            sys.exit("unknown scene %s; the atlas has %s" % (name, ", ".join(catalogue)))
    tool = os.path.join(args.build, "bench", "bench_atlas_render")
    if not os.access(tool, os.X_OK):
        sys.exit("%s not found: cmake --build %s --target bench_atlas_render" % (tool, args.build))
    work = args.work or os.path.join(args.out, "exr")
    os.makedirs(work, exist_ok=True)

    if args.replot:
        with open(os.path.join(args.out, "atlas.csv")) as f:
            atlas_rows = list(csv.DictReader(f))
        with open(os.path.join(args.out, "references.csv")) as f:
            references = {r["scene"]: r for r in csv.DictReader(f)}
        names = [n for n in names if n in references]
    else:
        atlas_rows, references = measure(args, tool, work, catalogue, names)
        names = [n for n in catalogue if n in references]
    for r in references.values():
        r["passes_per_half"] = int(r["passes_per_half"])
        r["relative_noise"] = float(r["relative_noise"])
    finish(args, catalogue, names, atlas_rows, references)


def measure(args, tool, work, catalogue, names):
    ladder = ",".join(str(2 ** i) for i in range(0, 31) if 2 ** i <= args.max_passes)
    references, atlas_rows = {}, []
    prefixes = [p for p in args.series.split(",") if p]
    chosen = lambda label: not prefixes or any(label.startswith(p) for p in prefixes)
    # A run of some scenes keeps the other scenes' rows already in --out; a run of some series
    # keeps the other series' rows and the references they were measured against.
    if os.path.exists(os.path.join(args.out, "references.csv")):
        with open(os.path.join(args.out, "references.csv")) as f:
            references = {r["scene"]: r for r in csv.DictReader(f)
                          if prefixes or r["scene"] not in names}
        with open(os.path.join(args.out, "atlas.csv")) as f:
            atlas_rows = [r for r in csv.DictReader(f) if r["scene"] in references and not (
                r["scene"] in names and prefixes and chosen(r["integrator"]))]
    elif prefixes:
        sys.exit("--series re-measures against the references of an earlier run; none in %s"
                 % args.out)
    for name in names:
        scene = catalogue[name]
        if prefixes:
            reference_path = os.path.join(work, "%s_ref.exr" % name)
            if name not in references or not os.path.exists(reference_path):
                sys.exit("%s: no reference of an earlier run (%s)" % (name, reference_path))
            references[name]["relative_noise"] = float(references[name]["relative_noise"])
        else:
            print("%s: reference" % name, flush=True)
            budget = args.reference_cpu_budget * scene.get("reference_budget_factor", 1)
            reference_path, references[name] = make_reference(tool, name, scene, work, budget)
        noise = references[name]["relative_noise"]
        for s in scene["series"]:
            if not chosen(s["label"]):
                continue
            try:
                rows = run_helper(tool, scene, integrator_args(s["integrator"], s["params"]) + [
                    "--seed", str(SERIES_SEED), "--passes", ladder, "--cpu-budget",
                    str(args.series_cpu_budget * s.get("budget_factor", 1)),
                    "--reference", reference_path])
            except subprocess.CalledProcessError as failure:
                print("    %s FAILED: %s" % (s["label"], failure.stderr.strip()), flush=True)
                continue
            for r in rows:
                atlas_rows.append(dict(scene=name, integrator=s["label"], passes=r["passes"],
                                       wall_seconds=r["wall_seconds"],
                                       cpu_seconds=r["cpu_seconds"],
                                       relative_rmse=r["relative_rmse"],
                                       reference_noise="%.6g" % noise,
                                       predicted_relative_rmse=r["predicted_relative_rmse"]))
            print("    %-40s %5s passes  %.2f CPU s  error %s" % (
                s["label"], rows[-1]["passes"], float(rows[-1]["cpu_seconds"]),
                rows[-1]["relative_rmse"]), flush=True)
        # Written after every scene, so an interrupted run keeps what it measured.
        write_csv(os.path.join(args.out, "atlas.csv"), CSV_FIELDS, atlas_rows)
        write_csv(os.path.join(args.out, "references.csv"),
                  list(next(iter(references.values()))), references.values())
    return atlas_rows, references


def write_csv(path, fields, rows):
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fields)
        writer.writeheader()
        writer.writerows(rows)


def finish(args, catalogue, names, atlas_rows, references):
    results, slopes_rows = {}, []
    for name in names:
        scene = catalogue[name]
        series_by_label = {s["label"]: s for s in scene["series"]}
        results[name] = {}
        for r in atlas_rows:
            if r["scene"] == name:
                results[name].setdefault(r["integrator"], []).append(r)
        slopes = {}
        for label, rows in results[name].items():
            slopes[label] = fit_slope(rows, references[name]["relative_noise"])
            slopes_rows.append(dict(scene=name, integrator=label, fitted_slope=slopes[label],
                                    theory_slope=series_by_label[label]["theory"],
                                    theory=series_by_label[label]["why"]))
        chart(os.path.join(args.out, name + ".png"), name, scene, results[name],
              series_by_label, slopes, references[name])
    write_csv(os.path.join(args.out, "slopes.csv"),
              ["scene", "integrator", "fitted_slope", "theory_slope", "theory"],
              [dict(r, fitted_slope="%.3f" % r["fitted_slope"]) for r in slopes_rows])
    with open(os.path.join(args.out, "summary.md"), "w") as f:
        f.write(summary(names, results, references, slopes_rows))
    print("wrote %s/{atlas.csv,references.csv,slopes.csv,summary.md} and %d charts"
          % (os.path.relpath(args.out, ROOT), len(names)))
    if args.check and not check(args.out, catalogue, names, results):
        sys.exit(1)


if __name__ == "__main__":
    main()
