#!/usr/bin/env python3
"""The studies behind format 3.0's coding, on the bakes its goals name (docs/format-3-study.md).

Bakes (skipping files already there): the closed city's sun at 16k and 64k (256k with --large), the 165 spots of
`cpvs-scenegen city-spots` at 8k, the same lights as point lights at 2k, the Macross diorama's sun at 16k. Then
runs build/bin/level_width_estimate (bytes per coding) and build/bin/level_width_walk (the scalar walk of 2.0
against the pooled byte form, alternating) on each, and prints both with the machine, commit and load average.

    python3 benchmarks/format3_study.py [--bin build/bin] [--out out/format3] [--large] [--skip-walks]
"""
import argparse
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
from many_lights import point_lights_of  # noqa: E402


def load():
    with open("/proc/loadavg") as f:
        return " ".join(f.read().split()[:3])


def run(cmd):
    print("$ " + " ".join(cmd if len(cmd) < 20 else cmd[:12] + ["... (%d arguments)" % len(cmd)]), flush=True)
    return subprocess.run(cmd, check=True, stdout=subprocess.PIPE, text=True).stdout


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--bin", default=os.path.join(ROOT, "build", "bin"))
    p.add_argument("--out", default=os.path.join(ROOT, "out", "format3"))
    p.add_argument("--large", action="store_true", help="also the closed city's sun at 256k (minutes, ~2 GB)")
    p.add_argument("--skip-walks", action="store_true", help="bytes only")
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)
    b = lambda name: os.path.join(a.bin, name)
    o = lambda name: os.path.join(a.out, name)
    city, spots = o("city.glb"), o("city-spots.glb")
    if not os.path.exists(city):
        run([b("cpvs-scenegen"), "city", "-o", city])
    if not os.path.exists(spots):
        run([b("cpvs-scenegen"), "city-spots", "--lights", "165", "-o", spots])
    points = []
    for light in point_lights_of(spots):
        points += ["--point", light]
    macross = os.path.join(ROOT, "data", "scenes", "MacrossCityDiorama", "scene.glb")
    bakes = [("city-sun-16k.cpvs", [city, "-r", "16k", "--sun", "0.4,-1,0.3"]),
             ("city-sun-64k.cpvs", [city, "-r", "64k", "--sun", "0.4,-1,0.3"]),
             ("spots-8k.cpvs", [spots, "-r", "8k"]),
             ("points-2k.cpvs", [spots, "-r", "2k"] + points),
             ("macross-sun-16k.cpvs", [macross, "-r", "16k", "--sun", "0.3,-1,0.2"])]
    if a.large:
        bakes.insert(2, ("city-sun-256k.cpvs", [city, "-r", "256k", "--sun", "0.4,-1,0.3"]))
    for name, args in bakes:
        if not os.path.exists(o(name)):
            run([b("cpvs-bake")] + args + ["-o", o(name), "-q"])
    commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], stdout=subprocess.PIPE,
                            text=True).stdout.strip()
    with open("/proc/cpuinfo") as f:
        cpu = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), "?")
    print("\nmachine: %s, %d cores; commit %s; load before %s" % (cpu, os.cpu_count(), commit, load()))
    files = [o(name) for name, _ in bakes]
    print(run([b("level_width_estimate")] + files))
    print(run([b("level_width_estimate"), "--cube-leaves"] + files))
    print(run([b("leaf_shape_estimate")] + files))
    for f in files:
        print(run([b("node_pool_cost"), f]))
    if not a.skip_walks:
        for f in files:
            print(run([b("level_width_walk"), f]))
    print("load after %s" % load())


if __name__ == "__main__":
    main()
