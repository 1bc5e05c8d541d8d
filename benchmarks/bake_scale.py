#!/usr/bin/env python3
"""Bake speed at the scale of a real level: many lights over a large level, and one sun at large resolutions.

    python3 benchmarks/bake_scale.py [--bin build/bin] [--out out/bake-scale] [--doc docs/many-lights]
                                     [--parts levels,profile,4k,suns] [--levels 1000000,10000000]
                                     [--lights 1000] [--suns 16k,32k,64k,128k] [--threads N]

levels   For each triangle count, `cpvs-scenegen city-spots --triangles T --lights 1000`, baked at 1k twice: the
         first 100 lights (--lights 0-99), then all of them. The cost of one more light is the difference in
         CPU time (user + system) divided by the 900 lights between; memory is each run's peak RSS.
profile  perf (cpu-clock) over the first level's first 200 lights at 1k: the share of the samples in the
         functions that visit every triangle of the scene (reading and flattening it, hashing it, building the
         triangle index), beside the report's load_ms and setup_ms. Skipped when perf is missing.
4k       The first level's lights, all of them, at 4k: time and bytes.
suns     `cpvs-scenegen city --triangles 100000` lit by `--sun 0.4,-1,0.3` at each resolution: wall and CPU time,
         the growth per doubling, peak RSS and bytes (a 256k bake takes about a quarter of an hour here).

Each run's wall time, CPU time and peak RSS come from the operating system (wait4), not from the tool. Writes
DOC/bake-scale.json and prints the markdown tables docs/many-lights.md quotes, with the machine, load average
and commit. Python 3 standard library only."""

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info  # noqa: E402

# Functions that visit every triangle of the scene, once per bake (their names as perf prints them).
WHOLE_SCENE = [r"TriangleBvh::TriangleBvh", r"cpvs::flatten", r"importGltf", r"tinygltf", r"meshopt_", r"draco",
               r"XXH3_64bits_update", r"bakeInputHash", r"classifyMesh", r"findGroundSheets", r"nlohmann"]


def measured(cmd):
    """Runs cmd; returns wall seconds, CPU seconds (user + system) and peak RSS in bytes of that process."""
    print("$ " + " ".join(cmd), flush=True)
    start = time.time()
    proc = subprocess.Popen(cmd)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.time() - start
    code = os.waitstatus_to_exitcode(status)
    if code != 0:
        sys.exit("%s exited with %d" % (cmd[0], code))
    return {"wall_s": wall, "cpu_s": usage.ru_utime + usage.ru_stime, "peak_rss_bytes": usage.ru_maxrss * 1024}


def bake(a, scene, resolution, out, extra):
    report = out + ".json"
    cmd = [os.path.join(a.bin, "cpvs-bake"), scene, "-r", resolution, "-j", str(a.threads), "-o", out + ".cpvs",
           "--report", report, "-q"] + extra
    run = measured(cmd)
    with open(report) as f:
        r = json.load(f)
    run.update({"command": " ".join(cmd), "file_bytes": r["file_bytes"], "lights": len(r["lights"]),
                "load_ms": r.get("load_ms", 0.0), "setup_ms": r.get("setup_ms", 0.0),
                "triangles": r["triangles"]})
    return run


def scenegen(a, kind, triangles, path, extra=()):
    if not os.path.exists(path):
        subprocess.run([os.path.join(a.bin, "cpvs-scenegen"), kind, "--triangles", str(triangles), "-o", path] +
                       list(extra), check=True)
    return path


def level_path(a, triangles):
    return scenegen(a, "city-spots", triangles, os.path.join(a.out, "city-spots-%d.glb" % triangles),
                    ["--lights", str(a.lights)])


def levels(a):
    rows = []
    for triangles in a.levels:
        scene = level_path(a, triangles)
        first = bake(a, scene, "1k", os.path.join(a.out, "level-%d-100" % triangles), ["--lights", "0-99"])
        every = bake(a, scene, "1k", os.path.join(a.out, "level-%d-all" % triangles), [])
        rows.append({"triangles": every["triangles"], "first_100": first, "all": every,
                     "cpu_ms_per_light_beyond_100": 1000 * (every["cpu_s"] - first["cpu_s"]) / (every["lights"] - 100),
                     "rss_ratio": every["peak_rss_bytes"] / first["peak_rss_bytes"]})
    return rows


def profile(a):
    if not shutil.which("perf"):
        print("perf not found: profile skipped")
        return None
    scene = level_path(a, a.levels[0])
    data = os.path.join(a.out, "perf.data")
    out = os.path.join(a.out, "profile-200")
    cmd = ["perf", "record", "-q", "-e", "cpu-clock", "-F", "999", "-o", data, "--",
           os.path.join(a.bin, "cpvs-bake"), scene, "-r", "1k", "--lights", "0-%d" % (min(200, a.lights) - 1), "-j", str(a.threads),
           "-o", out + ".cpvs", "--report", out + ".json", "-q"]
    measured(cmd)
    return analyse_profile(data, out + ".json", " ".join(cmd))


def analyse_profile(data, report, command):
    text = subprocess.run(["perf", "report", "-i", data, "--sort", "sym", "--stdio"], capture_output=True,
                          text=True, check=True).stdout
    symbols = []
    for line in text.splitlines():
        m = re.match(r"\s*([\d.]+)%\s+\[[.k]\]\s+(.*)", line)
        if m:
            symbols.append((float(m.group(1)), m.group(2).strip()))
    whole = [(p, s) for p, s in symbols if any(re.search(w, s) for w in WHOLE_SCENE)]
    with open(report) as f:
        r = json.load(f)
    short = lambda s: s if len(s) < 90 else s[:87] + "..."
    return {"command": command, "top": [{"percent": p, "symbol": short(s)} for p, s in symbols[:12]],
            "whole_scene": [{"percent": p, "symbol": short(s)} for p, s in whole],
            "whole_scene_percent": sum(p for p, _ in whole), "lights": len(r["lights"]), "load_ms": r["load_ms"], "setup_ms": r["setup_ms"],
            "total_ms": r["total_ms"]}


def at_4k(a):
    scene = level_path(a, a.levels[0])
    return bake(a, scene, "4k", os.path.join(a.out, "level-%d-4k" % a.levels[0]), [])


def suns(a):
    scene = scenegen(a, "city", 100000, os.path.join(a.out, "city-100k.glb"))
    rows = []
    for resolution in a.suns:
        before = os.getloadavg()[0]
        run = bake(a, scene, resolution, os.path.join(a.out, "sun-" + resolution), ["--sun", "0.4,-1,0.3"])
        run.update({"resolution": resolution, "commit": a.commit, "load_average_before": before,
                    "load_average_after": os.getloadavg()[0]})
        rows.append(run)
    return rows


def merged_suns(earlier, rows):
    """An earlier run's resolutions that this run did not bake are kept (each row names its commit); the growth
    per doubling is taken between neighbouring rows."""
    by_resolution = {r["resolution"]: r for r in earlier}
    by_resolution.update({r["resolution"]: r for r in rows})
    size = lambda r: int(r[:-1]) * 1024 if r.endswith("k") else int(r)  # noqa: E731
    out = [by_resolution[k] for k in sorted(by_resolution, key=size)]
    for previous, row in zip(out, out[1:]):
        row["cpu_growth"] = row["cpu_s"] / previous["cpu_s"]
    return out


def mb(b):
    return "%.1f MB" % (b / 1e6)


def provenance(part):
    m = part["machine"]
    return "(%s, %s logical CPUs; commit %s; load average %.2f before, %.2f after)" % (
        m["model"], m["cpus"], part["commit"], part["load_average_before"], part["load_average_after"])


def tables(result):
    lines = []
    for name in ("levels", "profile", "4k", "suns"):
        if name in result:
            lines.append("%s %s" % (name, provenance(result[name])))
    lines.append("")
    figures = {name: part["figures"] for name, part in result.items()}
    if figures.get("levels"):
        n = figures["levels"][0]["all"]["lights"]
        lines += ["| level | triangles | 100 lights at 1k: CPU, wall, RSS | %d lights: CPU, wall, RSS | CPU-ms per light beyond 100 | RSS %d / 100 |" % (n, n),
                  "|---|---|---|---|---|---|"]
        for r in figures["levels"]:
            f, e = r["first_100"], r["all"]
            lines.append("| city-spots | %d | %.1f s, %.1f s, %s | %.1f s, %.1f s, %s | %.1f | %.2f |" % (
                r["triangles"], f["cpu_s"], f["wall_s"], mb(f["peak_rss_bytes"]), e["cpu_s"], e["wall_s"],
                mb(e["peak_rss_bytes"]), r["cpu_ms_per_light_beyond_100"], r["rss_ratio"]))
        lines.append("")
    if figures.get("profile"):
        p = figures["profile"]
        lines.append("Profile (perf cpu-clock, %d lights at 1k): %.1f %% of the samples in whole-scene functions "
                     "(load %.0f ms, setup %.0f ms of %.0f ms wall):" % (p["lights"], p["whole_scene_percent"], p["load_ms"],
                                                                         p["setup_ms"], p["total_ms"]))
        lines += ["", "| share | function |", "|---|---|"]
        lines += ["| %.2f %% | `%s` |" % (s["percent"], s["symbol"]) for s in p["top"]]
        lines.append("")
    if figures.get("4k"):
        r = figures["4k"]
        lines.append("All %d lights at 4k: %.1f s wall, %.1f CPU-s, %s file, peak RSS %s." % (
            r["lights"], r["wall_s"], r["cpu_s"], mb(r["file_bytes"]), mb(r["peak_rss_bytes"])))
        lines.append("")
    if figures.get("suns"):
        lines += ["| sun over the closed city (100k triangles) | wall | CPU | CPU growth | peak RSS | bytes |",
                  "|---|---|---|---|---|---|"]
        for r in figures["suns"]:
            lines.append("| %s | %.1f s | %.1f s | %s | %s | %s |" % (
                r["resolution"], r["wall_s"], r["cpu_s"], "×%.2f" % r["cpu_growth"] if "cpu_growth" in r else "",
                mb(r["peak_rss_bytes"]), mb(r["file_bytes"])))
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="build/bin")
    ap.add_argument("--out", default="out/bake-scale")
    ap.add_argument("--doc", default="docs/many-lights")
    ap.add_argument("--parts", default="levels,profile,4k,suns")
    ap.add_argument("--levels", default="1000000,10000000")
    ap.add_argument("--lights", type=int, default=1000)
    ap.add_argument("--suns", default="16k,32k,64k,128k")
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    a = ap.parse_args()
    a.levels = [int(t) for t in a.levels.split(",")]
    a.suns = a.suns.split(",")
    parts = a.parts.split(",")
    os.makedirs(a.out, exist_ok=True)
    os.makedirs(a.doc, exist_ok=True)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    a.commit = commit
    path = os.path.join(a.doc, "bake-scale.json")
    result = {}
    if os.path.exists(path):  # parts this run does not measure keep their earlier figures (each names its commit)
        with open(path) as f:
            result = json.load(f)
    for name, measure in (("levels", levels), ("profile", profile), ("4k", at_4k), ("suns", suns)):
        if name in parts:
            before = os.getloadavg()[0]
            figures = measure(a)
            if name == "suns" and "suns" in result:
                figures = merged_suns(result["suns"]["figures"], figures)
            result[name] = {"commit": commit, "machine": machine_info(), "load_average_before": before,
                            "load_average_after": os.getloadavg()[0], "figures": figures}
    with open(path, "w") as f:
        json.dump(result, f, indent=1)
    print()
    print(tables(result))

if __name__ == "__main__":
    main()
