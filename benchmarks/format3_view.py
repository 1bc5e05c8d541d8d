#!/usr/bin/env python3
"""cpvs-view's CPU shadow pass over a 2.0 file and its 3.0 twin: does one pool that every view reads (shared
subtrees in shared cache lines) make the many-light lookups faster where a pixel's pairs walk many views in
turn, as the format 3.0 study measured for deep lookups?

    python3 benchmarks/format3_view.py [--bin build/bin] [--out out/format3] [--case spots8k]
                                       [--frames 4] [--size 1920x1080] [--doc docs/format3/view.json]

Reads the case's files that benchmarks/format3.py left in --out (CASE_v2.cpvs, CASE_v3.cpvs, and the scene
spots165.glb: the generated city with 165 spot lights), and times cpvs-view --shadows cpu, unfiltered and 9x9,
from --frames cameras of benchmarks/viewer.py's flythrough: for every camera and kernel both files run in their
own processes on a path of that camera twice, alternating (the order turned camera by camera), and the second
frame's shadow pass is kept. Prints a table and writes --doc with the machine, the commit and the load average.
Python 3 standard library only.
"""
import argparse
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info  # noqa: E402
from shadow_speed import view  # noqa: E402
from viewer import flythrough  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default=os.path.join(ROOT, "build", "bin"))
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "format3"))
    ap.add_argument("--case", default="spots8k")
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--doc", default=os.path.join(ROOT, "docs", "format3", "view.json"))
    a = ap.parse_args()
    scene = os.path.join(a.out, "spots165.glb")
    files = {v: os.path.join(a.out, "%s_v%d.cpvs" % (a.case, v)) for v in (2, 3)}
    for path in [scene] + list(files.values()):
        if not os.path.exists(path):
            sys.exit("format3_view.py: %s is missing: run benchmarks/format3.py --cases %s first" % (path, a.case))
    every = flythrough(8)
    n = max(2, min(a.frames, 8))
    cameras = [every[k] for k in sorted({round(j * 7 / (n - 1)) for j in range(n)})]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT).stdout.strip()
    isa = "CPVS_LOOKUP_ISA=%s " % os.environ["CPVS_LOOKUP_ISA"] if "CPVS_LOOKUP_ISA" in os.environ else ""
    result = {"machine": machine_info(), "commit": commit, "size": a.size, "load_average_before": os.getloadavg(),
              "command": isa + "python3 benchmarks/format3_view.py " + " ".join(sys.argv[1:]), "runs": []}
    for i, camera in enumerate(cameras):
        for k in (1, 9):
            for v in ((2, 3) if (i + k) % 2 == 0 else (3, 2)):
                r = view(a, scene, files[v], [camera, camera], ["--shadows", "cpu", "--pcf", str(k)],
                         "view-%d-k%d-v%d" % (i, k, v))
                frame = r["frames"][1]
                result["runs"].append({"camera": i, "pcf": k, "version": v, "shadows_ms": frame["passes_ms"]["shadows"],
                                       "pairs": frame["light_lists"]["pairs_listed"]})
    result["load_average_after"] = os.getloadavg()
    os.makedirs(os.path.dirname(a.doc), exist_ok=True)
    with open(a.doc, "w") as f:
        json.dump(result, f, indent=1)
        f.write("\n")
    cpus = result["machine"]["cpus"]
    print("| K | camera | 2.0 shadow pass ms | 3.0 shadow pass ms | 2.0 / 3.0 | core-ns per pair 2.0 / 3.0 |")
    print("|---|---|---|---|---|---|")
    for k in (1, 9):
        for i in range(len(cameras)):
            r = {x["version"]: x for x in result["runs"] if x["camera"] == i and x["pcf"] == k}
            ns = lambda x: 1e6 * cpus * x["shadows_ms"] / max(1, x["pairs"])  # noqa: E731
            print("| %d | %d | %.1f | %.1f | %.2f | %.1f / %.1f |" % (k, i, r[2]["shadows_ms"], r[3]["shadows_ms"],
                                                                    r[2]["shadows_ms"] / r[3]["shadows_ms"], ns(r[2]), ns(r[3])))
    return 0


if __name__ == "__main__":
    sys.exit(main())
