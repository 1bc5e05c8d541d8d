#!/usr/bin/env python3
"""Bytes against error for lossless and lossy bakes (docs/lossy.md): a sun's file size and its misclassified
facing pairs against the reference rays, at several resolutions and --max-voxel-error bounds.

    python3 benchmarks/lossy.py [--bin build/bin] [--out out/lossy] [--json docs/lossy/bytes-vs-error.json]
                                [--scenes foliage,city] [--lossless 4k,8k,16k,32k,64k]
                                [--lossy 32k:0,0e2,16e2 --lossy 64k:0,0e2,16e2,32e2] [--points 200000] [--threads 2]

A lossy setting is D (--max-voxel-error D) or DeK (--max-voxel-error D --max-edge-error K).

    python3 benchmarks/lossy.py --changed [--out out/lossy] [--json docs/lossy/bytes-vs-error.json]

adds to each lossy run of --json the answers that differ from the lossless bake's at the same resolution
(cpvs-query at the same points, unfiltered or with --pcf K; only facing pairs can differ), from the bakes left in
--out.

    python3 benchmarks/lossy.py --alternate RES:SETTING [--scenes foliage] [--rounds 2]
                                [--json docs/lossy/bake-cost.json]

bakes lossless and with SETTING (D or DeK) in turn, --rounds times: wall and CPU seconds, peak RSS (wait4) and the
report's phases of each, with the load average before and after each bake.

    python3 benchmarks/lossy.py --lookups FILE.cpvs,FILE.cpvs,... --points P.csv [--rounds 2]
                                [--json docs/lossy/lookups.json]

times cpvs-query's lookups on each file (hard and 9x9 PCF, --timing-rounds 7), the files taken in turn
(alternating), --rounds times: are lookups on lossy files as fast as on lossless ones.

With --scene-file, a scene of your own (e.g. data/scenes/JapaneseBridgeGarden/scene.glb, named by its folder)
under --sun instead. Scenes: `foliage` is `cpvs-scenegen foliage` (1,606 instanced trees of alpha-tested leaf cards) with its own
sun; `city` is the closed city of the bake-scale benchmark (`cpvs-scenegen city --triangles 100000`) under
`--sun 0.4,-1,0.3`. Each scene gets `cpvs-sample` points once; every bake is queried at them with
`cpvs-query --reference` (unfiltered lookups against Embree rays, alpha-aware), which gives the misclassified
facing pairs and both lit fractions. Bytes and errors do not depend on the machine; wall times (one run each,
not alternated) and the load average are recorded as a guide. Writes --json and prints a markdown table.
Python 3 standard library only."""

import argparse
import json
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info  # noqa: E402
from uniform_tiles import load_average  # noqa: E402

SCENES = {
    "foliage": {"generate": ["foliage"], "light": ["--lights", "sun"]},
    "city": {"generate": ["city", "--triangles", "100000"], "light": ["--sun", "0.4,-1,0.3"]},
}


def head_commit():
    here = os.path.dirname(os.path.abspath(__file__))
    run = lambda *cmd: subprocess.run(["git", *cmd], capture_output=True, text=True, cwd=here).stdout.strip()
    return run("rev-parse", "--short", "HEAD") + ("-dirty" if run("status", "--porcelain", "--untracked-files=no") else "")


def save(a, result, more=""):
    """Writes --json with the load average after, and prints the machine line above the table."""
    result["load_after"] = load_average()
    os.makedirs(os.path.dirname(a.json) or ".", exist_ok=True)
    with open(a.json, "w") as f:
        json.dump(result, f, indent=1)
    print("\nMachine: %s, %s CPUs; commit %s; load %.2f before, %.2f after%s\n" % (
        result["machine"]["model"], result["machine"]["cpus"], result["commit"], result["load_before"],
        result["load_after"], more))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bin", default="build/bin")
    parser.add_argument("--out", default="out/lossy")
    parser.add_argument("--json", default="docs/lossy/bytes-vs-error.json")
    parser.add_argument("--scenes", default="foliage,city")
    parser.add_argument("--scene-file", default="", help="a glTF scene of your own instead of --scenes (with --sun)")
    parser.add_argument("--sun", default="0.35,-1,0.45", help="with --scene-file: the sun's direction")
    parser.add_argument("--lossless", default="4k,8k,16k,32k,64k")
    parser.add_argument("--lossy", action="append", help="RES:D,DeK,... (repeatable)")
    parser.add_argument("--points", type=int, default=200000)
    parser.add_argument("--points-file", default="", help="with --lookups: the points to look up")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--lookups", default="", help="FILE,FILE,...: time the lookups on these files instead")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--changed", action="store_true", help="add answers changed against lossless to --json")
    parser.add_argument("--pcf", type=int, default=1, help="with --changed: the lookups' PCF kernel")
    parser.add_argument("--alternate", default="", help="RES:SETTING: time lossless and lossy bakes in turn")
    a = parser.parse_args()
    if a.lookups:
        return lookups(a)
    if a.changed:
        return changed(a)
    if a.alternate:
        return alternate(a)
    lossy = a.lossy or ["32k:0,0e2,16e2", "64k:0,0e2,16e2,32e2"]
    os.makedirs(a.out, exist_ok=True)
    tool = lambda name: os.path.join(a.bin, name)
    result = {"commit": head_commit(), "machine": machine_info(), "load_before": load_average(),
              "points": a.points, "threads": a.threads, "runs": []}
    plan = [(res, None) for res in a.lossless.split(",") if res]
    for spec in lossy:
        res, _, bounds = spec.partition(":")
        plan += [(res, tuple(int(v) for v in (d.split("e") + ["0"])[:2])) for d in bounds.split(",") if d]
    if a.scene_file:
        name = os.path.splitext(os.path.basename(os.path.dirname(os.path.abspath(a.scene_file))))[0]
        SCENES[name] = {"path": a.scene_file, "light": ["--sun", a.sun]}
        a.scenes = name
    for name in a.scenes.split(","):
        scene = SCENES[name].get("path") or os.path.join(a.out, name + ".glb")
        points = os.path.join(a.out, name + "-points.csv")
        if not os.path.exists(scene):
            subprocess.run([tool("cpvs-scenegen")] + SCENES[name]["generate"] + ["-o", scene], check=True)
        if not os.path.exists(points):
            subprocess.run([tool("cpvs-sample"), scene, "-o", points, "-n", str(a.points)], check=True)
        for res, bound in plan:
            tag = "%s-%s-%s" % (name, res, "lossless" if bound is None else "d%de%d" % bound)
            out = os.path.join(a.out, tag)
            cmd = [tool("cpvs-bake"), scene, "-o", out + ".cpvs", "-r", res, "-j", str(a.threads), "--quiet",
                   "--report", out + ".json"] + SCENES[name]["light"]
            if bound is not None:
                cmd += ["--max-voxel-error", str(bound[0])] + (["--max-edge-error", str(bound[1])] if bound[1] else [])
            load = load_average()
            start = time.monotonic()
            subprocess.run(cmd, check=True)
            wall = time.monotonic() - start
            subprocess.run([tool("cpvs-query"), out + ".cpvs", "--points", points, "-o", out + "-vis.csv",
                            "--reference", scene, "--report", out + "-query.json", "--timing-rounds", "0",
                            "--quiet"], check=True)
            with open(out + ".json") as f:
                view = json.load(f)["lights"][0]["views"][0]
            with open(out + "-query.json") as f:
                ref = json.load(f)["lights"][0]["reference"]
            run = {"scene": name, "resolution": res, "max_voxel_error": None if bound is None else bound[0],
                   "max_edge_error": 0 if bound is None else bound[1], "command": " ".join(cmd),
                   "bytes": os.path.getsize(out + ".cpvs"), "wall_s": wall, "load_before": load,
                   "phases_ms": view["phases_ms"], "free_voxels_lit": view.get("free_voxels_lit", 0),
                   "voxels_delayed": view.get("voxels_delayed", 0), "leaves_merged": view.get("leaves_merged", 0),
                   "facing_points": ref["facing_points"],
                   "misclassified_facing": ref["misclassified_facing"],
                   "misclassified_uniform": ref["misclassified_uniform"],
                   "lit_fraction": ref["cpvs_lit_fraction"], "reference_lit_fraction": ref["reference_lit_fraction"]}
            result["runs"].append(run)
            print("%s: %d bytes, %.3f %% misclassified facing, %.1f s" % (
                tag, run["bytes"], 100 * run["misclassified_facing"], wall), flush=True)
            os.remove(out + "-vis.csv")
    save(a, result, "; %d sample points per scene" % a.points)
    print("| scene | sun at | --max-voxel-error | --max-edge-error | bytes | misclassified facing pairs | "
          "lit fraction (rays) | voxels delayed | leaves merged | bake wall (s) | next-surface pass (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in result["runs"]:
        lossless = r["max_voxel_error"] is None
        print("| %s | %s | %s | %s | %.1f MB | %.3f %% | %.2f %% (%.2f %%) | %s | %s | %.1f | %s |" % (
            r["scene"], r["resolution"], "lossless" if lossless else r["max_voxel_error"],
            r["max_edge_error"] or "", r["bytes"] / 1e6, 100 * r["misclassified_facing"], 100 * r["lit_fraction"],
            100 * r["reference_lit_fraction"], "" if lossless else "{:,}".format(r["voxels_delayed"]),
            "{:,}".format(r["leaves_merged"]) if r["max_edge_error"] else "", r["wall_s"],
            "" if lossless else "%.1f" % (r["phases_ms"].get("next_surface", 0) / 1000)))


def alternate(a):
    """Lossless and lossy bakes of one scene in turn: what the lossy options cost or save in time and memory."""
    from bake_scale import measured  # noqa: E402
    res, _, setting = a.alternate.partition(":")
    d, _, k = setting.partition("e")
    name = a.scenes.split(",")[0]
    scene = os.path.join(a.out, name + ".glb")
    if not os.path.exists(scene):
        os.makedirs(a.out, exist_ok=True)
        subprocess.run([os.path.join(a.bin, "cpvs-scenegen")] + SCENES[name]["generate"] + ["-o", scene], check=True)
    lossy = ["--max-voxel-error", d] + (["--max-edge-error", k] if k and k != "0" else [])
    result = {"commit": head_commit(), "machine": machine_info(), "scene": name, "resolution": res,
              "setting": setting, "load_before": load_average(), "runs": []}
    for rnd in range(a.rounds):
        for label, extra in (("lossless", []), ("lossy " + setting, lossy)):
            out = os.path.join(a.out, "alternate")
            cmd = [os.path.join(a.bin, "cpvs-bake"), scene, "-o", out + ".cpvs", "-r", res, "-j", str(a.threads),
                   "--quiet", "--report", out + ".json"] + SCENES[name]["light"] + extra
            load = load_average()
            run = measured(cmd)
            with open(out + ".json") as f:
                report = json.load(f)
            phases = {}
            for view in report["lights"][0]["views"]:
                for key, ms in view["phases_ms"].items():
                    phases[key] = phases.get(key, 0.0) + ms / 1000.0
            run.update({"round": rnd, "bake": label, "bytes": report["file_bytes"], "phases_s": phases,
                        "load_before": load, "load_after": load_average()})
            result["runs"].append(run)
    save(a, result, "; %s sun at %s, -j %d" % (name, res, a.threads))
    print("| bake | wall s | CPU s | peak RSS | bytes | depth s | next surface s | masks s | DAG s | load before / after |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in result["runs"]:
        p = r["phases_s"]
        print("| %s | %.1f | %.1f | %.2f GB | %s | %.1f | %.1f | %.1f | %.1f | %.2f / %.2f |" % (
            r["bake"], r["wall_s"], r["cpu_s"], r["peak_rss_bytes"] / 1e9, "{:,}".format(r["bytes"]),
            p.get("depth", 0), p.get("next_surface", 0), p.get("masks", 0), p.get("dag", 0), r["load_before"],
            r["load_after"]))


def answers(a, cpvs, points):
    out = os.path.join(a.out, "answers.csv")
    subprocess.run([os.path.join(a.bin, "cpvs-query"), cpvs, "--points", points, "-o", out, "--timing-rounds", "0",
                    "--pcf", str(a.pcf), "--quiet"], check=True)
    with open(out) as f:
        rows = f.read().split("\n")
    os.remove(out)
    return rows


def changed(a):
    """Per lossy run, the points whose answer differs from the lossless bake's at the same resolution."""
    with open(a.json) as f:
        result = json.load(f)
    lossless = {}
    for r in result["runs"]:
        if r["max_voxel_error"] is None:
            continue
        tag = "%s-%s-d%de%d" % (r["scene"], r["resolution"], r["max_voxel_error"], r["max_edge_error"])
        points = os.path.join(a.out, r["scene"] + "-points.csv")
        key = (r["scene"], r["resolution"])
        if key not in lossless:
            lossless[key] = answers(a, os.path.join(a.out, "%s-%s-lossless.cpvs" % key), points)
        mine = answers(a, os.path.join(a.out, tag + ".cpvs"), points)
        base = lossless[key]
        key = "answers_changed" if a.pcf == 1 else "answers_changed_pcf%d" % a.pcf
        pairs = [(float(x), float(y)) for x, y in zip(base[1:], mine[1:]) if x.strip() and y.strip()]
        r[key] = sum(1 for x, y in pairs if x != y)
        if a.pcf > 1:  # filtered answers: how much they move, and the mean visibility (light leaking is +)
            r[key + "_by_more_than_0.1"] = sum(1 for x, y in pairs if abs(x - y) > 0.1)
            r[key + "_mean_abs"] = sum(abs(x - y) for x, y in pairs) / len(pairs)
            r[key + "_mean_visibility"] = [sum(x for x, _ in pairs) / len(pairs), sum(y for _, y in pairs) / len(pairs)]
        print("%s: %d answers differ from lossless at %dx%d PCF (%.3f %% of %d facing pairs)" % (
            tag, r[key], a.pcf, a.pcf, 100 * r[key] / r["facing_points"], r["facing_points"]))
    with open(a.json, "w") as f:
        json.dump(result, f, indent=1)


def lookups(a):
    """Throughput of cpvs-query on each file, hard and 9x9 PCF, files alternating."""
    files = a.lookups.split(",")
    points = a.points_file
    result = {"commit": head_commit(), "machine": machine_info(), "load_before": load_average(), "points": points,
              "runs": []}
    for rnd in range(a.rounds):
        for path in files:
            for pcf in (1, 9):
                report = os.path.join(a.out, "lookups.json")
                load = load_average()
                subprocess.run([os.path.join(a.bin, "cpvs-query"), path, "--points", points, "--pcf", str(pcf),
                                "-o", os.path.join(a.out, "lookups.csv"), "--report", report, "--timing-rounds", "7",
                                "--quiet"], check=True)
                with open(report) as f:
                    r = json.load(f)
                run = {"round": rnd, "file": path, "bytes": os.path.getsize(path), "pcf": pcf,
                       "lookups_per_s": r["lookups_per_s"], "load_before": load}
                result["runs"].append(run)
                print("round %d %s pcf %d: %.3g lookups/s" % (rnd, path, pcf, run["lookups_per_s"]), flush=True)
    save(a, result)
    print("| file | bytes | " + " | ".join("round %d hard | round %d 9x9" % (r, r) for r in range(a.rounds)) + " |")
    print("|---|---|" + "---|---|" * a.rounds)
    for path in files:
        cells = []
        for rnd in range(a.rounds):
            for pcf in (1, 9):
                v = [x for x in result["runs"] if x["file"] == path and x["round"] == rnd and x["pcf"] == pcf][0]
                cells.append("%.3g /s" % v["lookups_per_s"])
        print("| %s | %.1f MB | %s |" % (os.path.basename(path), os.path.getsize(path) / 1e6, " | ".join(cells)))


if __name__ == "__main__":
    main()
