#!/usr/bin/env python3
"""A log-log figure of bytes against error from benchmarks/lossy.py's JSON: per scene, the lossless bakes as a
line over resolution and the lossy ones as labelled points, as SVG.

    python3 benchmarks/plot_bytes_vs_error.py docs/lossy/bytes-vs-error.json --scene foliage \
        -o docs/lossy/bytes-vs-error-foliage.svg

x: the file's bytes; y: misclassified facing pairs against the rays. A point below and left of the lossless line
is a better trade than lowering the resolution. Python 3 standard library only.
"""

import argparse
import json
import math


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("json")
    p.add_argument("--scene", default="foliage")
    p.add_argument("-o", "--output", required=True)
    a = p.parse_args()
    with open(a.json) as f:
        data = json.load(f)
    runs = [r for r in data["runs"] if r["scene"] == a.scene]
    lossless = sorted((r for r in runs if r["max_voxel_error"] is None), key=lambda r: r["bytes"])
    lossy = [r for r in runs if r["max_voxel_error"] is not None]
    xs = [r["bytes"] for r in runs]
    ys = [100 * r["misclassified_facing"] for r in runs]
    width, height, left, right, top, bottom = 760, 480, 80, 40, 50, 50
    x0, x1 = math.floor(math.log10(min(xs))), math.ceil(math.log10(max(xs)))
    y0, y1 = math.log10(min(ys) * 0.8), math.log10(max(ys) * 1.25)

    def px(b):
        return left + (math.log10(b) - x0) / (x1 - x0) * (width - left - right)

    def py(e):
        return height - bottom - (math.log10(e) - y0) / (y1 - y0) * (height - top - bottom)

    out = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" font-family="sans-serif" '
           'font-size="12">' % (width, height), '<rect width="100%" height="100%" fill="white"/>']
    for e in range(x0, x1 + 1):
        for m in (1, 2, 5):
            b = m * 10 ** e
            if b < 10 ** x0 or b > 10 ** x1:
                continue
            x = px(b)
            out.append('<line x1="%.1f" y1="%d" x2="%.1f" y2="%d" stroke="#ddd"/>' % (x, top, x, height - bottom))
            out.append('<text x="%.1f" y="%d" text-anchor="middle">%s</text>' % (
                x, height - bottom + 18, "%g MB" % (b / 1e6) if b < 1e9 else "%g GB" % (b / 1e9)))
    for e in (0.1, 0.2, 0.5, 1, 2, 5, 10, 20):
        if math.log10(e) < y0 or math.log10(e) > y1:
            continue
        y = py(e)
        out.append('<line x1="%d" y1="%.1f" x2="%d" y2="%.1f" stroke="#ddd"/>' % (left, y, width - right, y))
        out.append('<text x="%d" y="%.1f" text-anchor="end">%g %%</text>' % (left - 6, y + 4, e))
    out.append('<text x="%d" y="%d" text-anchor="middle">bytes of the file, log scale</text>' % (
        (left + width - right) // 2, height - 10))
    out.append('<text x="%d" y="%d">%s sun: misclassified facing pairs against rays (log scale)</text>' % (
        left - 60, top - 22, a.scene))
    out.append('<text x="%d" y="%d">line: lossless by resolution; dots: lossy, resolution and '
               '--max-voxel-error / --max-edge-error</text>' % (left - 60, top - 8))
    path = " ".join("%s%.1f,%.1f" % ("M" if k == 0 else "L", px(r["bytes"]), py(100 * r["misclassified_facing"]))
                    for k, r in enumerate(lossless))
    out.append('<path d="%s" fill="none" stroke="#000" stroke-width="2"/>' % path)
    for r in lossless:
        x, y = px(r["bytes"]), py(100 * r["misclassified_facing"])
        out.append('<circle cx="%.1f" cy="%.1f" r="3" fill="#000"/>' % (x, y))
        out.append('<text x="%.1f" y="%.1f">%s</text>' % (x + 6, y - 6, r["resolution"]))
    colours = {"32k": "#1f77b4", "64k": "#d62728", "16k": "#2ca02c"}
    for k, r in enumerate(sorted(lossy, key=lambda r: r["bytes"])):
        x, y = px(r["bytes"]), py(100 * r["misclassified_facing"])
        colour = colours.get(r["resolution"], "#9467bd")
        out.append('<circle cx="%.1f" cy="%.1f" r="4" fill="%s"/>' % (x, y, colour))
        # Labels alternate below and above their dots, so neighbours do not cover each other.
        out.append('<text x="%.1f" y="%.1f" fill="%s" text-anchor="%s">%s %d/%d</text>' % (
            x + (6 if k % 2 == 0 else -6), y + (16 if k % 2 == 0 else -8), colour, "start" if k % 2 == 0 else "end",
            r["resolution"], r["max_voxel_error"], r["max_edge_error"]))
    out.append("</svg>")
    with open(a.output, "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
