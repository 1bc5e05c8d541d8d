#!/usr/bin/env python3
"""Lookups from Python against cpvs-query's on the same file and points, one thread each, alternating.

    PYTHONPATH=build/python python3 benchmarks/python_lookups.py [--bin build/bin] [--out out/python-lookups]
        [--points 1000000] [--resolution 16k] [--rounds 5] [--doc docs/python]

Bakes `cpvs-scenegen city --triangles 100000` with --sun 0.4,-1,0.3 at --resolution, samples --points points
(cpvs.sample, seed 1), writes them as cpvs-query's CSV, then alternates, unfiltered and with --pcf 3, on two
workloads:
  all     every point: cpvs-query --timing-points N (its single-thread batch lookups per second over all of
          them, best of 5 timing rounds) against ShadowFile.lookup(points, normals, threads=1) over all of them
          (best of 5 calls);
  first   cpvs-query's default timing set, the first 65,536 points, warm in the caches: cpvs-query's figure
          (best of 5 timing rounds) against the Python call on those points, repeated for at least 0.3 s (best
          of 5).
Also the Python figure over all points on every core (threads=0). Prints a table with the CPU model, the
instruction set the lookups used (CPVS_LOOKUP_ISA narrows it) and the load average; writes DOC/lookups.json
(DOC/lookups-ISA.json with CPVS_LOOKUP_ISA set).
Needs numpy and the module (build/python)."""
import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

import cpvs

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info, machine_line  # noqa: E402


def run(cmd):
    subprocess.run([str(c) for c in cmd], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def python_rate(f, points, normals, pcf, threads, seconds=0.0, tries=5):
    """Best of `tries`: lookups per second over `points`, each a run of calls lasting at least `seconds`."""
    best = 0.0
    for _ in range(tries):
        calls, start = 0, time.perf_counter()
        while True:
            f.lookup(points, normals, light=0, pcf=pcf, threads=threads)
            calls += 1
            elapsed = time.perf_counter() - start
            if elapsed >= seconds:
                break
        best = max(best, calls * len(points) / elapsed)
    return best


def query_rate(a, bake, csv, pcf, timing_points):
    report = os.path.join(a.out, "query.json")
    run([os.path.join(a.bin, "cpvs-query"), bake, "--points", csv, "-o", os.path.join(a.out, "vis.csv"),
         "--report", report, "--quiet", "--timing-rounds", "5", "--timing-points", timing_points] +
        (["--pcf", str(pcf)] if pcf else []))
    return json.load(open(report))["lookups_per_s"]


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--bin", default="build/bin")
    p.add_argument("--out", default="out/python-lookups")
    p.add_argument("--doc", default="docs/python")
    p.add_argument("--points", type=int, default=1000000)
    p.add_argument("--resolution", default="16k")
    p.add_argument("--rounds", type=int, default=5)
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)
    scene, bake = os.path.join(a.out, "city.glb"), os.path.join(a.out, "city.cpvs")
    run([os.path.join(a.bin, "cpvs-scenegen"), "city", "--triangles", "100000", "-o", scene])
    run([os.path.join(a.bin, "cpvs-bake"), scene, "--sun", "0.4,-1,0.3", "-r", a.resolution, "-o", bake, "--quiet"])
    points, normals = cpvs.sample(scene, a.points, seed=1)
    csv = os.path.join(a.out, "points.csv")
    with open(csv, "w") as out:
        out.write("x,y,z,nx,ny,nz\n")
        np.savetxt(out, np.hstack([points, normals]), fmt="%.17g", delimiter=",")
    f = cpvs.open(bake)
    first = 65536
    head_points, head_normals = points[:first].copy(), normals[:first].copy()
    rows = {}
    load = [os.getloadavg()[0]]
    for _ in range(a.rounds):
        for name, pcf in (("unfiltered", None), ("pcf3", 3)):
            row = {"all_cpvs_query": query_rate(a, bake, csv, pcf, len(points)),
                   "all_python": python_rate(f, points, normals, pcf, 1),
                   "first_cpvs_query": query_rate(a, bake, csv, pcf, first),
                   "first_python": python_rate(f, head_points, head_normals, pcf, 1, seconds=0.3),
                   "all_python_every_core": python_rate(f, points, normals, pcf, 0)}
            rows.setdefault(name, []).append(row)
            load.append(os.getloadavg()[0])
            print(name, json.dumps(row), flush=True)
    isa = os.environ.get("CPVS_LOOKUP_ISA", "widest the CPU has")
    result = {"points": a.points, "resolution": a.resolution, "isa": isa, "machine": machine_info(),
              "load_average": load, "rounds": rows}
    os.makedirs(a.doc, exist_ok=True)
    name = "lookups.json" if "CPVS_LOOKUP_ISA" not in os.environ else f"lookups-{os.environ['CPVS_LOOKUP_ISA']}.json"
    with open(os.path.join(a.doc, name), "w") as out:
        json.dump(result, out, indent=1)
    print("\n" + machine_line(with_load=True) + f"; lookups: {isa}\n")
    print("| lookups | points | cpvs-query, 1 thread (M/s) | Python, 1 thread (M/s) | Python / cpvs-query "
          "| Python, every core (M/s) |")
    print("|---|---|---|---|---|---|")
    for name, rs in rows.items():
        for workload, label in (("all", f"all {a.points:,}"), ("first", "first 65,536")):
            q = max(r[f"{workload}_cpvs_query"] for r in rs) / 1e6
            p1 = max(r[f"{workload}_python"] for r in rs) / 1e6
            every = f"{max(r['all_python_every_core'] for r in rs) / 1e6:.2f}" if workload == "all" else ""
            print(f"| {name} | {label} | {q:.2f} | {p1:.2f} | {p1 / q:.2f} | {every} |")
    print(f"(best of {a.rounds} alternating rounds; load average {', '.join('%.2f' % x for x in load)})")


if __name__ == "__main__":
    main()
