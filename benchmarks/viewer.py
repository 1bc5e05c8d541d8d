#!/usr/bin/env python3
"""cpvs-view's speed and error on the 165-spot city and on the Japanese temple (docs/viewer.md).

    python3 benchmarks/viewer.py [--bin build/bin] [--out out/viewer] [--doc docs/viewer]
                                 [--resolution 4k] [--frames 8] [--size 1920x1080] [--pcf 9] [--backend egl]

1. Bakes the generated city with 165 spot lights (cpvs-scenegen city-spots) and the shipped Japanese temple
   with a sun, two spots and a point light (reused when the .cpvs already exists).
2. A flythrough of the city (--frames cameras descending on a spiral toward the centre above the roofs, the
   last at street level: the paper's Figure 4 in spirit): every frame is rendered with --shadows gpu (the compute shader; llvmpipe on a machine without a
   GPU), cpu (the CPU runtime's batch lookups) and raytraced (Embree shadow rays for the same pixels and
   lights), the three modes alternating, each frame's order rotated, so that the ratios come from one run.
3. Error against the rays: the first flythrough frame of the city and a default view of the temple with
   --compare and the difference overlay; the images (smaller, for the docs) go to --doc.
Writes DOC/benchmark.json and DOC/benchmark.md (the tables docs/viewer.md quotes). Python 3 standard library.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info  # noqa: E402

MODES = ["gpu", "cpu", "raytraced"]
# Runs per frame: the three modes with --pcf K, and the CPU runtime unfiltered (K = 1) against the same rays.
RUNS = MODES + ["cpu-k1"]
PASSES = ["gbuffer", "tile_bounds", "light_lists", "shadows", "shading"]


def run(cmd):
    start = time.time()
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("failed (%d): %s\n%s" % (r.returncode, " ".join(cmd), r.stderr))
    return time.time() - start


def loadavg():
    with open("/proc/loadavg") as f:
        return f.read().split()[:3]


def flythrough(n):
    """Cameras over the 1040 x 1040 city: a descending spiral from an overview down to just above the roofs
    (the tallest reach 125), then the last one at street level between towers."""
    cameras = []
    for i in range(n):
        t = i / max(1, n - 1)
        angle = 2 * math.pi * 0.75 * t + 0.6
        radius, height = 650 - 450 * t, (420 - 270 * t) if i < n - 1 else 40
        target = [120 * math.cos(angle + 2.4) * t, 0.0, 120 * math.sin(angle + 2.4) * t]
        cameras.append({"eye": [radius * math.cos(angle), height, radius * math.sin(angle)], "target": target,
                        "fov": 50})
    return cameras


def stats(values):
    return {"mean": sum(values) / len(values), "max": max(values), "min": min(values)}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="build/bin")
    ap.add_argument("--out", default="out/viewer")
    ap.add_argument("--doc", default="docs/viewer")
    ap.add_argument("--resolution", default="4k")
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--doc-size", default="640x360")
    ap.add_argument("--pcf", type=int, default=9)
    ap.add_argument("--backend", default="osmesa", help="cpvs-view's GL: osmesa (llvmpipe) or egl (a GPU)")
    ap.add_argument("--report-only", action="store_true", help="rewrite DOC/benchmark.md from DOC/benchmark.json")
    a = ap.parse_args()
    if a.report_only:
        with open(os.path.join(a.doc, "benchmark.json")) as f:
            result = json.load(f)
        with open(os.path.join(a.doc, "benchmark.md"), "w") as f:
            f.write(markdown(result))
        return
    os.makedirs(a.out, exist_ok=True)
    os.makedirs(a.doc, exist_ok=True)
    tool = lambda name: os.path.join(a.bin, name)  # noqa: E731

    # 1. Scenes and bakes.
    city = os.path.join(a.out, "city-spots.glb")
    run([tool("cpvs-scenegen"), "city-spots", "--lights", "165", "-o", city])
    temple = "data/scenes/JapaneseTemple/scene.gltf"
    temple_lights = ["--sun", "0.5,-1,0.35", "--spot", "0,30,18,0,-0.8,-0.6,0.5,60",
                     "--spot", "-14,12,-12,0.7,-0.4,0.6,0.6,50", "--point", "0,6,6,25"]
    bakes = {}
    for name, scene, extra in [("city", city, []), ("temple", temple, temple_lights)]:
        cpvs = os.path.join(a.out, "%s-%s.cpvs" % (name, a.resolution))
        if not os.path.exists(cpvs):
            print("baking %s at %s ..." % (name, a.resolution), flush=True)
            wall = run([tool("cpvs-bake"), scene, "-r", a.resolution, "-o", cpvs, "-q"] + extra)
            print("  %.1f s" % wall, flush=True)
        bakes[name] = (scene, cpvs)

    # 2. The flythrough, modes alternating.
    load_before = loadavg()
    frames = []
    common = ["--size", a.size, "--backend", a.backend, "-q"]
    for i, camera in enumerate(flythrough(a.frames)):
        path = os.path.join(a.out, "camera-%02d.json" % i)
        with open(path, "w") as f:
            json.dump([camera], f)
        frame = {"camera": camera}
        order = RUNS[i % len(RUNS):] + RUNS[:i % len(RUNS)]
        for mode in order:
            report = os.path.join(a.out, "frame-%02d-%s.json" % (i, mode))
            shadows, pcf = (mode, ["--pcf", str(a.pcf)]) if mode != "cpu-k1" else ("cpu", ["--pcf", "1"])
            run([tool("cpvs-view"), bakes["city"][0], bakes["city"][1], "--path", path, "--frames",
                 os.path.join(a.out, "frames-" + mode), "--shadows", shadows, "--report", report] + common + pcf)
            with open(report) as f:
                r = json.load(f)
            frame[mode] = r["frames"][0]["passes_ms"]
            frame["light_lists"] = r["frames"][0]["light_lists"]
            frame["context"] = r["context"]
            frame["timers"] = "GL timer queries" if r["frames"][0]["gpu_timers"] else "wall clock around glFinish"
        frames.append(frame)
        print("frame %d: %.1f lights per tile; shadows gpu %.1f ms, cpu %.1f ms (K=1: %.1f), rays %.1f ms" %
              (i, frame["light_lists"]["mean_lights_per_tile"], frame["gpu"]["shadows"], frame["cpu"]["shadows"],
               frame["cpu-k1"]["shadows"], frame["raytraced"]["shadows"]), flush=True)
    load_after = loadavg()

    summary = {"passes": {}, "ratios": {}}
    for mode in MODES:
        summary["passes"][mode] = {p: stats([f[mode][p] for f in frames]) for p in PASSES if p in frames[0][mode]}
    for mode in ["gpu", "cpu", "cpu-k1"]:
        ratios = [f["raytraced"]["shadows"] / f[mode]["shadows"] for f in frames]
        summary["ratios"][mode] = stats(ratios)
    summary["light_lists"] = {k: stats([f["light_lists"][k] for f in frames])
                              for k in ["mean_lights_per_tile", "max_lights_per_tile", "pairs_listed", "pairs_culled"]}

    # 3. Error against the rays, and the images for the docs.
    errors = {}
    views = [("city", ["--path", os.path.join(a.out, "camera-00.json")]),
             ("city-street", ["--path", os.path.join(a.out, "camera-%02d.json" % (a.frames - 1))]),
             ("temple", [])]
    for name, camera in views:
        scene, cpvs = bakes[name.split("-")[0]]
        for mode, overlay in [("gpu", "difference"), ("gpu", "none"), ("raytraced", "none")]:
            folder = os.path.join(a.out, "doc-%s-%s-%s" % (name, mode, overlay))
            report = folder + ".json"
            args = camera + ["--frames", folder] if camera else ["--orbit", "1", "--frames", folder]
            run([tool("cpvs-view"), scene, cpvs, "--size", a.size, "--backend", a.backend, "--pcf", str(a.pcf), "--shadows", mode,
                 "--overlay", overlay, "--report", report, "-q"] + (["--compare"] if overlay == "difference" else []) + args)
            with open(report) as f:
                r = json.load(f)
            if overlay == "difference":
                errors[name] = r["frames"][0]["against_rays"]
            # The doc's copy: the same view at the doc size.
            small = folder + "-small"
            run([tool("cpvs-view"), scene, cpvs, "--size", a.doc_size, "--backend", a.backend, "--pcf", str(a.pcf), "--shadows", mode,
                 "--overlay", overlay, "-q"] + args[:-1] + [small])
            os.replace(os.path.join(small, "frame_0000.png"),
                       os.path.join(a.doc, "%s-%s.png" % (name, "difference" if overlay == "difference" else mode)))

    result = {"machine": machine_info(), "context": frames[0]["context"], "timers": frames[0]["timers"],
              "size": a.size, "pcf": a.pcf, "resolution": a.resolution, "lights": 165, "frames": frames,
              "summary": summary, "errors": errors, "load_average_before": load_before, "load_average_after": load_after,
              "command": "python3 benchmarks/viewer.py " + " ".join(sys.argv[1:])}
    with open(os.path.join(a.doc, "benchmark.json"), "w") as f:
        json.dump(result, f, indent=1)
    with open(os.path.join(a.doc, "benchmark.md"), "w") as f:
        f.write(markdown(result))
    print(markdown(result))


def markdown(r):
    m = r["machine"]
    s = r["summary"]
    lines = ["# cpvs-view benchmark", "",
             "Generated by `benchmarks/viewer.py`; do not edit by hand. [viewer.md](../viewer.md) explains the figures.", "",
             "* Machine: %s, %s logical CPUs, %.1f GiB RAM, Linux %s" % (m["model"], m["cpus"], m["memory_gib"], m["kernel"]),
             "* GL: `%s`; pass times: %s" % (r["context"], r["timers"]),
             "* Command: `%s`; load average %s before, %s after" % (r["command"], "/".join(r["load_average_before"]),
                                                                  "/".join(r["load_average_after"])),
             "* City: 165 spot lights baked at %s; %s, %dx%d PCF; %d flythrough frames, each rendered with the three "
             "shadow modes and the unfiltered CPU runtime, one process each, their order rotated frame by frame"
             % (r["resolution"], r["size"], r["pcf"], r["pcf"], len(r["frames"])), "",
             "## Pass times (ms; mean / max over the flythrough)", "",
             "| pass | --shadows gpu | --shadows cpu | --shadows raytraced |", "|---|---:|---:|---:|"]
    for p in PASSES:
        cells = []
        for mode in MODES:
            v = s["passes"][mode].get(p)
            cells.append("%.1f / %.1f" % (v["mean"], v["max"]) if v else "—")
        lines.append("| %s | %s |" % (p, " | ".join(cells)))
    ll = s["light_lists"]
    lines += ["", "Light lists: %.1f lights per covered 8x8 tile on average (frame means %.1f–%.1f), at most %d in a tile; "
              "%.0f (pixel, light) pairs listed and %.0f culled per frame on average." %
              (ll["mean_lights_per_tile"]["mean"], ll["mean_lights_per_tile"]["min"], ll["mean_lights_per_tile"]["max"],
               ll["max_lights_per_tile"]["max"], ll["pairs_listed"]["mean"], ll["pairs_culled"]["mean"]), "",
              "## Shadow pass against Embree shadow rays (same pixels and lights, one run)", "",
              "| CPVS shadow pass | rays / CPVS time, mean | min | max |", "|---|---:|---:|---:|"]
    for mode, label in [("gpu", "compute shader (this GL), %dx%d PCF" % (r["pcf"], r["pcf"])),
                        ("cpu", "CPU runtime, batch lookups, %dx%d PCF" % (r["pcf"], r["pcf"])),
                        ("cpu-k1", "CPU runtime, batch lookups, unfiltered")]:
        v = s["ratios"][mode]
        lines.append("| %s | %.2fx | %.2fx | %.2fx |" % (label, v["mean"], v["min"], v["max"]))
    lines += ["", "Per frame (ms: shadows gpu / cpu / cpu unfiltered / rays; lights per tile):", ""]
    for i, f in enumerate(r["frames"]):
        lines.append("%d. %.1f / %.1f / %.1f / %.1f; %.1f" % (i, f["gpu"]["shadows"], f["cpu"]["shadows"], f["cpu-k1"]["shadows"],
                                                              f["raytraced"]["shadows"], f["light_lists"]["mean_lights_per_tile"]))
    lines += ["", "## Error against the rays", "", "| view | wrong pixels | wrong (pixel, light) pairs | RMSE (sRGB) |",
              "|---|---:|---:|---:|"]
    for name, e in r["errors"].items():
        lines.append("| %s | %.3f %% (%d of %d) | %d of %d | %.4f |" % (name, e["wrong_pixels_percent"], e["wrong_pixels"],
                                                                     e["covered_pixels"], e["wrong_pairs"], e["pairs"], e["rmse"]))
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
