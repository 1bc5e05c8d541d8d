#!/usr/bin/env python3
"""Two builds of the tools against each other on one machine, alternating: lookups (cpvs-query's single-thread
batch lookups per second, unfiltered and PCF 3) and a bake (CPU and wall time of the closed city's sun).

    python3 benchmarks/compare_builds.py --a OLD/bin --b NEW/bin [--label-a A --label-b B] [--rounds 5]
        [--resolution 16k] [--points 200000] [--out out/compare-builds]

The scene, the bake the lookups read and the points are made once with build A (`cpvs-scenegen city
--triangles 100000`, --sun 0.4,-1,0.3, `cpvs-sample -n POINTS`). Each round runs A then B, then B then A in the
next, so drift in the machine's speed falls on both. Prints the best and median of each, their ratio, the CPU
model and the load average. Python 3 standard library only."""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_line  # noqa: E402


def run(cmd):
    start = time.time()
    proc = subprocess.Popen([str(c) for c in cmd], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(" ".join(map(str, cmd)) + ": " + proc.stderr.read().decode())
    return time.time() - start, usage.ru_utime + usage.ru_stime


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--a", required=True)
    p.add_argument("--b", required=True)
    p.add_argument("--label-a", default="A")
    p.add_argument("--label-b", default="B")
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--resolution", default="16k")
    p.add_argument("--points", type=int, default=200000)
    p.add_argument("--out", default="out/compare-builds")
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)
    scene, bake, points = (os.path.join(a.out, n) for n in ("city.glb", "city.cpvs", "points.csv"))
    run([os.path.join(a.a, "cpvs-scenegen"), "city", "--triangles", "100000", "-o", scene])
    run([os.path.join(a.a, "cpvs-bake"), scene, "--sun", "0.4,-1,0.3", "-r", a.resolution, "-o", bake, "--quiet"])
    run([os.path.join(a.a, "cpvs-sample"), scene, "-o", points, "-n", str(a.points)])
    figures = {label: {"unfiltered": [], "pcf3": [], "bake_cpu_s": [], "bake_wall_s": []}
               for label in (a.label_a, a.label_b)}
    load = [os.getloadavg()[0]]
    for r in range(a.rounds):
        order = [(a.label_a, a.a), (a.label_b, a.b)]
        for label, bindir in (order if r % 2 == 0 else order[::-1]):
            for name, extra in (("unfiltered", []), ("pcf3", ["--pcf", "3"])):
                report = os.path.join(a.out, "query.json")
                run([os.path.join(bindir, "cpvs-query"), bake, "--points", points, "-o", os.path.join(a.out, "v.csv"),
                     "--report", report, "--quiet"] + extra)
                figures[label][name].append(json.load(open(report))["lookups_per_s"] / 1e6)
            wall, cpu = run([os.path.join(bindir, "cpvs-bake"), scene, "--sun", "0.4,-1,0.3", "-r", a.resolution,
                             "-o", os.path.join(a.out, "again.cpvs"), "--quiet"])
            figures[label]["bake_cpu_s"].append(cpu)
            figures[label]["bake_wall_s"].append(wall)
        load.append(os.getloadavg()[0])
    print(machine_line(with_load=True))
    print(f"| | {a.label_a} | {a.label_b} | {a.label_b} / {a.label_a} |")
    print("|---|---|---|---|")
    for name, best in (("unfiltered", max), ("pcf3", max), ("bake_cpu_s", min), ("bake_wall_s", min)):
        fa, fb = figures[a.label_a][name], figures[a.label_b][name]
        unit = "M lookups/s" if "bake" not in name else "s"
        print(f"| {name} ({unit}; best, median) | {best(fa):.2f}, {statistics.median(fa):.2f} | "
              f"{best(fb):.2f}, {statistics.median(fb):.2f} | {best(fb) / best(fa):.3f} |")
    print(f"({a.rounds} alternating rounds; load average {', '.join('%.2f' % x for x in load)})")


if __name__ == "__main__":
    main()
