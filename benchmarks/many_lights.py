#!/usr/bin/env python3
"""Many-light bake benchmark: the generated city lit by 165 spot lights at 8k, and by 165 point lights (six
cube faces each) at 2k; per-light time and bytes as distributions, peak memory, the split by phase.

    python3 benchmarks/many_lights.py [--bin build/bin] [--out out/many-lights] [--doc docs/many-lights]
                                      [--lights 165] [--spot-resolution 8k] [--point-resolution 2k]
                                      [--backend cpu] [--threads N] [--only spots|points] [--report-only]

Writes DOC/spots.json, DOC/points.json (every light's figures), DOC/spots.svg, DOC/points.svg (per-light time
and bytes, as Kämpe et al. 2016 plot them) and prints the markdown tables that docs/many-lights.md quotes.
--report-only summarises the bake reports of an earlier run again (OUT/*-report.json), keeping that run's wall
time, machine and load average, without baking.
Python 3 standard library only."""

import argparse
import json
import os
import statistics
import struct
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info  # noqa: E402


def run(cmd):
    print("$ " + " ".join(cmd), flush=True)
    start = time.time()
    subprocess.run(cmd, check=True)
    return time.time() - start


def glb_json(path):
    with open(path, "rb") as f:
        data = f.read()
    length = struct.unpack_from("<I", data, 12)[0]
    return json.loads(data[20:20 + length])


def point_lights_of(scene):
    """The city's spot lights as point lights: same positions and ranges (the issue's 165 point lights)."""
    gltf = glb_json(scene)
    lights = gltf["extensions"]["KHR_lights_punctual"]["lights"]
    out = []
    for node in gltf["nodes"]:
        ext = node.get("extensions", {}).get("KHR_lights_punctual")
        if ext is None:
            continue
        x, y, z = node.get("translation", [0, 0, 0])
        out.append("%.6g,%.6g,%.6g,%.6g" % (x, y, z, lights[ext["light"]]["range"]))
    return out


def percentiles(values):
    s = sorted(values)
    pick = lambda p: s[min(len(s) - 1, int(round(p * (len(s) - 1))))]
    return {"min": s[0], "p10": pick(0.1), "median": pick(0.5), "p90": pick(0.9), "max": s[-1],
            "mean": statistics.fmean(s)}


def summarise(report, wall_s):
    lights = report["lights"]
    per_ms = [l["ms"] for l in lights]
    per_bytes = [sum(v["bytes"] for v in l["views"]) for l in lights]
    shadow_map = [sum(v["shadow_map_bytes"] for v in l["views"]) for l in lights]
    phases = {}
    for l in lights:
        for v in l["views"]:
            for k, ms in v["phases_ms"].items():
                phases[k] = phases.get(k, 0.0) + ms
    views = [v for l in lights for v in l["views"]]
    texels = [float(v["resolution"]) ** 2 for v in views]
    per_view = {"triangles_submitted": percentiles([v["triangles_submitted"] for v in views]),
                "fraction_outside_cone": percentiles([v.get("texels_outside_cone", 0) / t for v, t in zip(views, texels)]),
                "fraction_at_peel_cap": percentiles([v["texels_at_peel_cap"] / t for v, t in zip(views, texels)])}
    return {"lights": len(lights), "views": len(views), "wall_s": wall_s, "per_view": per_view,
            "total_ms": report["total_ms"], "peak_rss_bytes": report["peak_rss_bytes"],
            "file_bytes": report["file_bytes"], "ms_per_light": percentiles(per_ms),
            "bytes_per_light": percentiles(per_bytes),
            "smallest_ratio_to_shadow_map": min(m / max(1, b) for m, b in zip(shadow_map, per_bytes)),
            "phases_ms": phases, "renderer": report["renderer"], "warnings": report.get("warnings", []),
            "per_light": [{"name": l["name"], "ms": l["ms"], "bytes": b} for l, b in zip(lights, per_bytes)]}


def svg(summary, title, path):
    """Per-light bake time (bars) and bytes (dots), light by light, as Figure 3 of Kämpe et al. 2016."""
    per = summary["per_light"]
    w, h, left, right, top, bottom = 900, 320, 60, 70, 30, 40
    pw, ph = w - left - right, h - top - bottom
    max_ms = max(p["ms"] for p in per) or 1
    max_b = max(p["bytes"] for p in per) or 1
    n = len(per)
    out = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" font-family="sans-serif" '
           'font-size="11">' % (w, h), '<rect width="100%" height="100%" fill="white"/>',
           '<text x="%d" y="18" font-size="13">%s</text>' % (left, title)]
    bw = pw / n
    for i, p in enumerate(per):
        bh = ph * p["ms"] / max_ms
        out.append('<rect x="%.1f" y="%.1f" width="%.1f" height="%.1f" fill="#7aa6d8"/>' %
                   (left + i * bw, top + ph - bh, max(0.5, bw * 0.8), bh))
        out.append('<circle cx="%.1f" cy="%.1f" r="1.8" fill="#c0392b"/>' %
                   (left + (i + 0.4) * bw, top + ph - ph * p["bytes"] / max_b))
    out.append('<line x1="%d" y1="%d" x2="%d" y2="%d" stroke="black"/>' % (left, top + ph, left + pw, top + ph))
    for k in range(5):
        y = top + ph - ph * k / 4
        out.append('<text x="%d" y="%.1f" text-anchor="end" fill="#2c6aa8">%.2f s</text>' %
                   (left - 4, y + 4, max_ms * k / 4 / 1000))
        out.append('<text x="%d" y="%.1f" fill="#c0392b">%.2f MB</text>' % (left + pw + 4, y + 4, max_b * k / 4 / 1e6))
    out.append('<text x="%d" y="%d" text-anchor="middle">light (scene order): bars = bake time, dots = bytes</text>' %
               (left + pw / 2, h - 10))
    out.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def table(summary, label):
    ms, b = summary["ms_per_light"], summary["bytes_per_light"]
    ph = summary["phases_ms"]
    total = sum(ph.values()) or 1
    lines = ["| %s | value |" % label, "|---|---|",
             "| lights / views | %d / %d |" % (summary["lights"], summary["views"]),
             "| total (wall, whole run) | %.1f s |" % summary["wall_s"],
             "| per light: min / median / mean / p90 / max | %.2f / %.2f / %.2f / %.2f / %.2f s |" %
             tuple(ms[k] / 1000 for k in ("min", "median", "mean", "p90", "max")),
             "| bytes per light: min / median / mean / p90 / max | %.0f / %.0f / %.0f / %.0f / %.0f kB |" %
             tuple(b[k] / 1000 for k in ("min", "median", "mean", "p90", "max")),
             "| file | %.1f MB |" % (summary["file_bytes"] / 1e6),
             "| smallest ratio 16-bit shadow map / light | %.0fx |" % summary["smallest_ratio_to_shadow_map"],
             "| peak RSS | %.0f MB |" % (summary["peak_rss_bytes"] / 1e6),
             "| per view: triangles submitted median / max | %.0f / %.0f |" %
             (summary["per_view"]["triangles_submitted"]["median"], summary["per_view"]["triangles_submitted"]["max"]),
             "| per view: texels left free outside the cone, median | %.1f %% |" %
             (100 * summary["per_view"]["fraction_outside_cone"]["median"]),
             "| per view: texels still inside a solid at the peel cap, median | %.1f %% |" %
             (100 * summary["per_view"]["fraction_at_peel_cap"]["median"]),
             "| phases (CPU-side sums; masks and DAG overlap rendering) | %s |" %
             ", ".join("%s %.0f %%" % (k, 100 * v / total) for k, v in sorted(ph.items(), key=lambda kv: -kv[1]))]
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="build/bin")
    ap.add_argument("--out", default="out/many-lights")
    ap.add_argument("--doc", default="docs/many-lights")
    ap.add_argument("--lights", type=int, default=165)
    ap.add_argument("--spot-resolution", default="8k")
    ap.add_argument("--point-resolution", default="2k")
    ap.add_argument("--backend", default="cpu")
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--only", choices=["spots", "points"])
    ap.add_argument("--report-only", action="store_true")
    a = ap.parse_args()
    if a.report_only:
        for name in [a.only] if a.only else ["spots", "points"]:
            doc_json = os.path.join(a.doc, name + ".json")
            with open(doc_json) as f:
                earlier = json.load(f)
            with open(os.path.join(a.out, name + "-report.json")) as f:
                summary = summarise(json.load(f), earlier["wall_s"])
            for key in ("machine", "command", "load_average_before", "load_average_after"):
                summary[key] = earlier[key]
            with open(doc_json, "w") as f:
                json.dump(summary, f, indent=1)
            print(table(summary, name))
        return
    os.makedirs(a.out, exist_ok=True)
    os.makedirs(a.doc, exist_ok=True)
    scene = os.path.join(a.out, "city-spots.glb")
    run([os.path.join(a.bin, "cpvs-scenegen"), "city-spots", "--lights", str(a.lights), "-o", scene])
    machine = machine_info()
    with open("/proc/loadavg") as f:
        load_before = f.read().split()[:3]
    jobs = []
    if a.only in (None, "spots"):
        jobs.append(("spots", a.spot_resolution, []))
    if a.only in (None, "points"):
        points = []
        for p in point_lights_of(scene):
            points += ["--point", p]
        jobs.append(("points", a.point_resolution, points))
    for name, resolution, extra in jobs:
        report_path = os.path.join(a.out, name + "-report.json")
        cmd = [os.path.join(a.bin, "cpvs-bake"), scene, "-r", resolution, "--backend", a.backend,
               "-j", str(a.threads), "-o", os.path.join(a.out, name + ".cpvs"), "--report", report_path, "-q"] + extra
        wall = run(cmd)
        with open(report_path) as f:
            summary = summarise(json.load(f), wall)
        with open("/proc/loadavg") as f:
            summary["load_average_after"] = f.read().split()[:3]
        summary["load_average_before"] = load_before
        summary["machine"] = machine
        summary["command"] = " ".join(c if len(c) < 60 else c[:57] + "..." for c in cmd[:14]) + (
            " (+ %d --point flags)" % (len(extra) // 2) if extra else "")
        with open(os.path.join(a.doc, name + ".json"), "w") as f:
            json.dump(summary, f, indent=1)
        svg(summary, "%d %s, city (100k triangles), %s, %s" % (summary["lights"], name, resolution, a.backend),
            os.path.join(a.doc, name + ".svg"))
        print()
        print(table(summary, "%s at %s" % (name, resolution)))
        print()


if __name__ == "__main__":
    main()
