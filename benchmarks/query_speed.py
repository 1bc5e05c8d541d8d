#!/usr/bin/env python3
"""cpvs-query's lookup throughput, one build against another, alternating: the lookup benchmark's scenes
(benchmarks/lookups.py: TorusKnot, JapaneseTemple, FlightHelmet, Terrain, a sun and a spot each), baked once,
queried by both builds' cpvs-query on the same points, unfiltered and with 9x9 PCF. Each row runs the two
builds in turn, `--rounds` times, their order swapped every round (old-new, new-old, ...), and takes each
build's best; the answers of the two builds are compared byte for byte (the CSVs). The throughput is the
report's `lookups_per_s` (single-threaded, best of --timing-rounds; docs/query.md, "How throughput is
measured"). With --point each scene also gets a point light at its spot's position and range (six cube faces:
the per-point view selection of point lights). Each row also keeps the single-point rate (LightShadow::visibility
one point at a time, `lookups_per_s_single`). Writes DOC (JSON) and prints a table; the load average is taken
before and after.

    python3 benchmarks/query_speed.py --old /tmp/base/build/bin [--new build/bin] [--out out/query-speed]
                                      [--doc docs/query/speed.json] [--resolutions 4k,16k] [--rounds 3] [--point]

Python 3 standard library only. Exit status: 0 done, 1 usage, 2 a tool failed or the answers differ.
"""

import argparse
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from lookups import KERNELS, ROOT, SCENES  # noqa: E402
from machine import machine_info  # noqa: E402


def run(cmd):
    r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if r.returncode != 0:
        sys.stderr.write("query_speed.py: failed (%d): %s\n%s" % (r.returncode, " ".join(cmd), r.stderr))
        sys.exit(2)


def query(binary, cpvs, points, k, out, timing_rounds):
    csv, report = out + ".csv", out + ".json"
    run([os.path.join(binary, "cpvs-query"), cpvs, "--points", points, "-o", csv, "--pcf", str(k), "--report",
         report, "--threads", "2", "--timing-rounds", str(timing_rounds), "--quiet"])
    with open(report) as f:
        figures = json.load(f)
    with open(csv, "rb") as f:
        return figures["lookups_per_s"], figures["lookups_per_s_single"], f.read()


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--old", required=True, help="folder with the baseline build's tools")
    p.add_argument("--new", default=os.path.join(ROOT, "build", "bin"))
    p.add_argument("--out", default=os.path.join(ROOT, "out", "query-speed"))
    p.add_argument("--doc", default=os.path.join(ROOT, "docs", "query", "speed.json"))
    p.add_argument("--resolutions", default="4k,16k")
    p.add_argument("--points", type=int, default=50000)
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--timing-rounds", type=int, default=5)
    p.add_argument("--point", action="store_true", help="also a point light at each scene's spot")
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                            text=True).stdout.strip()
    result = {"machine": machine_info(), "commit": commit, "old": a.old, "new": a.new,
              "command": "python3 benchmarks/query_speed.py " + " ".join(sys.argv[1:]),
              "lookup_isa": os.environ.get("CPVS_LOOKUP_ISA", "best the CPU has"),
              "load_average_before": os.getloadavg(), "rows": []}
    for key, label, scene, _, sun, spot in SCENES:
        points = os.path.join(a.out, key + ".csv")
        run([os.path.join(a.new, "cpvs-sample"), scene, "-n", str(a.points), "--seed", "1", "-o", points])
        for res in a.resolutions.split(","):
            cpvs = os.path.join(a.out, "%s-%s.cpvs" % (key, res))
            lights = ["--sun", sun, "--spot", spot]
            if a.point:
                v = spot.split(",")
                lights += ["--point", ",".join(v[0:3] + [v[7]])]
            run([os.path.join(a.new, "cpvs-bake"), scene, "-o", cpvs, "--resolution", res, *lights, "--quiet"])
            for k in KERNELS:
                best = {"old": 0.0, "new": 0.0}
                single = {"old": 0.0, "new": 0.0}
                answers = {}
                for r in range(a.rounds):
                    for side in (("old", "new") if r % 2 == 0 else ("new", "old")):
                        rate, one, csv = query(a.old if side == "old" else a.new, cpvs, points, k,
                                               os.path.join(a.out, "%s-%s-k%d-%s" % (key, res, k, side)),
                                               a.timing_rounds)
                        best[side] = max(best[side], rate)
                        single[side] = max(single[side], one)
                        answers[side] = csv
                same = answers["old"] == answers["new"]
                row = {"scene": label, "resolution": res, "pcf": k, "old_lookups_per_s": best["old"],
                       "new_lookups_per_s": best["new"], "speedup": best["new"] / best["old"],
                       "old_single_per_s": single["old"], "new_single_per_s": single["new"],
                       "single_speedup": single["new"] / single["old"], "same_answers": same}
                result["rows"].append(row)
                print("%-15s %4s K=%d: old %6.2f M/s, new %6.2f M/s, %.2fx; one at a time %.2fx%s" % (
                    label, res, k, best["old"] / 1e6, best["new"] / 1e6, row["speedup"], row["single_speedup"],
                    "" if same else "  ANSWERS DIFFER"), flush=True)
                if not same:
                    sys.exit(2)
    result["load_average_after"] = os.getloadavg()
    os.makedirs(os.path.dirname(a.doc), exist_ok=True)
    with open(a.doc, "w") as f:
        json.dump(result, f, indent=1)
    print("load average before %s, after %s; written %s" % (
        " ".join("%.2f" % x for x in result["load_average_before"]),
        " ".join("%.2f" % x for x in result["load_average_after"]), a.doc))


if __name__ == "__main__":
    main()
