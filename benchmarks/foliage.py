#!/usr/bin/env python3
"""What alpha-tested casters cost and what they fix: the generated foliage level (cpvs-scenegen foliage: trees of
alpha-masked leaf cards placed by EXT_mesh_gpu_instancing, buildings with clear glass) with its sun and 16 spot
lights, baked with the alpha test on and off (alternating, same machine state), each scored against the
alpha-aware Embree reference; bake time, bytes, peak memory and lookup speed of both.

    python3 benchmarks/foliage.py [--bin build/bin] [--out out/foliage] [--doc docs/alpha]
                                  [--resolution 8k] [--points 200000] [--rounds 2] [--threads N]
                                  [--sun-sweep 2k,4k,8k,16k]

Writes DOC/foliage.json (every figure, the machine, the load average, the commit) and prints the markdown table
that docs/alpha.md quotes. With --sun-sweep it instead bakes the sun alone at each resolution and scores the
points on the ground and on everything else (leaf cards, trunks, buildings) apart: DOC/foliage-sun-sweep.json.
Python 3 standard library only."""

import argparse
import json
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info  # noqa: E402


def run(cmd):
    print("$ " + " ".join(cmd), flush=True)
    start = time.time()
    subprocess.run(cmd, check=True)
    return time.time() - start


def load_average():
    return list(os.getloadavg())


def commit():
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              cwd=os.path.dirname(os.path.abspath(__file__))).stdout.strip()
    except OSError:
        return ""


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bin", default="build/bin")
    parser.add_argument("--out", default="out/foliage")
    parser.add_argument("--doc", default="docs/alpha")
    parser.add_argument("--resolution", default="8k")
    parser.add_argument("--points", type=int, default=200000)
    parser.add_argument("--rounds", type=int, default=2, help="alternating on/off bakes per mode")
    parser.add_argument("--threads", type=int, default=os.cpu_count())
    parser.add_argument("--sun-sweep", default="", help="comma-separated resolutions: the sun's error against N")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    os.makedirs(args.doc, exist_ok=True)
    tool = lambda name: os.path.join(args.bin, name)
    scene = os.path.join(args.out, "foliage.glb")
    points = os.path.join(args.out, "points.csv")
    result = {"machine": machine_info(), "commit": commit(), "resolution": args.resolution,
              "threads": args.threads, "load_before": load_average(), "modes": {}}
    run([tool("cpvs-scenegen"), "foliage", "-o", scene])
    run([tool("cpvs-sample"), scene, "-o", points, "-n", str(args.points)])
    if args.sun_sweep:
        return sun_sweep(args, tool, scene, points, result)

    modes = {"on": [], "off": ["--alpha-test", "off"]}
    bakes = {m: [] for m in modes}
    for r in range(args.rounds):
        for mode, extra in modes.items():  # alternating: on, off, on, off, ...
            out = os.path.join(args.out, "foliage-%s.cpvs" % mode)
            report = os.path.join(args.out, "bake-%s-%d.json" % (mode, r))
            wall = run([tool("cpvs-bake"), scene, "-o", out, "-r", args.resolution, "--threads", str(args.threads),
                        "--report", report, "--quiet"] + extra)
            with open(report) as f:
                rep = json.load(f)
            bakes[mode].append({"wall_s": wall, "bytes": os.path.getsize(out),
                                "peak_rss_bytes": rep.get("peak_rss_bytes", 0), "load": load_average()})

    for mode, extra in modes.items():
        out = os.path.join(args.out, "foliage-%s.cpvs" % mode)
        entry = {"bakes": bakes[mode]}
        # Against the reference with the same rule (what the bake promises), and the alpha-off bake against the
        # alpha-aware reference too (what ignoring alpha gets wrong).
        for ref_name, ref_extra in [("same_rule", extra), ("alpha_aware", [])]:
            if mode == "on" and ref_name == "alpha_aware":
                continue
            report = os.path.join(args.out, "query-%s-%s.json" % (mode, ref_name))
            run([tool("cpvs-query"), out, "--points", points, "-o", os.path.join(args.out, "vis-%s.csv" % mode),
                 "--reference", scene, "--report", report, "--timing-rounds", "3", "--quiet"] + ref_extra)
            with open(report) as f:
                q = json.load(f)
            lights = {}
            for light in q["lights"]:
                e = light["reference"]
                lights[light["name"]] = {k: e[k] for k in ("misclassified", "misclassified_count", "facing_points",
                                                           "misclassified_facing", "misclassified_uniform",
                                                           "uniform_points")}
            entry[ref_name] = {"lights": lights, "lookups_per_s": q.get("lookups_per_s"),
                               "rays_per_s": q.get("rays_per_s", q.get("reference", {}).get("rays_per_s"))}
        result["modes"][mode] = entry
    result["load_after"] = load_average()
    with open(os.path.join(args.doc, "foliage.json"), "w") as f:
        json.dump(result, f, indent=1)

    def pooled(lights, subset):
        wrong = sum(lights[n]["misclassified_count"] for n in subset)
        facing = sum(lights[n]["facing_points"] for n in subset)
        return 100.0 * wrong / facing if facing else 0.0

    on = result["modes"]["on"]
    names = list(on["same_rule"]["lights"].keys())
    sun, spots = names[:1], names[1:]
    print("\nMachine: %s, %s CPUs; commit %s; load %.2f before, %.2f after\n" % (
        result["machine"]["model"], result["machine"]["cpus"], result["commit"], result["load_before"][0],
        result["load_after"][0]))
    print("| alpha test | bake wall (s, each run) | bytes | peak RSS (MB) | lookups/s | misclassified facing pairs, sun | spots | against |")
    print("|---|---|---|---|---|---|---|---|")
    for mode in modes:
        m = result["modes"][mode]
        for ref_name in ("same_rule", "alpha_aware"):
            if ref_name not in m:
                continue
            lights = m[ref_name]["lights"]
            print("| %s | %s | %d | %.0f | %.3g | %.3f %% | %.3f %% | %s |" % (
                mode, ", ".join("%.1f" % b["wall_s"] for b in m["bakes"]), m["bakes"][-1]["bytes"],
                m["bakes"][-1]["peak_rss_bytes"] / 1e6, m[ref_name]["lookups_per_s"] or 0,
                pooled(lights, sun), pooled(lights, spots),
                "alpha-aware rays" if ref_name == "alpha_aware" or mode == "on" else "rays with alpha off"))


def sun_sweep(args, tool, scene, points, result):
    """The sun's error against resolution, for ground points (dappled shadows) and the rest apart."""
    with open(points) as f:
        header, rows = f.readline(), [line for line in f if line.strip()]
    subsets = {"ground": [r for r in rows if abs(float(r.split(",")[1])) < 1e-6],
               "other": [r for r in rows if abs(float(r.split(",")[1])) >= 1e-6]}
    for name, subset in subsets.items():
        with open(os.path.join(args.out, "points-%s.csv" % name), "w") as f:
            f.write(header + "".join(subset))
    result["sweep"] = {}
    for res in args.sun_sweep.split(","):
        out = os.path.join(args.out, "sun-%s.cpvs" % res)
        wall = run([tool("cpvs-bake"), scene, "-o", out, "-r", res, "--lights", "sun", "--threads", str(args.threads),
                    "--quiet"])
        entry = {"wall_s": wall, "bytes": os.path.getsize(out)}
        for name in subsets:
            report = os.path.join(args.out, "sweep-%s-%s.json" % (res, name))
            run([tool("cpvs-query"), out, "--points", os.path.join(args.out, "points-%s.csv" % name), "-o",
                 os.path.join(args.out, "sweep-vis.csv"), "--reference", scene, "--report", report,
                 "--timing-rounds", "0", "--quiet"])
            with open(report) as f:
                e = json.load(f)["lights"][0]["reference"]
            entry[name] = {k: e[k] for k in ("facing_points", "misclassified_count", "misclassified_facing",
                                             "misclassified_uniform", "uniform_points")}
        result["sweep"][res] = entry
    result["load_after"] = load_average()
    with open(os.path.join(args.doc, "foliage-sun-sweep.json"), "w") as f:
        json.dump(result, f, indent=1)
    print("\nMachine: %s, %s CPUs; commit %s; load %.2f before, %.2f after\n" % (
        result["machine"]["model"], result["machine"]["cpus"], result["commit"], result["load_before"][0],
        result["load_after"][0]))
    print("| sun at | bake wall (s) | bytes | ground: misclassified facing | uniform | leaf cards, trunks, buildings: misclassified facing | uniform |")
    print("|---|---|---|---|---|---|---|")
    for res, e in result["sweep"].items():
        g, o = e["ground"], e["other"]
        print("| %s | %.1f | %d | %.2f %% | %.3f %% | %.2f %% | %.3f %% |" % (
            res, e["wall_s"], e["bytes"], 100 * g["misclassified_facing"], 100 * g["misclassified_uniform"],
            100 * o["misclassified_facing"], 100 * o["misclassified_uniform"]))


if __name__ == "__main__":
    main()
