#!/usr/bin/env python3
"""A bake's work and span against its wall time: does the report predict the speed on N cores?

cpvs-bake's report gives the bake's work (CPU time of every thread) and its span (the longest chain of work that
must run on one thread: setup, per view the rendering lane's serial work or the DAG's construction beside it,
whichever is longer, then the DAG's encoding; docs/construction.md, "Work and span"). On N cores a bake then
takes at least max(work / N, span) and, scheduled ideally, at most work / N + span. This bakes each case with
each thread count, alternating (rounds of 1, 2, ... threads), and prints the measured wall time (wait4) beside
the two bounds, with the CPU model and the load average. Writes DOC/work-span.json.

    python3 benchmarks/work_span.py [--bin build/bin] [--out out/work-span] [--doc docs/construction]
                                    [--cases city16k,city64k,spots8k] [--threads 1,2] [--rounds 2]
                                    [--compare OLD/bin] [--name work-span]

With --compare, each bake runs with both builds in turn (OLD then NEW, NEW then OLD in the next round), the
files compared byte for byte, and the table has a row per build.
"""
import argparse
import json
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
from machine import machine_info  # noqa: E402

CASES = {
    "city16k": ("closed city's sun at 16k", "city.glb", ["-r", "16k", "--sun", "0.4,-1,0.3"]),
    "city64k": ("closed city's sun at 64k", "city.glb", ["-r", "64k", "--sun", "0.4,-1,0.3"]),
    "city256k": ("closed city's sun at 256k", "city.glb", ["-r", "256k", "--sun", "0.4,-1,0.3"]),
    "spots8k": ("165 spots at 8k", "city-spots.glb", ["-r", "8k"]),
}


def load():
    with open("/proc/loadavg") as f:
        return float(f.read().split()[0])


def timed(cmd):
    """Wall seconds of cmd, measured around the child (its CPU is in the report)."""
    start = time.monotonic()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    _, err = proc.communicate()
    wall = time.monotonic() - start
    if proc.returncode != 0:
        sys.exit("%s failed (%d): %s" % (" ".join(cmd), proc.returncode, err))
    return wall


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--bin", default=os.path.join(ROOT, "build", "bin"))
    p.add_argument("--out", default=os.path.join(ROOT, "out", "work-span"))
    p.add_argument("--doc", default=os.path.join(ROOT, "docs", "construction"))
    p.add_argument("--cases", default="city16k,city64k,spots8k")
    p.add_argument("--threads", default="1,2")
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--compare", default="", help="another build's bin folder, run alternating with --bin")
    p.add_argument("--name", default="work-span", help="the JSON's name in --doc")
    a = p.parse_args()
    builds = [("new", a.bin)] + ([("old", a.compare)] if a.compare else [])
    os.makedirs(a.out, exist_ok=True)
    os.makedirs(a.doc, exist_ok=True)
    b = lambda name: os.path.join(a.bin, name)
    scenes = {"city.glb": ["city"], "city-spots.glb": ["city-spots", "--lights", "165"]}
    for name, args in scenes.items():
        if not os.path.exists(os.path.join(a.out, name)):
            subprocess.run([b("cpvs-scenegen")] + args + ["-o", os.path.join(a.out, name)], check=True,
                           stdout=subprocess.DEVNULL)
    threads = [int(t) for t in a.threads.split(",")]
    commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], stdout=subprocess.PIPE,
                            text=True).stdout.strip()
    result = {"machine": machine_info(), "commit": commit, "date": time.strftime("%Y-%m-%d"),
              "command": " ".join(sys.argv), "runs": []}
    for key in a.cases.split(","):
        title, scene, args = CASES[key]
        for r in range(a.rounds):
            for t in (threads if r % 2 == 0 else threads[::-1]):
                order = builds if (r + threads.index(t)) % 2 == 0 else builds[::-1]
                if a.compare:
                    order = order[::-1]  # the old build first in the first round
                outputs = []
                for label, folder in order:
                    report = os.path.join(a.out, "%s-%s-j%d-r%d.json" % (key, label, t, r))
                    output = os.path.join(a.out, "%s-%s.cpvs" % (key, label))
                    cmd = [os.path.join(folder, "cpvs-bake"), os.path.join(a.out, scene)] + args + [
                        "-j", str(t), "-q", "-o", output, "--report", report]
                    before = load()
                    wall = timed(cmd)
                    with open(report) as f:
                        rep = json.load(f)
                    work = rep["work"]
                    bounds = work["wall_bounds_ms"][str(t)]
                    bake_s = (rep["total_ms"] - rep["load_ms"]) / 1000.0
                    run = {"case": key, "title": title, "build": label, "threads": t, "round": r, "wall_s": wall,
                           "bake_s": bake_s, "cpu_s": work["cpu_ms"] / 1000.0, "span_s": work["span_ms"] / 1000.0,
                           "serial_fraction": work["serial_fraction"], "lower_s": bounds[0] / 1000.0,
                           "upper_s": bounds[1] / 1000.0, "load_before": before, "load_after": load()}
                    result["runs"].append(run)
                    outputs.append(output)
                    print("%s %s -j %d: wall %.2f s (bake %.2f s), work %.2f CPU-s, span %.2f s (%.1f %%), bounds "
                          "%.2f-%.2f s" % (key, label, t, wall, bake_s, run["cpu_s"], run["span_s"],
                                           100 * run["serial_fraction"], run["lower_s"], run["upper_s"]), flush=True)
                if len(outputs) == 2:
                    with open(outputs[0], "rb") as f0, open(outputs[1], "rb") as f1:
                        if f0.read() != f1.read():
                            sys.exit("%s -j %d: the two builds wrote different bytes" % (key, t))
    with open(os.path.join(a.doc, a.name + ".json"), "w") as f:
        json.dump(result, f, indent=1)
        f.write("\n")
    m = result["machine"]
    print("\n%s, %s logical CPUs; commit %s; load %.2f-%.2f\n" % (
        m["model"], m["cpus"], commit, min(r["load_before"] for r in result["runs"]),
        max(r["load_after"] for r in result["runs"])))
    print("| case | build | -j | bake wall (best, s) | work (CPU-s) | span (s) | serial share | at least | at most "
          "(ideal scheduling) | wall / at most |\n|---|---|---|---|---|---|---|---|---|---|")
    for key in a.cases.split(","):
        for t in threads:
            for label, _ in builds:
                runs = [r for r in result["runs"] if r["case"] == key and r["threads"] == t and r["build"] == label]
                best = min(runs, key=lambda r: r["bake_s"])
                print("| %s | %s | %d | %.2f | %.2f | %.2f | %.1f %% | %.2f | %.2f | %.2f |" % (
                    best["title"], label, t, best["bake_s"], best["cpu_s"], best["span_s"],
                    100 * best["serial_fraction"], best["lower_s"], best["upper_s"], best["bake_s"] / best["upper_s"]))


if __name__ == "__main__":
    main()
