#!/usr/bin/env python3
"""Format 3.0 against 2.0 on the benchmark bakes: bytes, bake time and peak memory, the time an open takes, and
whether both files answer alike. Each case is baked by one cpvs-bake build with --format-version 2 and 3,
alternating (2-3, then 3-2, ...) for --rounds rounds; each bake records wall and CPU seconds and peak RSS
(wait4), the load average before and after. Then both files are queried by cpvs-query on the same points
(cpvs-sample on the scene), unfiltered and with 9x9 PCF: the answers must be equal byte for byte, and each
file's lookup rate (the report's lookups_per_s, single-threaded best of rounds) and the wall time of opening it
and answering one point are kept.

    python3 benchmarks/format3.py [--bin build/bin] [--out out/format3] [--doc docs/format3/sizes.json]
                                  [--cases spots8k,points2k,sun16k,spots1000] [--rounds 2] [--threads 2]

Cases (the study's, docs/format-3-study.md): spots8k, `cpvs-scenegen city-spots --lights 165` at 8k; points2k,
its 165 lights as point lights (990 cube faces) at 2k; sun16k, `cpvs-scenegen city` with --sun 0.4,-1,0.3 at 16k;
spots1000, `city-spots --triangles 1000000 --lights 1000` at 1k (the 1,000-light level). Writes --doc (every
figure, the commit, the machine) and prints a markdown table. Python 3 standard library only. Exit status: 0 done,
2 a tool failed or the answers differ."""

import argparse
import filecmp
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bake_scale import measured  # noqa: E402
from machine import machine_info  # noqa: E402
from many_lights import point_lights_of  # noqa: E402
from uniform_tiles import load_average  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def head_commit():
    run = lambda *cmd: subprocess.run(["git", *cmd], capture_output=True, text=True, cwd=ROOT).stdout.strip()
    return run("rev-parse", "--short", "HEAD") + ("-dirty" if run("status", "--porcelain", "--untracked-files=no") else "")


def tool(a, name, *args, capture=False):
    cmd = [os.path.join(a.bin, name), *args]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.stderr.write("format3.py: failed (%d): %s\n%s" % (r.returncode, " ".join(cmd), r.stderr))
        sys.exit(2)
    return r.stdout if capture else None


def cases(a):
    """name -> (scene, resolution, light arguments)"""
    def scene(name, *gen):
        path = os.path.join(a.out, name + ".glb")
        if not os.path.exists(path):
            tool(a, "cpvs-scenegen", *gen, "-o", path)
        return path
    out = {}
    for name in a.cases.split(","):
        if name == "spots8k":
            out[name] = (scene("spots165", "city-spots", "--lights", "165"), "8k", [])
        elif name == "points2k":
            spots = scene("spots165", "city-spots", "--lights", "165")
            lights = []
            for p in point_lights_of(spots):
                lights += ["--point", p]
            out[name] = (spots, "2k", lights)
        elif name == "sun16k":
            out[name] = (scene("city", "city"), "16k", ["--sun", "0.4,-1,0.3"])
        elif name == "spots1000":
            out[name] = (scene("spots1000", "city-spots", "--triangles", "1000000", "--lights", "1000"), "1k", [])
        else:
            sys.exit("format3.py: unknown case " + name)
    return out


def bake(a, scene, resolution, lights, version, path):
    cmd = [os.path.join(a.bin, "cpvs-bake"), scene, "-r", resolution, *lights, "-j", str(a.threads),
           "--format-version", str(version), "-o", path, "-q"]
    before = load_average()
    run = measured(cmd)
    run.update({"command": " ".join(cmd if not lights else cmd[:4] + ["(%d lights)" % (len(lights) // 2)] + cmd[4 + len(lights):]),
                "file_bytes": os.path.getsize(path), "load_before": before, "load_after": load_average()})
    return run


def query(a, cpvs, points, k, out):
    tool(a, "cpvs-query", cpvs, "--points", points, "-o", out + ".csv", "--pcf", str(k), "--report", out + ".json",
         "--threads", "1", "--timing-rounds", "3", "--quiet")
    with open(out + ".json") as f:
        return json.load(f)["lookups_per_s"]


def open_seconds(a, cpvs, one_point):
    """Wall seconds of cpvs-query opening the file and answering one point: the open, mostly."""
    cmd = [os.path.join(a.bin, "cpvs-query"), cpvs, "--points", one_point, "-o", os.devnull, "--quiet"]
    return measured(cmd)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default=os.path.join(ROOT, "build", "bin"))
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "format3"))
    ap.add_argument("--doc", default=os.path.join(ROOT, "docs", "format3", "sizes.json"))
    ap.add_argument("--cases", default="spots8k,points2k,sun16k,spots1000")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--points", type=int, default=200000)
    ap.add_argument("--lookups-only", action="store_true",
                    help="bake nothing: query and open the files a previous run left in --out (after a change to "
                         "the reader or the walks, which leaves the files' bytes as they were)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    results = []
    for name, (scene, resolution, lights) in cases(a).items():
        runs = {2: [], 3: []}
        for r in range(0 if a.lookups_only else a.rounds):
            for version in ((2, 3) if r % 2 == 0 else (3, 2)):
                path = os.path.join(a.out, "%s_v%d.cpvs" % (name, version))
                runs[version].append(bake(a, scene, resolution, lights, version, path))
        points = os.path.join(a.out, name + "_points.csv")
        if not (a.lookups_only and os.path.exists(points)):
            tool(a, "cpvs-sample", scene, "-o", points, "--count", str(a.points))
        one = os.path.join(a.out, name + "_one.csv")
        with open(points) as f, open(one, "w") as g:
            g.write(f.readline())
            g.write(f.readline())
        row = {"case": name, "scene": os.path.relpath(scene, ROOT), "resolution": resolution,
               "lights_given": len(lights) // 2, "bakes": {str(v): runs[v] for v in runs}}
        for k in (1, 9):
            rates = {}
            for version in ((2, 3) if k == 1 else (3, 2)):
                rates[version] = query(a, os.path.join(a.out, "%s_v%d.cpvs" % (name, version)), points, k,
                                       os.path.join(a.out, "%s_v%d_k%d" % (name, version, k)))
            same = filecmp.cmp(os.path.join(a.out, "%s_v2_k%d.csv" % (name, k)),
                               os.path.join(a.out, "%s_v3_k%d.csv" % (name, k)), shallow=False)
            if not same:
                sys.stderr.write("format3.py: %s: the 2.0 and 3.0 files answer differently (K = %d)\n" % (name, k))
                sys.exit(2)
            row["lookups_per_s_k%d" % k] = {str(v): rates[v] for v in rates}
        row["open_and_one_point"] = {}
        for r in range(a.rounds):  # alternating, the best kept
            for v in ((2, 3) if r % 2 == 0 else (3, 2)):
                run = open_seconds(a, os.path.join(a.out, "%s_v%d.cpvs" % (name, v)), one)
                best = row["open_and_one_point"].get(str(v))
                if best is None or run["wall_s"] < best["wall_s"]:
                    row["open_and_one_point"][str(v)] = run
        if a.lookups_only:
            row["file_bytes"] = {str(v): os.path.getsize(os.path.join(a.out, "%s_v%d.cpvs" % (name, v))) for v in (2, 3)}
        results.append(row)
        print(json.dumps(row, indent=1), flush=True)
    doc = {"commit": head_commit(), "machine": machine_info(), "threads": a.threads, "rounds": a.rounds,
           "load_average_end": load_average(),
           "command": "python3 benchmarks/format3.py " + " ".join(sys.argv[1:]), "cases": results}
    os.makedirs(os.path.dirname(a.doc), exist_ok=True)
    with open(a.doc, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    print("| case | 2.0 bytes | 3.0 bytes | 3.0 / 2.0 | bake wall 2.0 / 3.0 (best, s) | peak RSS 2.0 / 3.0 (MB) | "
          "open + 1 point 2.0 / 3.0 (s) | lookups/s K=1 2.0 / 3.0 | K=9 2.0 / 3.0 |")
    print("|---|---|---|---|---|---|---|---|---|")
    for row in results:
        if a.lookups_only:
            o = row["open_and_one_point"]
            print("| %s | %d | %d | %.3f | - | - | %.2f / %.2f | %.3g / %.3g | %.3g / %.3g |" % (
                row["case"], row["file_bytes"]["2"], row["file_bytes"]["3"],
                row["file_bytes"]["3"] / row["file_bytes"]["2"], o["2"]["wall_s"], o["3"]["wall_s"],
                row["lookups_per_s_k1"]["2"], row["lookups_per_s_k1"]["3"],
                row["lookups_per_s_k9"]["2"], row["lookups_per_s_k9"]["3"]))
            continue
        b2, b3 = row["bakes"]["2"], row["bakes"]["3"]
        best = lambda runs, key: min(r[key] for r in runs)
        o = row["open_and_one_point"]
        print("| %s | %d | %d | %.3f | %.1f / %.1f | %.0f / %.0f | %.2f / %.2f | %.3g / %.3g | %.3g / %.3g |" % (
            row["case"], b2[0]["file_bytes"], b3[0]["file_bytes"], b3[0]["file_bytes"] / b2[0]["file_bytes"],
            best(b2, "wall_s"), best(b3, "wall_s"), best(b2, "peak_rss_bytes") / 1e6, best(b3, "peak_rss_bytes") / 1e6,
            o["2"]["wall_s"], o["3"]["wall_s"], row["lookups_per_s_k1"]["2"], row["lookups_per_s_k1"]["3"],
            row["lookups_per_s_k9"]["2"], row["lookups_per_s_k9"]["3"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
