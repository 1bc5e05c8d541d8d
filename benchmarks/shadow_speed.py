#!/usr/bin/env python3
"""cpvs-view's CPU shadow pass against Embree rays at the same quality: hard against hard (CPVS unfiltered, one
lookup per pair, against one shadow ray per pair) and filtered against filtered (CPVS 9x9 PCF against 16 rays
spread over the same 9x9 footprint), with the error of each side against the 81-ray footprint reference.

    python3 benchmarks/shadow_speed.py [--bin build/bin] [--out out/shadow-speed] [--doc docs/viewer]
                                       [--resolutions 8k,4k] [--frames 4] [--size 1920x1080] [--commit C]

The generated city with 165 spot lights (cpvs-scenegen city-spots), baked at each resolution, seen from the
--frames cameras spread over benchmarks/viewer.py's flythrough (its first, overview, to its last, street level). Timing: for every camera, each side runs in its own
process on a path of that camera twice, and the second frame's shadow pass is taken (shaders compiled, the
lookups' and rays' buffers, DAG pages and BVH warm on both sides alike); the four runs of a camera alternate,
their order rotated camera by camera, so that ratios come from one run on this noisy machine. Error: the first
and last cameras with --compare --compare-rays 81 (mean |visibility - reference| over the pairs, and the pairs on
the other side of 1/2). Writes DOC/speed.json and DOC/speed.md. Python 3 standard library only."""

import argparse
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info  # noqa: E402
from viewer import flythrough  # noqa: E402

# (label, cpvs-view flags): the four sides of the table.
SIDES = [("CPVS, unfiltered", ["--shadows", "cpu", "--pcf", "1"]),
         ("1 ray per pair", ["--shadows", "raytraced", "--pcf", "1", "--rays", "1"]),
         ("CPVS, 9x9 PCF", ["--shadows", "cpu", "--pcf", "9"]),
         ("16 footprint rays per pair", ["--shadows", "raytraced", "--pcf", "9", "--rays", "16"])]


def view(a, scene, cpvs, cameras, extra, tag):
    path = os.path.join(a.out, tag + "-path.json")
    with open(path, "w") as f:
        json.dump(cameras, f)
    report = os.path.join(a.out, tag + ".json")
    cmd = [os.path.join(a.bin, "cpvs-view"), scene, cpvs, "--path", path, "--frames", os.path.join(a.out, tag),
           "--size", a.size, "--report", report, "-q"] + extra
    print("$ " + " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True)
    with open(report) as f:
        return json.load(f)


def measure(a, scene, cpvs, resolution):
    # Spread over benchmarks/viewer.py's eight cameras, from the overview to the last (street level).
    every = flythrough(8)
    n = max(2, min(a.frames, 8))
    cameras = [every[k] for k in sorted({round(j * 7 / (n - 1)) for j in range(n)})]
    timing = []
    for i, camera in enumerate(cameras):
        order = SIDES[i % len(SIDES):] + SIDES[:i % len(SIDES)]
        row = {}
        for label, flags in order:
            r = view(a, scene, cpvs, [camera, camera], flags, "t-%s-%d-%d" % (resolution, i, SIDES.index((label, flags))))
            frame = r["frames"][1]
            row[label] = {"shadows_ms": frame["passes_ms"]["shadows"], "pairs": frame["light_lists"]["pairs_listed"]}
        timing.append(row)
    errors = {}
    for i in sorted({0, len(cameras) - 1}):
        errors[i] = {}
        for label, flags in SIDES:
            r = view(a, scene, cpvs, [cameras[i]], flags + ["--compare", "--compare-rays", "81"],
                     "e-%s-%d-%d" % (resolution, i, SIDES.index((label, flags))))
            e = r["frames"][0]["against_rays"]
            errors[i][label] = {"mean_abs": e["mean_abs_visibility_difference"],
                                "wrong_pairs_percent": 100.0 * e["wrong_pairs"] / max(1, e["pairs"])}
    return {"timing": timing, "errors": errors}


def summary(result):
    lines = []
    for resolution, r in result["resolutions"].items():
        t = r["timing"]
        ns = lambda label, row: 1e6 * a_threads * row[label]["shadows_ms"] / row[label]["pairs"]  # noqa: E731
        a_threads = result["machine"]["cpus"]
        lines += ["### 165 spots baked at %s, %s, %d flythrough cameras" % (resolution, result["size"], len(t)), "",
                  "| side | shadow pass, ms (mean; min–max) | core-ns per listed pair (mean) | error vs 81 footprint rays: mean abs visibility difference / pairs on the other side of ½ (first; last camera) |",
                  "|---|---|---|---|"]
        for label, _ in SIDES:
            ms = [row[label]["shadows_ms"] for row in t]
            e = r["errors"]
            err = "; ".join("%.4f / %.2f %%" % (e[k][label]["mean_abs"], e[k][label]["wrong_pairs_percent"]) for k in sorted(e))
            lines.append("| %s | %.1f (%.1f–%.1f) | %.1f | %s |" % (label, sum(ms) / len(ms), min(ms), max(ms),
                                                                 sum(ns(label, row) for row in t) / len(t), err))
        hard = [row["1 ray per pair"]["shadows_ms"] / row["CPVS, unfiltered"]["shadows_ms"] for row in t]
        soft = [row["16 footprint rays per pair"]["shadows_ms"] / row["CPVS, 9x9 PCF"]["shadows_ms"] for row in t]
        lines += ["", "Hard against hard: CPVS %.1f× faster than one ray per pair (per camera %s). Filtered against "
                  "filtered: CPVS 9×9 %.1f× faster than 16 footprint rays (per camera %s)." % (
                      sum(hard) / len(hard), ", ".join("%.1f" % x for x in hard), sum(soft) / len(soft),
                      ", ".join("%.1f" % x for x in soft)), ""]
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="build/bin")
    ap.add_argument("--out", default="out/shadow-speed")
    ap.add_argument("--doc", default="docs/viewer")
    ap.add_argument("--resolutions", default="8k,4k")
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--commit", help="the commit --bin was built from (default: this checkout's HEAD)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    os.makedirs(a.doc, exist_ok=True)
    scene = os.path.join(a.out, "city-spots.glb")
    subprocess.run([os.path.join(a.bin, "cpvs-scenegen"), "city-spots", "--lights", "165", "-o", scene], check=True)
    commit = a.commit or subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    # The command as it ran, with the lookup ISA it was forced to, if any (docs/cli.md, CPVS_LOOKUP_ISA).
    isa = "CPVS_LOOKUP_ISA=%s " % os.environ["CPVS_LOOKUP_ISA"] if "CPVS_LOOKUP_ISA" in os.environ else ""
    result = {"machine": machine_info(), "commit": commit, "bin": a.bin, "size": a.size, "load_average_before": os.getloadavg(),
              "command": isa + "python3 benchmarks/shadow_speed.py " + " ".join(sys.argv[1:]), "resolutions": {}}
    for resolution in a.resolutions.split(","):
        cpvs = os.path.join(a.out, "city-%s.cpvs" % resolution)
        if not os.path.exists(cpvs):
            subprocess.run([os.path.join(a.bin, "cpvs-bake"), scene, "-r", resolution, "-o", cpvs, "-q"], check=True)
        result["resolutions"][resolution] = measure(a, scene, cpvs, resolution)
    result["load_average_after"] = os.getloadavg()
    with open(os.path.join(a.doc, "speed.json"), "w") as f:
        json.dump(result, f, indent=1)
    m = result["machine"]
    text = ("# cpvs-view: CPU shadow pass against rays at the same quality\n\nGenerated by `benchmarks/shadow_speed.py`; "
            "[viewer.md](../viewer.md) explains it.\n\n* Machine: %s, %s logical CPUs; commit %s; load average %.2f "
            "before, %.2f after\n* Command: `%s`\n\n" % (m["model"], m["cpus"], commit, result["load_average_before"][0],
                                                       result["load_average_after"][0], result["command"]) + summary(result))
    with open(os.path.join(a.doc, "speed.md"), "w") as f:
        f.write(text)
    print(text)


if __name__ == "__main__":
    main()
