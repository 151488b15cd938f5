#!/usr/bin/python3
"""Alphorn against pbrt-v3 at equal time: path tracing, fog and progressive photon mapping on
the same Cornell box (bench/peers/make_scenes.py writes it for both).

    bench/peers/compare.py --pbrt PATH_TO_PBRT_V3 [--size 256] [--out out/peers] [--quick]

For every (scene, renderer, sampler) it renders a ladder of sample counts, alternating between
the two renderers so that both see the same machine load, and measures the error against a long
Alphorn reference (relative RMSE of luminance, bench_atlas_render's definition) and the time
(wall, and CPU = user + system of the child). Efficiency is 1 / (relative RMSE² × seconds):
equal-time error ratios are the square roots of its ratios. The reference's own noise is
measured by a second reference of another seed and printed beside the results; errors near it
mean nothing. pbrt is built by bench/peers/build-pbrt-v3.sh.

The longest rung, which the efficiency ratios use, is rendered --repeats times, interleaved:
Alphorn with seeds 1, 2, ... (its error is the root of the mean square over them, so the ratio
does not move with one image's luck), pbrt again on the same scene (it takes no seed: its image
is the same each time); each time is the median over the repeats, which this VM's drift of its
speed from minute to minute otherwise puts into the ratio.
"""
import argparse
import csv
import os
import resource
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
TOP = os.path.normpath(os.path.join(HERE, "..", ".."))

# (label, scene file stem, Alphorn -D values, pbrt integrator line)
PATH = ("path tracing", "box", {"integrator": "path_mis"}, 'Integrator "path" "integer maxdepth" [64]')
FOG = ("fog", "fog", {"integrator": "volume_path_mis"}, 'Integrator "volpath" "integer maxdepth" [64]')


def run(cmd):
    """Runs cmd; returns (wall seconds, CPU seconds of the child)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.monotonic()
    result = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.monotonic() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if result.returncode != 0:
        sys.exit("failed (%d): %s\n%s" % (result.returncode, " ".join(cmd), result.stderr[-2000:]))
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


class Peers:
    def __init__(self, args):
        self.args = args
        self.scenes = os.path.join(args.out, "scenes")
        self.images = os.path.join(args.out, "images")
        os.makedirs(self.images, exist_ok=True)
        subprocess.run(["/usr/bin/python3", os.path.join(HERE, "make_scenes.py"), self.scenes,
                        "--size", str(args.size)], check=True, stdout=subprocess.DEVNULL)

    def alphorn(self, stem, defines, spp, seed, out, size=None):
        cmd = [self.args.alphorn, "render", os.path.join(self.scenes, stem + ".xml"), "--spp",
               str(spp), "--seed", str(seed), "--threads", str(self.args.threads), "-o", out]
        if size:
            cmd += ["--size", "%dx%d" % (size, size)]
        for name, value in defines.items():
            cmd += ["-D", "%s=%s" % (name, value)]
        return run(cmd)

    def pbrt(self, stem, integrator, sampler, spp, out, size=None):
        with open(os.path.join(self.scenes, stem + ".pbrt-body")) as f:
            body = f.read()
        size = size or self.args.size
        header = "\n".join([
            integrator,
            'Sampler "%s" "integer pixelsamples" [%d]' % (sampler, spp),
            'Film "image" "integer xresolution" [%d] "integer yresolution" [%d] "string filename" "%s"'
            % (size, size, out)])
        scene = out + ".pbrt"
        with open(scene, "w") as f:
            f.write(header + "\n" + body)
        return run([self.args.pbrt, "--quiet", "--nthreads", str(self.args.threads), scene])

    def error(self, image, reference):
        result = subprocess.run([self.args.compare, "compare", image, reference], check=True,
                                stdout=subprocess.PIPE, text=True)
        return float(result.stdout.split()[-1])


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--pbrt", required=True, help="a pbrt-v3 binary (bench/peers/build-pbrt-v3.sh)")
    parser.add_argument("--alphorn", default=os.path.join(TOP, "build", "cli", "alphorn"))
    parser.add_argument("--compare", default=os.path.join(TOP, "build", "bench", "bench_atlas_render"),
                        help="the image comparison tool (bench_atlas_render compare)")
    parser.add_argument("--size", type=int, default=256, help="image width and height, pixels")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--reference-spp", type=int, default=4096)
    parser.add_argument("--repeats", type=int, default=3,
                        help="renders of each renderer and sampler at the longest rung")
    parser.add_argument("--out", default=os.path.join(TOP, "out", "peers"))
    parser.add_argument("--quick", action="store_true", help="small ladders and references (a smoke run)")
    args = parser.parse_args()
    peers = Peers(args)
    ladder = [4, 16] if args.quick else [4, 16, 64, 256]
    photon_ladder = [4, 16] if args.quick else [16, 64, 256]
    reference_spp = 64 if args.quick else args.reference_spp
    repeats = max(1, args.repeats)
    photons, radius = (20000, 0.04) if args.quick else (100000, 0.04)

    # Start-up (parsing the scene, building the BVH, writing the image) is not rendering: each
    # renderer's is measured on a 4 x 4 image at 1 sample and taken off its times, so the
    # efficiencies compare rendering alone (the tables also give them with start-up).
    startup = {}
    for renderer in ("alphorn", "pbrt"):
        samples = []
        for _ in range(3):
            out = os.path.join(peers.images, "startup_%s.exr" % renderer)
            if renderer == "alphorn":
                samples.append(peers.alphorn("box", dict(PATH[2], sampler="independent"), 1, 1, out, size=4))
            else:
                samples.append(peers.pbrt("box", PATH[3], "random", 1, out, size=4))
        startup[renderer] = (min(w for w, _ in samples), min(c for _, c in samples))
        print("start-up of %s: wall %.2f s, CPU %.2f s" % ((renderer,) + startup[renderer]), flush=True)

    rows = []
    for label, stem, defines, pbrt_integrator in (PATH, FOG):
        references = []
        for seed in (101, 102):
            ref = os.path.join(peers.images, "%s_reference_%d.exr" % (stem, seed))
            if not os.path.exists(ref):
                print("reference %s (seed %d, %d spp)..." % (stem, seed, reference_spp), flush=True)
                peers.alphorn(stem, dict(defines, sampler="sobol"), reference_spp, seed, ref)
            references.append(ref)
        reference_noise = peers.error(references[1], references[0]) / 2 ** 0.5
        print("%s: reference noise (relative RMSE) %.5f" % (label, reference_noise), flush=True)
        for spp in ladder:
            # Alternate renderers within each rung, so both see the same load.
            for repeat in range(repeats if spp == ladder[-1] else 1):
                seed = 1 + repeat
                for renderer, sampler in (("alphorn", "independent"), ("pbrt", "random"),
                                          ("alphorn", "sobol"), ("pbrt", "halton"),
                                          ("pbrt", "sobol")):
                    out = os.path.join(peers.images,
                                       "%s_%s_%s_%d_%d.exr" % (stem, renderer, sampler, spp, seed))
                    if renderer == "alphorn":
                        wall, cpu = peers.alphorn(stem, dict(defines, sampler=sampler), spp, seed,
                                                  out)
                    else:
                        wall, cpu = peers.pbrt(stem, pbrt_integrator, sampler, spp, out)
                    err = peers.error(out, references[0])
                    rows.append(dict(scene=label, renderer=renderer, sampler=sampler, spp=spp,
                                     repeat=repeat, wall_seconds=wall, cpu_seconds=cpu,
                                     relative_rmse=err, reference_noise=reference_noise,
                                     startup_wall_seconds=startup[renderer][0],
                                     startup_cpu_seconds=startup[renderer][1]))
                    print("  %-12s %-5s %-11s %4d spp: rmse %.5f wall %6.2f s cpu %6.2f s"
                          % (label, renderer, sampler, spp, err, wall, cpu), flush=True)

    # Photon mapping against the path-traced reference of the same box (both converge to it).
    references = [os.path.join(peers.images, "box_reference_%d.exr" % s) for s in (101, 102)]
    reference_noise = peers.error(references[1], references[0]) / 2 ** 0.5
    for passes in photon_ladder:
        for repeat in range(repeats if passes == photon_ladder[-1] else 1):
            seed = 1 + repeat
            for renderer in ("alphorn", "pbrt"):
                out = os.path.join(peers.images, "photons_%s_%d_%d.exr" % (renderer, passes, seed))
                if renderer == "alphorn":
                    wall, cpu = peers.alphorn("box_photons", {"sampler": "sobol", "photons": photons,
                                                              "radius": radius}, passes, seed, out)
                    sampler = "sobol"
                else:
                    integrator = ('Integrator "sppm" "integer numiterations" [%d] "integer '
                                  'photonsperiteration" [%d] "float radius" [%g] "integer '
                                  'maxdepth" [64]' % (passes, photons, radius))
                    wall, cpu = peers.pbrt("box", integrator, "random", 1, out)
                    sampler = "random"
                err = peers.error(out, references[0])
                rows.append(dict(scene="photon mapping", renderer=renderer, sampler=sampler,
                                 spp=passes, repeat=repeat, wall_seconds=wall, cpu_seconds=cpu,
                                 relative_rmse=err, reference_noise=reference_noise,
                                 startup_wall_seconds=startup[renderer][0],
                                 startup_cpu_seconds=startup[renderer][1]))
                print("  photons      %-5s %4d passes: rmse %.5f wall %6.2f s cpu %6.2f s"
                      % (renderer, passes, err, wall, cpu), flush=True)

    csv_path = os.path.join(args.out, "peers.csv")
    with open(csv_path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(rows)

    # Equal-time efficiency at the longest rung: Alphorn's best sampler against pbrt's best, over
    # the repeats (mean squared error, median time). The error's square has the reference's own
    # noise taken off (independent noises add in variance); times are rendering only (start-up
    # off), and with start-up in brackets.
    def efficiency(group, seconds_key, startup_key):
        mean_square = statistics.fmean(r["relative_rmse"] ** 2 for r in group)
        variance = max(mean_square - group[0]["reference_noise"] ** 2, 1e-12)
        seconds = statistics.median(r[seconds_key] for r in group)
        render = max(seconds - group[0][startup_key], 1e-3)
        return 1.0 / (variance * render), 1.0 / (variance * seconds)

    print("\n| scene (longest rung) | Alphorn | pbrt-v3 | relative RMSE, Alphorn / pbrt | "
          "efficiency ratio, CPU time (with start-up) | wall time (with start-up) |")
    print("|---|---|---|---|---:|---:|")
    for scene in ("path tracing", "fog", "photon mapping"):
        last = max(r["spp"] for r in rows if r["scene"] == scene)
        groups = {}
        for r in rows:
            if r["scene"] == scene and r["spp"] == last:
                groups.setdefault((r["renderer"], r["sampler"]), []).append(r)
        best = {}
        for (renderer, sampler), group in groups.items():
            cpu = efficiency(group, "cpu_seconds", "startup_cpu_seconds")
            wall = efficiency(group, "wall_seconds", "startup_wall_seconds")
            rmse = statistics.fmean(r["relative_rmse"] ** 2 for r in group) ** 0.5
            if renderer not in best or cpu[0] > best[renderer][0][0]:
                best[renderer] = (cpu, wall, sampler, rmse)
        a, p = best["alphorn"], best["pbrt"]
        print("| %s (%d spp) | %s | %s | %.4f / %.4f | %.2f× (%.2f×) | %.2f× (%.2f×) |"
              % (scene, last, a[2], p[2], a[3], p[3], a[0][0] / p[0][0], a[0][1] / p[0][1],
                 a[1][0] / p[1][0], a[1][1] / p[1][1]))
    print("\ncsv: %s" % csv_path)


if __name__ == "__main__":
    main()
