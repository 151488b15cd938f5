#!/usr/bin/env python3
"""Alphorn against pbrt-v4 on the same pbrt-v4 scene files: do they render the same image?

  bench/peers/agree_pbrt_v4.py --pbrt ../peers/pbrt-v4/bin/pbrt [--spp 64] [--seeds 4]
      [--size 256x256] [--crop 32] [--out out/peers/agreement.md] SCENE.pbrt...

Each scene is rendered by both renderers at the same resolution and samples per pixel, with
--seeds seeds each (the renderers alternate, so both see the same machine load). The scene's
directory is copied to a scratch directory first, where --size rewrites the Film's resolution;
the originals are never touched. For the image and for every CROP x CROP crop, the luminance means
of the two renderers are compared as z = (mean_alphorn - mean_pbrt) / sqrt(var_alphorn +
var_pbrt), each variance that of a renderer's mean over its seeds (from the spread of its seeds'
images), so the z-score counts a difference against both renderers' noise. A difference beyond
|z| 3 is more than noise: a different image, whose cause the report must name.

Alphorn's image is `alphorn render`'s EXR; pbrt's is its `--outfile` EXR. Crop means come from
`bench_atlas_render crops`. The report (Markdown) gives per scene: both means, their ratio, the
image z-score, the number of crops beyond |z| 3 and the worst ones, and both renderers' CPU time.
"""
import argparse
import math
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time

TOP = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def luminance(r, g, b):
    return 0.212671 * r + 0.715160 * g + 0.072169 * b


def run(command, log):
    """Runs a command; returns its CPU seconds (user + system of the child)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.time()
    result = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    log.write("$ " + " ".join(command) + "\n" + result.stdout[-4000:] + "\n")
    if result.returncode != 0:
        sys.exit("agree_pbrt_v4: %s failed (status %d):\n%s" % (command[0], result.returncode,
                                                                 result.stdout[-2000:]))
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, time.time() - started


def crops(tool, image, size):
    out = subprocess.run([tool, "crops", image, str(size)], stdout=subprocess.PIPE, text=True,
                         check=True).stdout
    whole, parts = None, {}
    for line in out.splitlines():
        fields = line.split(",")
        if fields[0] == "all":
            whole = luminance(*map(float, fields[1:4]))
        else:
            parts[(int(fields[0]), int(fields[1]))] = luminance(*map(float, fields[2:5]))
    return whole, parts


def mean_and_variance_of_mean(values):
    n = len(values)
    mean = sum(values) / n
    variance = sum((v - mean) ** 2 for v in values) / (n - 1) if n > 1 else float("nan")
    return mean, variance / n


def prepare(scene, size, scratch):
    """A copy of the scene's directory with the Film's resolution set to `size` (if given)."""
    source = os.path.dirname(os.path.abspath(scene))
    copy = os.path.join(scratch, os.path.basename(source))
    shutil.copytree(source, copy, dirs_exist_ok=True)
    path = os.path.join(copy, os.path.basename(scene))
    if size:
        width, height = size
        with open(path) as f:
            text = f.read()
        for name, value in (("xresolution", width), ("yresolution", height)):
            pattern = r'"integer\s+%s"\s*(\[\s*\d+\s*\]|\d+)' % name
            if re.search(pattern, text):
                text = re.sub(pattern, '"integer %s" [ %d ]' % (name, value), text)
            else:
                text = re.sub(r'(Film\s+"[a-z]+")', r'\1 "integer %s" [ %d ]' % (name, value),
                              text, count=1)
        with open(path, "w") as f:
            f.write(text)
    return path


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="+")
    parser.add_argument("--pbrt", required=True, help="the pbrt-v4 binary")
    parser.add_argument("--alphorn", default=os.path.join(TOP, "build", "cli", "alphorn"))
    parser.add_argument("--tool", default=os.path.join(TOP, "build", "bench", "bench_atlas_render"))
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--size", help="WIDTHxHEIGHT: the Film's resolution for both renderers")
    parser.add_argument("--crop", type=int, default=32)
    parser.add_argument("--out", default=os.path.join(TOP, "out", "peers", "agreement.md"))
    args = parser.parse_args()
    if args.seeds < 2:
        sys.exit("agree_pbrt_v4: --seeds must be at least 2 (the noise is measured from them)")
    size = tuple(int(v) for v in args.size.split("x")) if args.size else None
    for tool in (args.pbrt, args.alphorn, args.tool):
        if not os.access(tool, os.X_OK):
            sys.exit("agree_pbrt_v4: %s is not an executable" % tool)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    scratch = tempfile.mkdtemp(prefix="alphorn-agree-")
    log = open(args.out + ".log", "w")
    rows = []
    for scene in args.scenes:
        path = prepare(scene, size, scratch)
        name = os.path.relpath(os.path.abspath(scene), os.getcwd())
        images = {"alphorn": [], "pbrt": []}
        cpu = {"alphorn": 0.0, "pbrt": 0.0}
        for seed in range(1, args.seeds + 1):
            out = os.path.join(scratch, "alphorn-%d.exr" % seed)
            cpu["alphorn"] += run([args.alphorn, "render", path, "--spp", str(args.spp), "--seed",
                                   str(seed), "-o", out], log)[0]
            images["alphorn"].append(out)
            out = os.path.join(scratch, "pbrt-%d.exr" % seed)
            cpu["pbrt"] += run([args.pbrt, "--spp", str(args.spp), "--seed", str(seed),
                                "--outfile", out, "--quiet", path], log)[0]
            images["pbrt"].append(out)
        stats = {}
        for renderer, files in images.items():
            measured = [crops(args.tool, f, args.crop) for f in files]
            whole = mean_and_variance_of_mean([m[0] for m in measured])
            parts = {key: mean_and_variance_of_mean([m[1][key] for m in measured])
                     for key in measured[0][1]}
            stats[renderer] = (whole, parts)
        (ma, va), (mp, vp) = stats["alphorn"][0], stats["pbrt"][0]
        z_image = (ma - mp) / math.sqrt(va + vp) if va + vp > 0 else float("inf")
        crop_z = []
        for key, (a, a_var) in stats["alphorn"][1].items():
            p, p_var = stats["pbrt"][1][key]
            spread = math.sqrt(a_var + p_var)
            if spread > 0:
                crop_z.append(((a - p) / spread, key, a, p))
        crop_z.sort(key=lambda item: -abs(item[0]))
        beyond = [c for c in crop_z if abs(c[0]) > 3]
        # How large the differences are, not only how sure: the relative difference of each crop
        # (of crops that are not black in both).
        relative = sorted(abs(a / p - 1) for _, _, a, p in crop_z if p > 0)
        median_relative = relative[len(relative) // 2] if relative else float("nan")
        rows.append((name, ma, mp, z_image, len(crop_z), beyond, cpu, median_relative))
        print("%s: Alphorn %.5g, pbrt-v4 %.5g (ratio %.4f, z %.2f); %d of %d crops beyond |z| 3; "
              "median crop difference %.2f%%; worst: %s"
              % (name, ma, mp, ma / mp if mp else float("nan"), z_image, len(beyond), len(crop_z),
                 100 * median_relative,
                 ", ".join("(%d, %d: z %.1f, %+.1f%%)" % (c[1][0], c[1][1], c[0],
                                                          100 * (c[2] / c[3] - 1) if c[3] else 0)
                           for c in beyond[:6])))
        sys.stdout.flush()
    with open(args.out, "w") as f:
        f.write("# Alphorn against pbrt-v4\n\n")
        f.write("`%s`\n\n" % " ".join(["bench/peers/agree_pbrt_v4.py"] + sys.argv[1:]))
        f.write("%d spp, %d seeds per renderer, %s, crops of %d pixels; luminance means; z against "
                "both renderers' noise (their seeds' spread).\n\n"
                % (args.spp, args.seeds, "size %s" % args.size if args.size else "the scenes' "
                   "resolution", args.crop))
        f.write("| scene | Alphorn mean | pbrt-v4 mean | ratio | image z | crops beyond \\|z\\| 3 "
                "| median crop difference | worst crops (x, y: z, difference) "
                "| CPU s Alphorn / pbrt-v4 |\n|---|---|---|---|---|---|---|---|---|\n")
        for name, ma, mp, z, count, beyond, cpu, median_relative in rows:
            worst = ", ".join("(%d, %d: %.1f, %+.1f%%)" % (c[1][0], c[1][1], c[0],
                                                           100 * (c[2] / c[3] - 1) if c[3] else 0)
                              for c in beyond[:4])
            f.write("| %s | %.5g | %.5g | %.4f | %.2f | %d of %d | %.2f%% | %s | %.1f / %.1f |\n"
                    % (name, ma, mp, ma / mp if mp else float("nan"), z, len(beyond), count,
                       100 * median_relative, worst or "-", cpu["alphorn"], cpu["pbrt"]))
    print("wrote %s (commands and output in %s.log)" % (args.out, args.out))
    shutil.rmtree(scratch, ignore_errors=True)


if __name__ == "__main__":
    main()
