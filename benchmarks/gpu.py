#!/usr/bin/env python3
"""The GPU figures in one run (about 5 minutes on an NVIDIA H100/H200): the EGL bake of the city's 165 spots at
8k, the EGL bake of a sun over the closed city at 64k, and cpvs-view's flythrough of the 165-light city at
1080p with 9x9 PCF, CPVS walked in the compute shader. The paper bakes such a
level in 19 s and shades it in 3.2 ms per frame on a 2013 GPU (Kämpe et al. 2015, §5.3): the marks.

    python3 benchmarks/gpu.py [--bin build/bin] [--out out/gpu] [--backend egl]
                              [--spot-resolution 8k] [--sun-resolution 64k] [--size 1920x1080] [--pcf 9]

benchmarks/gpu.sh runs it on the device machine. --backend osmesa (llvmpipe) and small resolutions check the
script itself on a machine without a GPU. Writes OUT/gpu.json and OUT/gpu.md (one markdown table with the
machine, the GL renderer and the commit). Python 3 standard library only."""

import argparse
import json
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info, run_text  # noqa: E402
from viewer import flythrough  # noqa: E402

PASSES = ["gbuffer", "tile_bounds", "light_lists", "shadows", "shading"]


def measured(cmd):
    print("$ " + " ".join(cmd), flush=True)
    start = time.time()
    proc = subprocess.Popen(cmd)
    _, status, usage = os.wait4(proc.pid, 0)
    code = os.waitstatus_to_exitcode(status)
    if code != 0:
        sys.exit("%s exited with %d" % (cmd[0], code))
    return {"wall_s": time.time() - start, "cpu_s": usage.ru_utime + usage.ru_stime,
            "peak_rss_bytes": usage.ru_maxrss * 1024}


def bake(a, scene, resolution, name, extra):
    report = os.path.join(a.out, name + ".json")
    cpvs = os.path.join(a.out, name + ".cpvs")
    result = measured([os.path.join(a.bin, "cpvs-bake"), scene, "-r", resolution, "--backend", a.backend,
                       "-o", cpvs, "--report", report, "-q"] + extra)
    with open(report) as f:
        r = json.load(f)
    phases = {}
    for light in r["lights"]:
        for view in light["views"]:
            for k, ms in view["phases_ms"].items():
                phases[k] = phases.get(k, 0.0) + ms
    result.update({"name": name, "resolution": resolution, "lights": len(r["lights"]),
                   "file_bytes": r["file_bytes"], "renderer": r["renderer"], "phases_ms": phases})
    return result, cpvs


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="build/bin")
    ap.add_argument("--out", default="out/gpu")
    ap.add_argument("--backend", default="egl")
    ap.add_argument("--spot-resolution", default="8k")
    ap.add_argument("--sun-resolution", default="64k")
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--pcf", type=int, default=9)
    ap.add_argument("--frames", type=int, default=8)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    tool = lambda name: os.path.join(a.bin, name)  # noqa: E731
    spots_scene = os.path.join(a.out, "city-spots.glb")
    city = os.path.join(a.out, "city-100k.glb")
    subprocess.run([tool("cpvs-scenegen"), "city-spots", "--lights", "165", "-o", spots_scene], check=True)
    subprocess.run([tool("cpvs-scenegen"), "city", "--triangles", "100000", "-o", city], check=True)

    bakes = []
    spots, spots_cpvs = bake(a, spots_scene, a.spot_resolution, "spots-" + a.spot_resolution, [])
    bakes.append(spots)
    sun, _ = bake(a, city, a.sun_resolution, "sun-" + a.sun_resolution, ["--sun", "0.4,-1,0.3"])
    bakes.append(sun)

    # The flythrough twice in one process: the first pass warms shaders and caches, the second is reported.
    cameras = flythrough(a.frames)
    path = os.path.join(a.out, "flythrough.json")
    with open(path, "w") as f:
        json.dump(cameras + cameras, f)
    report = os.path.join(a.out, "view.json")
    view_run = measured([tool("cpvs-view"), spots_scene, spots_cpvs, "--path", path, "--frames",
                         os.path.join(a.out, "frames"), "--shadows", "gpu", "--pcf", str(a.pcf), "--size", a.size,
                         "--backend", a.backend, "--report", report, "-q"])
    with open(report) as f:
        r = json.load(f)
    frames = r["frames"][len(cameras):]
    passes = {p: [f["passes_ms"][p] for f in frames if p in f["passes_ms"]] for p in PASSES}
    view = {"context": r["context"], "gpu_timers": all(f["gpu_timers"] for f in frames), "frames": len(frames),
            "wall_s": view_run["wall_s"],
            "passes_ms": {p: {"mean": sum(v) / len(v), "max": max(v)} for p, v in passes.items() if v},
            "frame_ms": [sum(f["passes_ms"][p] for p in PASSES if p in f["passes_ms"]) for f in frames]}

    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    gpu = run_text(["nvidia-smi", "--query-gpu=name,driver_version,memory.total", "--format=csv,noheader"]).strip()
    result = {"machine": machine_info(), "gpu": gpu, "commit": commit, "load_average": os.getloadavg(),
              "bakes": bakes, "view": view}
    with open(os.path.join(a.out, "gpu.json"), "w") as f:
        json.dump(result, f, indent=1)
    m = result["machine"]
    lines = ["Machine: %s, %s logical CPUs; GPU: %s; GL: `%s`; commit %s; load average %.2f" % (
                 m["model"], m["cpus"], gpu or "none found by nvidia-smi", spots["renderer"], commit,
                 result["load_average"][0]), "",
             "| figure | measured | mark (Kämpe et al. 2015, GTX Titan) |", "|---|---:|---:|",
             "| bake, 165 spots at %s (%s) | %.1f s wall, %.1f MB | 19 s |" % (
                 a.spot_resolution, a.backend, spots["wall_s"], spots["file_bytes"] / 1e6),
             "| bake, sun over the closed city at %s (%s) | %.1f s wall, %.1f MB | — |" % (
                 a.sun_resolution, a.backend, sun["wall_s"], sun["file_bytes"] / 1e6),
             "| view, 165 lights, %s, %dx%d PCF: shadow pass (mean / max over %d frames) | %.2f / %.2f ms | 3.2 ms |" % (
                 a.size, a.pcf, a.pcf, len(frames), view["passes_ms"]["shadows"]["mean"],
                 view["passes_ms"]["shadows"]["max"]),
             "| view: whole frame (all passes, mean) | %.2f ms (%s) | — |" % (
                 sum(view["frame_ms"]) / len(frames), "GL timer queries" if view["gpu_timers"] else "wall clock")]
    lines += ["", "Bake phases (CPU-side ms, summed over views): " + "; ".join(
        "%s: " % b["name"] + ", ".join("%s %.0f" % kv for kv in b["phases_ms"].items()) for b in bakes)]
    text = "\n".join(lines) + "\n"
    with open(os.path.join(a.out, "gpu.md"), "w") as f:
        f.write(text)
    print(text)


if __name__ == "__main__":
    main()
