#!/usr/bin/env python3
"""Lookups from Python against cpvs-query's on the same file and points, one thread each, alternating.

    PYTHONPATH=build/python python3 benchmarks/python_lookups.py [--bin build/bin] [--out out/python-lookups]
        [--points 1000000] [--resolution 16k] [--rounds 5] [--doc docs/python]

Bakes `cpvs-scenegen city --triangles 100000` with --sun 0.4,-1,0.3 at --resolution, samples --points points
(cpvs.sample, seed 1), writes them as cpvs-query's CSV, then alternates: cpvs-query --report (its "lookups" figure:
single-thread batch lookups per second, best of its rounds over the first 65,536 points) and
ShadowFile.lookup(points, normals, threads=1) over all the points (best of three calls), both unfiltered and with
--pcf 3. Also the Python figure on every core (threads=0). Prints a table with the CPU model, the instruction set
the lookups used (CPVS_LOOKUP_ISA narrows it) and the load average; writes DOC/lookups.json.
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


def python_rate(f, points, normals, pcf, threads):
    best = 0.0
    for _ in range(3):
        start = time.perf_counter()
        f.lookup(points, normals, light=0, pcf=pcf, threads=threads)
        best = max(best, len(points) / (time.perf_counter() - start))
    return best


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
    rows = {"unfiltered": [], "pcf3": []}
    load = [os.getloadavg()[0]]
    for _ in range(a.rounds):
        for name, pcf in (("unfiltered", None), ("pcf3", 3)):
            report = os.path.join(a.out, "query.json")
            cmd = [os.path.join(a.bin, "cpvs-query"), bake, "--points", csv, "-o", os.path.join(a.out, "vis.csv"),
                   "--report", report, "--quiet"] + (["--pcf", "3"] if pcf else [])
            run(cmd)
            tool = json.load(open(report))["lookups_per_s"]
            py1 = python_rate(f, points, normals, pcf, 1)
            py_all = python_rate(f, points, normals, pcf, 0)
            rows[name].append({"cpvs_query": tool, "python_1_thread": py1, "python_all_cores": py_all})
            load.append(os.getloadavg()[0])
            print(name, json.dumps(rows[name][-1]), flush=True)
    isa = os.environ.get("CPVS_LOOKUP_ISA", "widest the CPU has")
    result = {"points": a.points, "resolution": a.resolution, "isa": isa, "machine": machine_info(),
              "load_average": load, "rounds": rows}
    os.makedirs(a.doc, exist_ok=True)
    with open(os.path.join(a.doc, "lookups.json"), "w") as out:
        json.dump(result, out, indent=1)
    print("\n" + machine_line(with_load=True) + f"; lookups: {isa}\n")
    print("| lookups | cpvs-query, 1 thread (M/s) | Python, 1 thread (M/s) | Python / cpvs-query | Python, all cores (M/s) |")
    print("|---|---|---|---|---|")
    for name, rs in rows.items():
        q = max(r["cpvs_query"] for r in rs) / 1e6
        p1 = max(r["python_1_thread"] for r in rs) / 1e6
        pa = max(r["python_all_cores"] for r in rs) / 1e6
        print(f"| {name} | {q:.2f} | {p1:.2f} | {p1 / q:.2f} | {pa:.2f} |")
    print(f"(best of {a.rounds} alternating rounds; load average {', '.join('%.2f' % x for x in load)})")


if __name__ == "__main__":
    main()
