#!/usr/bin/env python3
"""A log-log figure of bake time against resolution from benchmarks/uniform_tiles.py's JSON files (runs of one scene and
light, e.g. one file up to 64k with the per-texel path and one of 128k-256k without), as SVG.

    python3 benchmarks/plot_bake_time.py docs/depth-maps/uniform-tiles-sun.json docs/depth-maps/uniform-tiles-sun-large.json \
        -o docs/depth-maps/bake-time.svg

Lines: our bake's CPU seconds with uniform tiles (best run per resolution), each phase of it (summed CPU time of
the report's depth, peel, masks and dag), the per-texel path where it ran, and the closed-construction totals
of Kämpe et al. 2015, Table 1 (CLOSED CITY with identical-node culling, on their GPU; 4k-256k). Python 3
standard library only.
"""

import argparse
import json
import math

# Kämpe et al. 2015, Table 1: closed construction with culling of identical nodes, total seconds.
PAPER = {4096: 0.113, 8192: 0.185, 16384: 0.377, 32768: 1.1, 65536: 3.3, 131072: 10.9, 262144: 38.1}


def resolution_value(text):
    text = text.lower()
    return int(text[:-1]) * 1024 if text.endswith("k") else int(text)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("json", nargs="+")
    p.add_argument("-o", "--output", required=True)
    a = p.parse_args()
    data = None
    for path in a.json:
        with open(path) as f:
            part = json.load(f)
        if data is None:
            data = part
        else:
            data["runs"] += part["runs"]
    best = {}
    for r in data["runs"]:
        key = (resolution_value(r["resolution"]), r["per_texel"])
        if key not in best or r["cpu_s"] < best[key]["cpu_s"]:
            best[key] = r
    resolutions = sorted({k[0] for k in best})
    series = [("uniform tiles: CPU s", "#000000", 2.5, [(n, best[(n, False)]["cpu_s"]) for n in resolutions
                                                        if (n, False) in best]),
              ("per-texel path: CPU s", "#888888", 2.0, [(n, best[(n, True)]["cpu_s"]) for n in resolutions
                                                         if (n, True) in best])]
    colours = {"depth": "#1f77b4", "peel": "#ff7f0e", "masks": "#2ca02c", "dag": "#d62728"}
    for phase, colour in colours.items():
        series.append(("  phase %s" % phase, colour, 1.2,
                       [(n, best[(n, False)]["phases_s"].get(phase, 0.0)) for n in resolutions
                        if (n, False) in best and best[(n, False)]["phases_s"].get(phase, 0.0) > 0]))
    series.append(("paper, GPU (Table 1)", "#9467bd", 2.0, sorted(PAPER.items())))

    width, height, left, right, top, bottom = 760, 480, 70, 230, 30, 50
    xs = [n for _, _, _, pts in series for n, _ in pts]
    ys = [t for _, _, _, pts in series for _, t in pts]
    x0, x1 = math.log2(min(xs)), math.log2(max(xs))
    y0, y1 = math.floor(math.log10(min(ys))), math.ceil(math.log10(max(ys)))

    def px(n):
        return left + (math.log2(n) - x0) / max(1e-9, x1 - x0) * (width - left - right)

    def py(t):
        return height - bottom - (math.log10(t) - y0) / (y1 - y0) * (height - top - bottom)

    out = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" font-family="sans-serif" '
           'font-size="12">' % (width, height), '<rect width="100%" height="100%" fill="white"/>']
    for e in range(y0, y1 + 1):
        y = py(10 ** e)
        out.append('<line x1="%d" y1="%.1f" x2="%d" y2="%.1f" stroke="#ddd"/>' % (left, y, width - right, y))
        out.append('<text x="%d" y="%.1f" text-anchor="end">%s s</text>' % (left - 6, y + 4, "%g" % (10 ** e)))
    for n in sorted(set(xs)):
        x = px(n)
        out.append('<line x1="%.1f" y1="%d" x2="%.1f" y2="%d" stroke="#ddd"/>' % (x, top, x, height - bottom))
        out.append('<text x="%.1f" y="%d" text-anchor="middle">%s</text>' % (
            x, height - bottom + 18, "%dk" % (n // 1024) if n >= 1024 else str(n)))
    out.append('<text x="%d" y="%d" text-anchor="middle">resolution N (N^3 voxels), log scale</text>' % (
        (left + width - right) // 2, height - 10))
    for i, (name, colour, stroke, pts) in enumerate(series):
        if not pts:
            continue
        path = " ".join("%s%.1f,%.1f" % ("M" if k == 0 else "L", px(n), py(t)) for k, (n, t) in enumerate(pts))
        dash = ' stroke-dasharray="6,4"' if name.startswith("paper") else ""
        out.append('<path d="%s" fill="none" stroke="%s" stroke-width="%.1f"%s/>' % (path, colour, stroke, dash))
        for n, t in pts:
            out.append('<circle cx="%.1f" cy="%.1f" r="2.5" fill="%s"/>' % (px(n), py(t), colour))
        ly = top + 10 + 18 * i
        out.append('<line x1="%d" y1="%d" x2="%d" y2="%d" stroke="%s" stroke-width="%.1f"%s/>' % (
            width - right + 12, ly, width - right + 36, ly, colour, stroke, dash))
        out.append('<text x="%d" y="%d">%s</text>' % (width - right + 42, ly + 4, name.strip()))
    out.append('<text x="%d" y="%d">%s, %s -j %d, %s</text>' % (
        left, top - 10, data["scene"], data["light"], data["threads"], data["machine"]["model"]))
    out.append("</svg>")
    with open(a.output, "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
