#!/usr/bin/python3
"""CPU time (user + system) of two or more alphorn binaries on the same command, interleaved.

    bench/ab_cpu_time.py ROUNDS 'ARGUMENTS' BASE_BINARY OTHER_BINARY...

Each round runs every binary once (the first of each round rotating), so that machine load
affects them alike, and the table gives each binary's CPU times, their median, the median wall
time and the median of its per-round CPU ratio to the first binary (the baseline). The image goes
to a temporary file. Used for the before/after figures in bench/RESULTS.md.
"""
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    rounds, arguments, binaries = int(sys.argv[1]), sys.argv[2].split(), sys.argv[3:]
    cpu = {b: [] for b in binaries}
    wall = {b: [] for b in binaries}
    with tempfile.TemporaryDirectory() as folder:
        image = os.path.join(folder, "image.exr")
        for r in range(rounds):
            shift = r % len(binaries)
            for binary in binaries[shift:] + binaries[:shift]:
                before = resource.getrusage(resource.RUSAGE_CHILDREN)
                start = time.monotonic()
                subprocess.run([binary] + arguments + ["-o", image], check=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                after = resource.getrusage(resource.RUSAGE_CHILDREN)
                wall[binary].append(time.monotonic() - start)
                cpu[binary].append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    base = cpu[binaries[0]]
    for binary in binaries:
        ratios = [c / b for c, b in zip(cpu[binary], base)]
        print("%s\n  CPU s %s, median %.3f; wall median %.3f s; CPU / baseline median %.3f"
              % (binary, " ".join("%.2f" % c for c in cpu[binary]), statistics.median(cpu[binary]),
                 statistics.median(wall[binary]), statistics.median(ratios)))


if __name__ == "__main__":
    main()
