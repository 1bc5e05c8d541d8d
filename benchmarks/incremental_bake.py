#!/usr/bin/env python3
"""Incremental bakes: what a re-bake costs after a one-object edit, against a clean bake of the same scene.

    python3 benchmarks/incremental_bake.py [--bin build/bin] [--out out/incremental] [--doc docs/incremental]
                                           [--cases city64k,foliage64k,spots8k,macross8k] [--rounds 2] [--threads 2]

Cases (docs/incremental-bakes.md): city64k and city256k, `cpvs-scenegen city` lit by --sun 0.4,-1,0.3 at 64k
(256k), one building (node proto_gable_2.0) moved by 5 units along x; foliage64k, `cpvs-scenegen foliage`, its
sun alone (--lights sun) at 64k, one tree (instance 0 of tree_0_trunk and tree_0_crown) moved by 5 units; spots8k, `cpvs-scenegen city-spots --lights 165` at 8k, the same
building moved; macross8k, an artist-made level (data/scenes/MacrossCityDiorama) lit by --sun 0.3,-1,0.4 at 8k,
its one alpha-blended material (index 16) made opaque.

Per case the scene A and its edit B. First A is baked with a fresh cache (that bake's CPU time is a clean bake's
with the cache's recording), then, alternating for --rounds rounds: a clean bake of B (no cache), an incremental
bake of B (the cache holds A), a clean bake of A, an incremental bake of A (the cache holds B). Every incremental
file is compared byte for byte with the clean bake of the same scene. CPU time (user + system) and peak RSS come
from wait4 on each cpvs-bake process; the DAG phase's time from each bake's --report; the cache's size is the
folder's after each incremental bake.
Writes DOC/CASE.json and prints the table docs/incremental-bakes.md quotes, with the CPU model and load average.
Python 3 standard library only."""

import argparse
import filecmp
import json
import os
import shutil
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info, machine_line  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
EDIT = os.path.join(HERE, "..", "scripts", "gltf_edit.py")

MOVE_BUILDING = ["move", "proto_gable_2.0", "5", "0", "0"]
# case: (cpvs-scenegen kind and its options, or a scene file of the repo; the bake's options; the edit,
# scripts/gltf_edit.py's arguments)
CASES = {
    "city64k": (("city", "--triangles", "100000"), ["--sun", "0.4,-1,0.3", "-r", "64k"], MOVE_BUILDING),
    "city256k": (("city", "--triangles", "100000"), ["--sun", "0.4,-1,0.3", "-r", "256k"], MOVE_BUILDING),
    # The foliage's trees are instances (EXT_mesh_gpu_instancing): the first tree's trunk and crown move.
    "foliage64k": (("foliage",), ["--lights", "sun", "-r", "64k"],
                   ["move-instance", "tree_0_trunk,tree_0_crown", "0", "5", "0", "0"]),
    "spots8k": (("city-spots", "--lights", "165"), ["-r", "8k"], MOVE_BUILDING),
    "macross8k": (os.path.join(HERE, "..", "data", "scenes", "MacrossCityDiorama", "scene.glb"),
                  ["--sun", "0.3,-1,0.4", "-r", "8k"], ["alpha", "16", "OPAQUE"]),
}


def timed(cmd):
    """Runs cmd; returns (wall s, CPU s, peak RSS MiB)."""
    print("$ " + " ".join(cmd), flush=True)
    start = time.time()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.time() - start
    err = proc.stderr.read().decode()
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(err)
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0, err


def folder_bytes(path):
    return sum(os.path.getsize(os.path.join(path, f)) for f in os.listdir(path))


def run_case(a, name):
    source, bake, edit = CASES[name]
    work = os.path.join(a.out, name)
    os.makedirs(work, exist_ok=True)
    scene_a = os.path.join(work, "a.glb")
    if isinstance(source, str):
        shutil.copyfile(source, scene_a)
    else:
        subprocess.run([os.path.join(a.bin, "cpvs-scenegen"), source[0], *source[1:], "-o", scene_a], check=True,
                       stdout=subprocess.DEVNULL)
    scene_b = os.path.join(work, "b.glb")
    subprocess.run([sys.executable, EDIT, scene_a, scene_b, *edit], check=True)
    cache = os.path.join(work, "cache")
    shutil.rmtree(cache, ignore_errors=True)
    bake = [os.path.join(a.bin, "cpvs-bake"), *bake, "--threads", str(a.threads), "--quiet"]
    out = lambda tag: os.path.join(work, tag + ".cpvs")  # noqa: E731

    load = [os.getloadavg()[0]]
    first = timed(bake + [scene_a, "-o", out("first"), "--cache", cache])
    rows = []
    for r in range(a.rounds):
        for scene, tag in ((scene_b, "b"), (scene_a, "a")):
            clean = timed(bake + [scene, "-o", out("clean-" + tag), "--report",
                                  os.path.join(work, "report-clean-" + tag + ".json")])
            clean_report = json.load(open(os.path.join(work, "report-clean-" + tag + ".json")))
            incremental = timed(bake + [scene, "-o", out("incremental-" + tag), "--cache", cache, "--report",
                                        os.path.join(work, "report-" + tag + ".json")])
            report = json.load(open(os.path.join(work, "report-" + tag + ".json")))
            regions = sum(v["regions"] for l in report["lights"] if l["cache"] != "hit" for v in l["views"])
            reused = sum(v["regions_reused"] for l in report["lights"] for v in l["views"])
            hits = sum(l["cache"] == "hit" for l in report["lights"])
            # The DAG phase: building the DAG in a clean bake, replaying (and building the rest) in an incremental one.
            dag_ms = lambda r: sum(v["phases_ms"]["dag"] for l in r["lights"] for v in l.get("views", []))  # noqa: E731
            rows.append({"round": r, "scene": tag, "clean_wall_s": clean[0], "clean_cpu_s": clean[1],
                         "clean_rss_mib": clean[2], "incremental_wall_s": incremental[0],
                         "incremental_cpu_s": incremental[1], "incremental_rss_mib": incremental[2],
                         "cpu_ratio": incremental[1] / clean[1],
                         "identical": filecmp.cmp(out("clean-" + tag), out("incremental-" + tag), shallow=False),
                         "cpvs_bytes": os.path.getsize(out("clean-" + tag)), "cache_bytes": folder_bytes(cache),
                         "light_hits": hits, "lights": len(report["lights"]),
                         "regions_reused": reused, "regions_baked_lights": regions,
                         "clean_dag_ms": dag_ms(clean_report), "incremental_dag_ms": dag_ms(report)})
            load.append(os.getloadavg()[0])
            print(json.dumps(rows[-1]), flush=True)
    scene = os.path.relpath(source, os.path.join(HERE, "..")) if isinstance(source, str) else list(source)
    result = {"case": name, "scene": scene, "bake": bake[1:], "edit": edit,
              "machine": machine_info(), "load_average": load,
              "first_with_cache": {"wall_s": first[0], "cpu_s": first[1], "rss_mib": first[2]}, "rounds": rows}
    os.makedirs(a.doc, exist_ok=True)
    with open(os.path.join(a.doc, name + ".json"), "w") as f:
        json.dump(result, f, indent=1)
    return result


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--bin", default="build/bin")
    p.add_argument("--out", default="out/incremental")
    p.add_argument("--doc", default="docs/incremental")
    p.add_argument("--cases", default="city64k,foliage64k,spots8k")
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--threads", type=int, default=2)
    a = p.parse_args()
    results = [run_case(a, c) for c in a.cases.split(",")]
    print("\n" + machine_line(with_load=True) + "\n")
    print("| case | clean CPU s | incremental CPU s | ratio | clean / incremental wall s | peak RSS MiB clean / incr. "
          "| regions replayed | identical | cache / .cpvs |")
    print("|---|---|---|---|---|---|---|---|---|")
    for res in results:
        for row in res["rounds"]:
            print(f"| {res['case']} {row['scene'].upper()} r{row['round']} | {row['clean_cpu_s']:.2f} | "
                  f"{row['incremental_cpu_s']:.2f} | {100 * row['cpu_ratio']:.1f} % | "
                  f"{row['clean_wall_s']:.2f} / {row['incremental_wall_s']:.2f} | "
                  f"{row['clean_rss_mib']:.0f} / {row['incremental_rss_mib']:.0f} | "
                  f"{row['regions_reused']} of {row['regions_baked_lights']} ({row['light_hits']} of "
                  f"{row['lights']} lights whole) | {'yes' if row['identical'] else 'NO'} | "
                  f"{row['cache_bytes'] / row['cpvs_bytes']:.2f} |")
        print(f"(load average {', '.join('%.2f' % x for x in res['load_average'])})")


if __name__ == "__main__":
    main()
