#!/usr/bin/env python3
"""Peak memory and time of one bake with two builds of cpvs-bake, alternating: what a change to the bake's
memory costs or saves, and whether both builds write the same bytes.

    python3 benchmarks/bake_memory.py --baseline-bin OLD/bin --baseline-commit C [--bin build/bin] [--scene S.glb]
                                      [--light "--lights sun"] [--resolution 64k] [--rounds 2] [--threads 2]
                                      [--out out/bake-memory] [--json docs/construction/bake-memory.json]

Without --scene it bakes the generated foliage level (`cpvs-scenegen foliage`: 1,606 instanced trees of
alpha-tested leaf cards), whose sun is the largest DAG per texel we know. Each round bakes with the baseline
build, then with --bin; each run records wall and CPU seconds and peak RSS (wait4), the report's phases, and
the load average before and after. The two outputs are compared byte for byte. Writes --json (every figure, both
commits, the machine) and prints a markdown table. Python 3 standard library only."""

import argparse
import filecmp
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bake_scale import measured  # noqa: E402
from machine import machine_info  # noqa: E402
from uniform_tiles import load_average  # noqa: E402


def head_commit():
    here = os.path.dirname(os.path.abspath(__file__))
    run = lambda *cmd: subprocess.run(["git", *cmd], capture_output=True, text=True, cwd=here).stdout.strip()
    return run("rev-parse", "--short", "HEAD") + ("-dirty" if run("status", "--porcelain", "--untracked-files=no") else "")


def bake(binary_dir, a, scene, out):
    cmd = [os.path.join(binary_dir, "cpvs-bake"), scene, "-r", a.resolution] + a.light.split() + ["-j",
           str(a.threads), "-o", out + ".cpvs", "--report", out + ".json", "-q"]
    load_before = load_average()
    run = measured(cmd)
    with open(out + ".json") as f:
        report = json.load(f)
    phases = {}
    for light in report["lights"]:
        for view in light["views"]:
            for k, ms in view["phases_ms"].items():
                phases[k] = phases.get(k, 0.0) + ms / 1000.0
    run.update({"command": " ".join(cmd), "file_bytes": report["file_bytes"], "phases_s": phases,
                "load_before": load_before, "load_after": load_average()})
    return run


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bin", default="build/bin")
    parser.add_argument("--baseline-bin", required=True)
    parser.add_argument("--baseline-commit", required=True, help="the commit the baseline build was made from")
    parser.add_argument("--scene", default="")
    parser.add_argument("--light", default="--lights sun", help="the bake's light options")
    parser.add_argument("--resolution", default="64k")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--out", default="out/bake-memory")
    parser.add_argument("--json", default="docs/construction/bake-memory.json")
    a = parser.parse_args()
    os.makedirs(a.out, exist_ok=True)
    scene = a.scene
    if not scene:
        scene = os.path.join(a.out, "foliage.glb")
        subprocess.run([os.path.join(a.bin, "cpvs-scenegen"), "foliage", "-o", scene], check=True)
    result = {"machine": machine_info(), "scene": scene, "light": a.light, "resolution": a.resolution,
              "threads": a.threads, "builds": {"baseline": a.baseline_commit, "new": head_commit()},
              "runs": {"baseline": [], "new": []}}
    for _ in range(a.rounds):
        for name, binary_dir in (("baseline", a.baseline_bin), ("new", a.bin)):
            result["runs"][name].append(bake(binary_dir, a, scene, os.path.join(a.out, name)))
    result["same_bytes"] = filecmp.cmp(os.path.join(a.out, "baseline.cpvs"), os.path.join(a.out, "new.cpvs"),
                                       shallow=False)
    os.makedirs(os.path.dirname(a.json) or ".", exist_ok=True)
    with open(a.json, "w") as f:
        json.dump(result, f, indent=1)

    print("\n| build | wall s | CPU s | DAG phase s | peak RSS | bytes | load before/after |")
    print("|---|---|---|---|---|---|---|")
    for name in ("baseline", "new"):
        for r in result["runs"][name]:
            print("| %s | %.1f | %.1f | %.1f | %.2f GB | %d | %.2f / %.2f |" % (
                result["builds"][name], r["wall_s"], r["cpu_s"], r["phases_s"].get("dag", 0.0),
                r["peak_rss_bytes"] / 1e9, r["file_bytes"], r["load_before"], r["load_after"]))
    print("\nsame bytes: %s" % result["same_bytes"])


if __name__ == "__main__":
    main()
