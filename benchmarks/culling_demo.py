#!/usr/bin/env python3
"""The culling demo: CPVS beside the per-frame shadow-map techniques it replaces (docs/culling-demo.md).

    python3 benchmarks/culling_demo.py [--bin build/bin] [--out out/culling] [--doc docs/culling-demo]
                                       [--frames 4] [--size 1920x1080] [--pcf 9] [--map-size 512]
                                       [--resolution 4k] [--backend osmesa|egl]

Renders the same flythrough of the generated city with 165 spot lights (cpvs-scenegen city-spots, the
flythrough of benchmarks/viewer.py) with every mode, one cpvs-view process per (frame, mode), the modes'
order rotated frame by frame so that ratios come from one run:
  cpvs (the CPVS walked on the GPU) and cpvs-cpu (the CPU runtime), baked once at --resolution;
  shadowmap with caster culling none, frustum, voxel-grid, receiver-mask (frag) and receiver-mask (bvol);
  lightcluster with 10 clusters (frustum culled);
  manypsm (ManyPSMs: the BVH traversal into an atlas, maps of 16^2 up to --map-size by the camera's distance).
Every frame is also traced with Embree (--compare) for the error. Then the sun-lit city (cpvs-scenegen city)
for the receiver masks against frustum culling, and the 165-spot city at three triangle budgets (the
generator's --triangles) for the frame cost against the scene's size. Writes DOC/benchmark.json, DOC/benchmark.md
(tables), DOC/cost-vs-triangles.svg and the images of the first frame (DOC/MODE.png, DOC/MODE-difference.png).
Python 3 standard library only.
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
from viewer import flythrough  # noqa: E402

# name -> cpvs-view arguments
MODES = {
    "cpvs": ["--shadows", "gpu"],
    "cpvs-cpu": ["--shadows", "cpu"],
    "shadowmap-none": ["--shadows", "shadowmap", "--caster-culling", "none"],
    "shadowmap-frustum": ["--shadows", "shadowmap", "--caster-culling", "frustum"],
    "shadowmap-voxel-grid": ["--shadows", "shadowmap", "--caster-culling", "voxel-grid"],
    "shadowmap-receiver-mask-frag": ["--shadows", "shadowmap", "--caster-culling", "receiver-mask", "--mask-variant", "frag"],
    "shadowmap-receiver-mask-bvol": ["--shadows", "shadowmap", "--caster-culling", "receiver-mask", "--mask-variant", "bvol"],
    "lightcluster-10": ["--shadows", "lightcluster", "--clusters", "10", "--caster-culling", "frustum"],
    "manypsm": ["--shadows", "manypsm"],
}
SUN_MODES = ["cpvs", "cpvs-cpu", "shadowmap-none", "shadowmap-frustum", "shadowmap-receiver-mask-frag",
             "shadowmap-receiver-mask-bvol", "shadowmap-voxel-grid"]
DETAIL_MODES = ["cpvs", "cpvs-cpu", "shadowmap-frustum", "shadowmap-voxel-grid", "lightcluster-10", "manypsm"]
DETAIL_TRIANGLES = [50000, 100000, 200000]


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("failed (%d): %s\n%s" % (r.returncode, " ".join(cmd), r.stderr))


def loadavg():
    with open("/proc/loadavg") as f:
        return f.read().split()[:3]


def shadow_cost(passes):
    """A frame's shadow cost: culling (ManyPSMs: its plan and traversal), map rendering and lookups (CPVS: the
    lookups alone)."""
    return sum(passes.get(p, 0.0) for p in ("culling", "plan", "traversal", "shadow_maps", "shadows"))


def render(a, scene, cpvs, camera_file, mode, report, image_dir=None):
    cmd = [os.path.join(a.bin, "cpvs-view"), scene, cpvs, "--path", camera_file, "--frames",
           image_dir or os.path.join(a.out, "frames"), "--size", a.size, "--pcf", str(a.pcf), "--shadow-map-size",
           str(a.map_size), "--backend", a.backend, "--compare", "--report", report, "-q"] + MODES[mode]
    run(cmd)
    with open(report) as f:
        frame = json.load(f)["frames"][0]
    out = {"passes": frame["passes_ms"], "errors": frame["against_rays"], "lights_per_tile": frame["light_lists"]["mean_lights_per_tile"]}
    out["shadow_cost"] = shadow_cost(out["passes"])
    if "shadow_maps" in frame:
        sm = frame["shadow_maps"]
        out.update({"maps": sm["maps"], "triangles_drawn": sm["triangles_drawn"],
                    "triangles_per_light": sm["triangles_per_light_mean"], "gpu_bytes": sm["gpu_bytes"]})
    else:
        out["gpu_bytes"] = frame.get("cpvs_gpu_bytes", frame.get("cpvs_cpu_bytes", 0))
    return out


def series(a, scene, cpvs, cameras, modes, tag):
    """Every camera with every mode, the modes' order rotated frame by frame."""
    frames = []
    for i, camera in enumerate(cameras):
        path = os.path.join(a.out, "%s-camera-%02d.json" % (tag, i))
        with open(path, "w") as f:
            json.dump([camera], f)
        order = modes[i % len(modes):] + modes[:i % len(modes)]
        frame = {}
        for mode in order:
            frame[mode] = render(a, scene, cpvs, path, mode, os.path.join(a.out, "%s-%02d-%s.json" % (tag, i, mode)))
        frames.append(frame)
        print("%s frame %d: %s" % (tag, i, ", ".join("%s %.0f ms" % (m, frame[m]["shadow_cost"]) for m in modes)), flush=True)
    return frames


def mean(values):
    values = list(values)
    return sum(values) / len(values) if values else 0.0


def summarise(frames, modes):
    s = {}
    for m in modes:
        rows = [f[m] for f in frames]
        s[m] = {"shadow_cost": mean(r["shadow_cost"] for r in rows),
                "shadow_cost_max": max(r["shadow_cost"] for r in rows),
                "culling": mean(r["passes"].get("culling", 0) + r["passes"].get("plan", 0) + r["passes"].get("traversal", 0)
                                for r in rows),
                "shadow_maps": mean(r["passes"].get("shadow_maps", 0) for r in rows),
                "lookups": mean(r["passes"].get("shadows", 0) for r in rows),
                "shading": mean(r["passes"].get("shading", 0) for r in rows),
                "wrong_pixels_percent": mean(r["errors"]["wrong_pixels_percent"] for r in rows),
                "rmse": mean(r["errors"]["rmse"] for r in rows),
                "gpu_bytes": mean(r["gpu_bytes"] for r in rows),
                "triangles_per_light": mean(r.get("triangles_per_light", 0) for r in rows),
                "maps": mean(r.get("maps", 0) for r in rows)}
    return s


def ratio(frames, slow, fast, key):
    """Per frame slow / fast of one figure (a pass's time or the shadow cost), mean and range."""
    values = []
    for f in frames:
        a = f[slow]["passes"].get(key, 0) if key != "shadow_cost" else f[slow]["shadow_cost"]
        b = f[fast]["passes"].get(key, 0) if key != "shadow_cost" else f[fast]["shadow_cost"]
        if b > 0:
            values.append(a / b)
    return {"mean": mean(values), "min": min(values), "max": max(values)} if values else None


def images(a, city, city_cpvs):
    """The first flythrough frame at the docs' size: each mode, and its difference against the rays."""
    path = os.path.join(a.out, "spots-camera-00.json")
    for mode in MODES:
        for overlay in ["none", "difference"]:
            folder = os.path.join(a.out, "doc-%s-%s" % (mode, overlay))
            run([os.path.join(a.bin, "cpvs-view"), city, city_cpvs, "--path", path, "--frames", folder, "--size", a.doc_size, "--pcf",
                 str(a.pcf), "--shadow-map-size", str(a.map_size), "--backend", a.backend, "--overlay", overlay, "-q"]
                + MODES[mode])
            os.replace(os.path.join(folder, "frame_0000.png"),
                       os.path.join(a.doc, "%s%s.png" % (mode, "-difference" if overlay == "difference" else "")))


def svg(detail, path):
    """Shadow cost per frame against the scene's triangles, one line per mode."""
    w, h, left, right, top, bottom = 640, 360, 70, 190, 30, 50
    pw, ph = w - left - right, h - top - bottom
    xs = DETAIL_TRIANGLES
    top_ms = max(detail[str(t)][m]["shadow_cost"] for t in xs for m in DETAIL_MODES) * 1.1 or 1
    colours = ["#c0392b", "#e67e22", "#2c6aa8", "#27ae60", "#8e44ad", "#7f8c8d"]
    x_of = lambda t: left + pw * (math.log(t) - math.log(xs[0])) / (math.log(xs[-1]) - math.log(xs[0]))  # noqa: E731
    y_of = lambda v: top + ph - ph * v / top_ms  # noqa: E731
    out = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" font-family="sans-serif" font-size="11">' % (w, h),
           '<rect width="100%" height="100%" fill="white"/>',
           '<text x="%d" y="18" font-size="13">Shadow cost per frame against the scene\'s triangles (165 spots)</text>' % left,
           '<line x1="%d" y1="%d" x2="%d" y2="%d" stroke="black"/>' % (left, top + ph, left + pw, top + ph),
           '<line x1="%d" y1="%d" x2="%d" y2="%d" stroke="black"/>' % (left, top, left, top + ph)]
    for k in range(5):
        v = top_ms * k / 4
        out.append('<text x="%d" y="%.1f" text-anchor="end">%.0f ms</text>' % (left - 4, y_of(v) + 4, v))
    for t in xs:
        out.append('<text x="%.1f" y="%d" text-anchor="middle">%dk</text>' % (x_of(t), top + ph + 16, t // 1000))
    out.append('<text x="%d" y="%d" text-anchor="middle">triangles (cpvs-scenegen --triangles)</text>' % (left + pw / 2, h - 10))
    for i, m in enumerate(DETAIL_MODES):
        pts = " ".join("%.1f,%.1f" % (x_of(t), y_of(detail[str(t)][m]["shadow_cost"])) for t in xs)
        out.append('<polyline points="%s" fill="none" stroke="%s" stroke-width="2"/>' % (pts, colours[i]))
        out.append('<text x="%d" y="%d" fill="%s">%s</text>' % (left + pw + 10, top + 14 + 16 * i, colours[i], m))
    out.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="build/bin")
    ap.add_argument("--out", default="out/culling")
    ap.add_argument("--doc", default="docs/culling-demo")
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--doc-size", default="480x270")
    ap.add_argument("--pcf", type=int, default=9)
    ap.add_argument("--map-size", type=int, default=512)
    ap.add_argument("--resolution", default="4k")
    ap.add_argument("--backend", default="osmesa")
    ap.add_argument("--report-only", action="store_true", help="rewrite the tables and plot from DOC/benchmark.json")
    ap.add_argument("--images-only", action="store_true", help="render only the docs' images (scenes and bakes reused)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    os.makedirs(a.doc, exist_ok=True)
    if a.report_only:
        with open(os.path.join(a.doc, "benchmark.json")) as f:
            result = json.load(f)
        svg(result["detail"], os.path.join(a.doc, "cost-vs-triangles.svg"))
        with open(os.path.join(a.doc, "benchmark.md"), "w") as f:
            f.write(markdown(result))
        return
    tool = lambda name: os.path.join(a.bin, name)  # noqa: E731

    def scene_and_bake(kind, triangles, lights=None):
        scene = os.path.join(a.out, "%s-%d.glb" % (kind, triangles))
        cmd = [tool("cpvs-scenegen"), kind, "--triangles", str(triangles), "-o", scene]
        if lights:
            cmd += ["--lights", str(lights)]
        run(cmd)
        cpvs = os.path.join(a.out, "%s-%d-%s.cpvs" % (kind, triangles, a.resolution))
        if not os.path.exists(cpvs):
            print("baking %s (%d triangles) at %s ..." % (kind, triangles, a.resolution), flush=True)
            start = time.time()
            run([tool("cpvs-bake"), scene, "-r", a.resolution, "-o", cpvs, "-q"])
            print("  %.0f s" % (time.time() - start), flush=True)
        return scene, cpvs

    cameras = flythrough(a.frames)
    load_before = loadavg()
    city, city_cpvs = scene_and_bake("city-spots", 100000, 165)
    if a.images_only:
        images(a, city, city_cpvs)
        return
    frames = series(a, city, city_cpvs, cameras, list(MODES), "spots")
    sun, sun_cpvs = scene_and_bake("city", 100000)
    sun_frames = series(a, sun, sun_cpvs, cameras, SUN_MODES, "sun")
    detail = {}
    for t in DETAIL_TRIANGLES:
        scene, cpvs = (city, city_cpvs) if t == 100000 else scene_and_bake("city-spots", t, 165)
        detail[str(t)] = summarise(series(a, scene, cpvs, cameras[:2], DETAIL_MODES, "detail-%d" % t), DETAIL_MODES)
    load_after = loadavg()

    images(a, city, city_cpvs)
    result = {"machine": machine_info(), "command": "python3 benchmarks/culling_demo.py " + " ".join(sys.argv[1:]),
              "size": a.size, "pcf": a.pcf, "map_size": a.map_size, "resolution": a.resolution, "backend": a.backend,
              "load_average_before": load_before, "load_average_after": load_after,
              "spots": {"frames": frames, "summary": summarise(frames, list(MODES)),
                        "ratios": {"voxel-grid over frustum (map rendering)": ratio(frames, "shadowmap-frustum", "shadowmap-voxel-grid", "shadow_maps"),
                                   "lightcluster-10 over per-light maps (shadow cost, both frustum culled)": ratio(frames, "shadowmap-frustum", "lightcluster-10", "shadow_cost"),
                                   "manypsm over per-light frustum-culled maps (shadow cost)": ratio(frames, "shadowmap-frustum", "manypsm", "shadow_cost"),
                                   "fastest map mode over CPVS on the GPU (shadow cost)": None,
                                   "fastest map mode over CPVS on the CPU (shadow cost)": None}},
              "sun": {"frames": sun_frames, "summary": summarise(sun_frames, SUN_MODES),
                      "ratios": {"receiver-mask frag over frustum (map rendering)": ratio(sun_frames, "shadowmap-frustum", "shadowmap-receiver-mask-frag", "shadow_maps"),
                                 "receiver-mask bvol over frustum (map rendering)": ratio(sun_frames, "shadowmap-frustum", "shadowmap-receiver-mask-bvol", "shadow_maps")}},
              "detail": detail}
    s = result["spots"]["summary"]
    map_modes = [m for m in MODES if m.startswith("shadowmap") or m.startswith("lightcluster") or m == "manypsm"]
    fastest = min(map_modes, key=lambda m: s[m]["shadow_cost"])
    result["spots"]["fastest_map_mode"] = fastest
    result["spots"]["ratios"]["fastest map mode over CPVS on the GPU (shadow cost)"] = ratio(frames, fastest, "cpvs", "shadow_cost")
    result["spots"]["ratios"]["fastest map mode over CPVS on the CPU (shadow cost)"] = ratio(frames, fastest, "cpvs-cpu", "shadow_cost")
    with open(os.path.join(a.doc, "benchmark.json"), "w") as f:
        json.dump(result, f, indent=1)
    svg(detail, os.path.join(a.doc, "cost-vs-triangles.svg"))
    with open(os.path.join(a.doc, "benchmark.md"), "w") as f:
        f.write(markdown(result))
    print(markdown(result))


def markdown(r):
    m = r["machine"]
    lines = ["# Culling demo benchmark", "",
             "Generated by `benchmarks/culling_demo.py`; do not edit by hand. [culling-demo.md](../culling-demo.md) explains it.", "",
             "* Machine: %s, %s logical CPUs, %.1f GiB RAM, Linux %s; GL backend `%s`" % (m["model"], m["cpus"], m["memory_gib"], m["kernel"], r["backend"]),
             "* Command: `%s`; load average %s before, %s after" % (r["command"], "/".join(r["load_average_before"]), "/".join(r["load_average_after"])),
             "* %s, %dx%d PCF everywhere; maps %d x %d texels (16-bit depth); CPVS baked at %s; %d flythrough frames, "
             "one process per (frame, mode), the modes' order rotated frame by frame; times in ms, means over the frames"
             % (r["size"], r["pcf"], r["pcf"], r["map_size"], r["map_size"], r["resolution"], len(r["spots"]["frames"])), ""]

    def table(title, summary, modes):
        out = ["## " + title, "",
               "| mode | shadow cost | worst frame | culling (ManyPSMs: plan + traversal) | map rendering | lookups | shading | maps | triangles per light | shadow data MB (GPU; cpvs-cpu: CPU) | wrong pixels | RMSE |",
               "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for mode in modes:
            v = summary[mode]
            out.append("| %s | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.0f | %.0f | %.1f | %.3f %% | %.4f |" % (
                mode, v["shadow_cost"], v["shadow_cost_max"], v["culling"], v["shadow_maps"], v["lookups"], v["shading"],
                v["maps"], v["triangles_per_light"], v["gpu_bytes"] / 1e6, v["wrong_pixels_percent"], v["rmse"]))
        return out

    lines += table("165 spot lights (city-spots, 100k triangles)", r["spots"]["summary"], list(MODES))
    lines += ["", "Ratios (per frame, then mean [min–max]):", ""]
    for name, v in r["spots"]["ratios"].items():
        lines.append("* %s: %s" % (name, "%.2fx [%.2f–%.2f]" % (v["mean"], v["min"], v["max"]) if v else "n/a"))
    lines.append("* the fastest map mode: %s" % r["spots"]["fastest_map_mode"])
    lines += [""] + table("The sun-lit city (city, 100k triangles, one sun)", r["sun"]["summary"], SUN_MODES)
    lines += ["", "Ratios (per frame, then mean [min–max]):", ""]
    for name, v in r["sun"]["ratios"].items():
        lines.append("* %s: %s" % (name, "%.2fx [%.2f–%.2f]" % (v["mean"], v["min"], v["max"]) if v else "n/a"))
    lines += ["", "## Shadow cost against the scene's triangles (165 spots, the first two frames)", "",
              "| mode | " + " | ".join("%dk" % (t // 1000) for t in DETAIL_TRIANGLES) + " | largest / smallest |",
              "|---|" + "---:|" * (len(DETAIL_TRIANGLES) + 1)]
    for mode in DETAIL_MODES:
        costs = [r["detail"][str(t)][mode]["shadow_cost"] for t in DETAIL_TRIANGLES]
        lines.append("| %s | %s | %.2f |" % (mode, " | ".join("%.1f" % c for c in costs), max(costs) / min(costs)))
    lines += ["", "![shadow cost against triangles](cost-vs-triangles.svg)"]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
