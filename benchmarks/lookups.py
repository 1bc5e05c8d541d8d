#!/usr/bin/env python3
"""Lookup benchmark: unfiltered and 9x9 PCF lookup throughput against Embree occlusion rays on the
same points, one thread each, measured by `cpvs-query --reference --report` in one run per row, with the error
figures beside them. Four shipped scenes (closed, open, thin, terrain), a sun and a spot each, at 4k and 16k.
Writes docs/lookups.md: the machine, every command, the table; text below the analysis marker is kept.

Python 3 standard library only.

    python3 benchmarks/lookups.py                  # bakes into out/bench/lookups/, queries, writes the doc
    python3 benchmarks/lookups.py --reuse-bakes    # keep .cpvs files already baked by the same command
    python3 benchmarks/lookups.py --resolutions 4k --doc out/lookups-quick.md   # a quicker run

Exit status: 0 done (targets met or not: the doc says), 1 usage, 2 a tool failed.
"""

import argparse
import datetime
import json
import os
import shlex
import subprocess
import sys

from machine import machine_line

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
S = "data/scenes"
# key, label, scene, sun direction, spot (px,py,pz,dx,dy,dz,outer angle,range)
SCENES = [
    ("tk", "TorusKnot", f"{S}/TorusKnot/torusknot.gltf", "closed", "0.3,-1,0.2", "10,60,-30,-0.15,-0.85,0.5,0.6,200"),
    ("jt", "JapaneseTemple", f"{S}/JapaneseTemple/scene.gltf", "open", "-0.4,-1,0.3",
     "25,60,30,-0.4467,-0.7380,-0.5057,0.6,150"),
    ("fh", "FlightHelmet", f"{S}/FlightHelmet/FlightHelmet.gltf", "thin", "0.5,-1,-0.3",
     "-0.5,1.2,0.6,0.4236,-0.7413,-0.5207,0.6,5"),
    ("tr", "Terrain", f"{S}/Terrain/terrain.gltf", "terrain", "0.6,-0.5,0.2", "-0.5,2,0.4,0.2,-0.95,-0.2,0.8,10"),
]
KERNELS = [1, 9]
TARGET_LOOKUP_SPEEDUP = 5.0
TARGET_PCF_COST = 4.0
ANALYSIS_MARKER = "<!-- analysis: everything from this line on is hand-written and kept by lookups.py -->"


def run(cmd, log):
    log.append(" ".join(shlex.quote(c) for c in cmd))
    r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if r.returncode != 0:
        sys.stderr.write(f"lookups.py: failed ({r.returncode}): {log[-1]}\n{r.stderr}")
        sys.exit(2)
    return r


def rate(x):
    return f"{x / 1e6:.2f} M" if x >= 1e6 else f"{x / 1e3:.0f} k"


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--bin", default=os.path.join(ROOT, "build-bench", "bin"), help="folder with the tools")
    p.add_argument("--out", default=os.path.join(ROOT, "out", "bench", "lookups"), help="bakes, points, reports")
    p.add_argument("--doc", default=os.path.join(ROOT, "docs", "lookups.md"))
    p.add_argument("--resolutions", default="4k,16k")
    p.add_argument("--points", type=int, default=50000)
    p.add_argument("--timing-rounds", type=int, default=7)
    p.add_argument("--reuse-bakes", action="store_true", help="keep a .cpvs baked earlier by the same command")
    a = p.parse_args()
    resolutions = [r for r in a.resolutions.split(",") if r]
    a.bin, a.out = os.path.relpath(a.bin, ROOT), os.path.relpath(a.out, ROOT)  # commands run in ROOT
    os.makedirs(os.path.join(ROOT, a.out), exist_ok=True)
    tool = lambda name: os.path.join(a.bin, name)
    log = []
    rows = []
    for key, label, scene, kind, sun, spot in SCENES:
        points = os.path.join(a.out, f"{key}.csv")
        run([tool("cpvs-sample"), scene, "-n", str(a.points), "--seed", "1", "-o", points], log)
        for res in resolutions:
            cpvs = os.path.join(a.out, f"{key}-{res}.cpvs")
            bake = [tool("cpvs-bake"), scene, "-o", cpvs, "--resolution", res, "--sun", sun, "--spot", spot, "--quiet"]
            stamp = os.path.join(ROOT, cpvs + ".cmd")
            cached = a.reuse_bakes and os.path.exists(os.path.join(ROOT, cpvs)) and os.path.exists(stamp) and \
                open(stamp).read() == " ".join(bake)
            if cached:
                log.append(" ".join(shlex.quote(c) for c in bake) + "   # reused")
            else:
                run(bake, log)
                with open(stamp, "w") as f:
                    f.write(" ".join(bake))
            for k in KERNELS:
                report = os.path.join(a.out, f"{key}-{res}-k{k}.json")
                run([tool("cpvs-query"), cpvs, "--points", points, "-o", os.path.join(a.out, f"{key}-{res}-k{k}.csv"),
                     "--pcf", str(k), "--reference", scene, "--report", report, "--threads", "2",
                     "--timing-rounds", str(a.timing_rounds), "--quiet"], log)
                with open(os.path.join(ROOT, report)) as f:
                    r = json.load(f)
                rows.append((label, kind, res, k, r, os.path.getsize(os.path.join(ROOT, cpvs))))
                print(f"{label} {res} K={k}: {rate(r['lookups_per_s'])}/s lookups, "
                      f"{rate(r['reference']['rays_per_s'])}/s rays", flush=True)

    out = []
    w = out.append
    w("# Lookup throughput against Embree rays")
    w("")
    w("Generated by `python3 benchmarks/lookups.py`; do not edit the table by hand. Each row is one `cpvs-query "
      "--reference --report` run (sun and spot together): `lookups_per_s`, `lookups_per_s_unfiltered` and "
      "`rays_per_s` come from the same run, on the same points, **one thread each**, best of "
      f"{a.timing_rounds} interleaved rounds (docs/query.md, \"How throughput is measured\"). "
      f"{a.points} points per scene from `cpvs-sample` (area-weighted, random order, seed 1).")
    w("")
    w("* Machine: " + machine_line(with_load=True))
    w(f"* Date: {datetime.date.today().isoformat()}; build: Release (`-O3`, baseline x86-64; the batch mapping picks its AVX-512 or AVX2 kernel at run time) from `{a.bin}`")
    offsets = sorted({r["reference"].get("relative_epsilon", 1e-5) for _, _, _, _, r, _ in rows})  # 0.4.0: 1e-5
    w("* Reference rays start " + " or ".join(f"{e:g}" for e in offsets) + " of the scene's diagonal off the "
      "surface (docs/query.md, \"The reference's offset\")")
    w("* Targets: unfiltered lookups ≥ 5× Embree occlusion rays; 9×9 PCF ≤ 4× the cost of an unfiltered lookup.")
    w("")
    w("| scene | N | K | lookups/s | single-point calls/s | rays/s (16-wide packets) | lookups ÷ rays | PCF cost | "
      "misclassified (uniform) | mean abs diff | file |")
    w("|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    speedups, costs = [], []
    for label, kind, res, k, r, size in rows:
        ref = r["reference"]
        speed = r["lookups_per_s"] / ref["rays_per_s"] if ref["rays_per_s"] else 0.0
        cost = r.get("pcf_cost", 1.0)
        if k == 1:
            speedups.append((label, res, speed))
        else:
            costs.append((label, res, cost))
        w(f"| {label} ({ref['triangles']} triangles, {kind}) | {res} | {k} | {rate(r['lookups_per_s'])} | "
          f"{rate(r['lookups_per_s_single'])} | {rate(ref['rays_per_s'])} ({rate(ref['rays_per_s_packets'])}) | "
          f"{'**' if k == 1 else ''}{speed:.1f}×{'**' if k == 1 else ''} | "
          f"{'**%.2f×**' % cost if k > 1 else '—'} | "
          f"{100 * ref['misclassified']:.3f} % ({100 * ref['misclassified_uniform']:.3f} %) | "
          f"{ref['mean_abs_diff']:.4f} | {size / 1e6:.1f} MB |")
    w("")
    met = sum(1 for _, _, s in speedups if s >= TARGET_LOOKUP_SPEEDUP)
    w(f"Unfiltered lookups ÷ rays: {min(s for *_, s in speedups):.1f}× to {max(s for *_, s in speedups):.1f}×; "
      f"{met} of {len(speedups)} rows reach the {TARGET_LOOKUP_SPEEDUP:g}× target. 9×9 PCF cost: "
      f"{min(c for *_, c in costs):.2f}× to {max(c for *_, c in costs):.2f}× "
      f"({'all within' if all(c <= TARGET_PCF_COST for *_, c in costs) else 'not all within'} the "
      f"{TARGET_PCF_COST:g}× target).")
    w("")
    w("## Commands")
    w("")
    w("```sh")
    out.extend(log)
    w("```")
    w("")
    analysis = ANALYSIS_MARKER + "\n\n(No analysis yet.)\n"
    if os.path.exists(a.doc):
        text = open(a.doc).read()
        if ANALYSIS_MARKER in text:
            analysis = text[text.index(ANALYSIS_MARKER):]
    with open(a.doc, "w") as f:
        f.write("\n".join(out) + "\n" + analysis)
    print(f"lookups.py: wrote {a.doc}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
