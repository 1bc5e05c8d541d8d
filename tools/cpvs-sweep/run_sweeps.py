#!/usr/bin/env python3
"""Runs cpvs-sweep (speed against error) on the shipped scenes and the generated cities, each with a
sun and a spot light, and assembles docs/speed-vs-error.md from the per-scene tables and SVG plots in
docs/speed-vs-error/. Python 3 standard library only.

    python3 tools/cpvs-sweep/run_sweeps.py                   # every scene, 1k..16k (long on 2 cores)
    python3 tools/cpvs-sweep/run_sweeps.py --quick           # 1k..4k, fewer points, into out/sweep-quick/
    python3 tools/cpvs-sweep/run_sweeps.py --only torusknot  # one scene
    python3 tools/cpvs-sweep/run_sweeps.py --report-only     # reassemble the markdown from the JSON files

A scene whose JSON already exists with the same cpvs-sweep command is not run again (use --force).
"""

import argparse
import datetime
import json
import os
import shlex
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
from kept_analysis import kept_analysis  # noqa: E402  (shared with the benchmarks)
from machine import machine_line  # noqa: E402

# name, scene (relative to the repository), what it tests, light arguments. Lights are chosen so that each
# scene casts shadows on itself from a sun and from a spot whose cone covers the interesting part.
SCENES = [
    ("torusknot", "data/scenes/TorusKnot/torusknot.gltf", "closed, curved self-shadowing",
     ["--sun", "0.3,-1,0.2", "--spot", "40,60,30,-0.5121,-0.7682,-0.3841,0.6,250"]),
    ("terrain", "data/scenes/Terrain/terrain.gltf", "terrain (open height field), low sun",
     ["--sun", "0.6,-0.5,0.3", "--spot", "1.5,1.5,1,-0.6396,-0.6396,-0.4264,0.7,10"]),
    ("subpass", "data/scenes/SubpassSceneOpaque/subpass_scene_opaque.gltf",
     "mixed closed and open architecture (authored -Y up, so the light travels toward +Y)",
     ["--sun", "0.3,1,0.2", "--spot", "8,-15,6,-0.4240,0.7950,-0.3180,0.7,60"]),
    ("flighthelmet", "data/scenes/FlightHelmet/FlightHelmet.gltf", "thin structures (straps, hoses, stand)",
     ["--sun", "0.4,-1,0.3", "--spot", "0.6,1.2,0.5,-0.5124,-0.7259,-0.4270,0.6,5"]),
    ("japanesetemple", "data/scenes/JapaneseTemple/scene.gltf", "open geometry: columns, railings, roofs",
     ["--sun", "0.4,-1,0.3", "--spot", "25,45,20,-0.5132,-0.7184,-0.4105,0.6,120"]),
    ("city", "out/bench/scenes/city-t100000-s1.glb", "generated closed city (cpvs-scenegen city, 100k triangles)",
     ["--sun", "0.4,-1,0.3", "--spot", "100,200,50,-0.4364,-0.8729,-0.2182,0.5,600", "--min-light-points", "50000"]),
    ("open-city", "out/bench/scenes/open-city-t100000-s1.glb",
     "generated open city (cpvs-scenegen open-city, single-sided walls)",
     ["--sun", "0.4,-1,0.3", "--spot", "100,200,50,-0.4364,-0.8729,-0.2182,0.5,600", "--min-light-points", "50000"]),
]
GENERATED = {"city-t100000-s1.glb": ["city", "--triangles", "100000", "--seed", "1"],
             "open-city-t100000-s1.glb": ["open-city", "--triangles", "100000", "--seed", "1"]}

TARGET_RATIO = 10.0
ANALYSIS_MARKER = "<!-- analysis: everything from this line on is hand-written and kept by run_sweeps.py -->"


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--bin", default=os.path.join(ROOT, "build-bench", "bin"), help="folder with cpvs-sweep")
    p.add_argument("--out-dir", default=None, help="per-scene outputs (default docs/speed-vs-error; --quick: out/sweep-quick)")
    p.add_argument("--doc", default=None, help="markdown (default docs/speed-vs-error.md; --quick: out/sweep-quick.md)")
    p.add_argument("--resolutions", default=None, help="default 1k,2k,4k,8k,16k (--quick: 1k,2k,4k)")
    p.add_argument("--points", type=int, default=None, help="surface samples per scene (default 200000; --quick 20000)")
    p.add_argument("--quick", action="store_true", help="smoke run")
    p.add_argument("--only", action="append", default=[], help="run only this scene name (repeatable)")
    p.add_argument("--force", action="store_true", help="run again even when the JSON exists")
    p.add_argument("--report-only", action="store_true", help="only reassemble the markdown")
    a = p.parse_args()
    out_dir = os.path.abspath(a.out_dir or (os.path.join(ROOT, "out", "sweep-quick") if a.quick
                                            else os.path.join(ROOT, "docs", "speed-vs-error")))
    doc = os.path.abspath(a.doc or (os.path.join(ROOT, "out", "sweep-quick.md") if a.quick
                                    else os.path.join(ROOT, "docs", "speed-vs-error.md")))
    resolutions = a.resolutions or ("1k,2k,4k" if a.quick else "1k,2k,4k,8k,16k")
    points = a.points or (20000 if a.quick else 200000)
    sweep = os.path.join(a.bin, "cpvs-sweep")
    if not a.report_only and not os.access(sweep, os.X_OK):
        sys.exit(f"run_sweeps.py: {sweep} not found; build it: ninja -C build-bench cpvs-sweep")
    os.makedirs(out_dir, exist_ok=True)
    failed = []
    for name, scene, what, lights in SCENES:
        if a.only and name not in a.only:
            continue
        path = os.path.join(ROOT, scene)
        base = os.path.basename(scene)
        if base in GENERATED and not os.path.exists(path) and not a.report_only:
            gen = [os.path.join(a.bin, "cpvs-scenegen")] + GENERATED[base][:1] + ["-o", path] + GENERATED[base][1:]
            os.makedirs(os.path.dirname(path), exist_ok=True)
            subprocess.run(gen, check=True)
        cmd = [sweep, scene, *lights, "--resolutions", resolutions, "--points", str(points), "--name", name,
               "--out-dir", os.path.relpath(out_dir, ROOT)]
        js = os.path.join(out_dir, name + ".json")
        if os.path.exists(js) and not a.force:
            with open(js) as f:
                old = json.load(f)
            want = "cpvs-sweep " + " ".join(shlex.quote(x) if " " in x else x for x in cmd[1:])
            if old.get("command") == want or a.report_only:
                print(f"cached   {name}")
                continue
        if a.report_only:
            continue
        print(f"running  {name}: {' '.join(cmd)}", flush=True)
        started = datetime.datetime.now()
        proc = subprocess.run(cmd, cwd=ROOT, stdout=subprocess.DEVNULL)
        print(f"         {name}: exit {proc.returncode} after {(datetime.datetime.now() - started).seconds} s", flush=True)
        if proc.returncode != 0:
            failed.append(name)
        elif os.path.exists(js):  # which run_sweeps.py command measured this scene (scenes may come from different runs)
            with open(js) as f:
                measured = json.load(f)
            measured["run_sweeps_command"] = this_command()
            measured["machine"] = machine_line()  # scenes may come from runs on different machines
            with open(js, "w") as f:
                json.dump(measured, f, indent=1, ensure_ascii=False)
                f.write("\n")
    write_doc(a, out_dir, doc, resolutions, points)
    return 2 if failed else 0


def this_command():
    return "python3 " + " ".join([os.path.relpath(os.path.abspath(sys.argv[0]), ROOT)] +
                                 [shlex.quote(x) for x in sys.argv[1:]])


def summary_table(w, jsons, res_all, cell):
    """One row per scene and light, one column per resolution; cell(row, n) gives (text, counted, met) or None.
    Returns (met, counted)."""
    w("| scene | light | " + " | ".join(res_name(n) for n in res_all) + " |")
    w("|---|---|" + "---:|" * len(res_all))
    met, counted = 0, 0
    for name, what, j in jsons:
        for light in [l["name"] for l in j["lights"]]:
            cells = []
            for n in res_all:
                row = next((r for r in j["rows"] if r["light"] == light and r["resolution"] == n), None)
                value = cell(row, n, max(r["resolution"] for r in j["rows"])) if row else None
                if value is None:
                    cells.append("—")
                    continue
                text, counts, ok = value
                cells.append(text)
                counted += counts
                met += counts and ok
            w(f"| {name} | {light} | " + " | ".join(cells) + " |")
    w("")
    return met, counted


def write_doc(a, out_dir, doc, resolutions, points):
    L = []
    w = L.append
    w("# Speed against error")
    w("")
    w("Generated by `tools/cpvs-sweep/run_sweeps.py` from `cpvs-sweep` runs; do not edit the tables by hand. "
      "For each scene and light the CPVS is baked at each resolution N, sampled surface points are answered "
      "with the CPVS lookup (unfiltered, the normal bias of [Kämpe et al. 2015](references.md), §4) and compared with Embree shadow rays "
      "(the rule of `cpvs-query --reference`). Beside it, a plain 16-bit shadow map of **equal bytes** "
      "(M = floor(sqrt(DAG bytes / 2)) texels square over the same fitted view, same depth mapping, same normal "
      "bias rule in its own voxel units, depth from Embree rays through the texel centres; "
      "libcpvs/eval/shadow_map.h) answers the same points.")
    w("")
    w("* *misclassified*: points whose binary answer (value ≥ 0.5 = lit) differs from the ray-traced one, over "
      "the light's points (surface samples inside the light's influence that face the light; points facing away "
      "are in their own surface's shadow for every method and are left out).")
    w("* *misclassified_uniform*: the same over the points whose reference is the same everywhere within 2 voxels "
      "(at that N): on a circle of radius 2 voxels on the surface and 2 voxels out along the normal, as "
      "`cpvs-query --reference` defines it (docs/query.md) — the figure that excludes shadow edges and occluders "
      "closer to the surface than the voxels can resolve.")
    w("* *bytes*: the light's DAG (node units + leaf masks); *bake*: depth + peel + masks + DAG of the light's "
      "views; *lookups/s*: one thread, batches of 4096 points as cpvs-query makes them, with the ratio to Embree's "
      "rays timed beside them.")
    w("")
    jsons = []
    for name, scene, what, lights in SCENES:
        js = os.path.join(out_dir, name + ".json")
        if os.path.exists(js):
            with open(js) as f:
                jsons.append((name, what, json.load(f)))
    renderer = next((j["renderer"] for _, _, j in jsons if j.get("renderer")), "")
    w("## Machine and command")
    w("")
    # The machine each scene was measured on (recorded in its JSON; older JSONs lack it).
    machines = []
    for name, _, j in jsons:
        m = j.get("machine", "not recorded (measured before run_sweeps.py recorded the machine)")
        entry = next((e for e in machines if e[0] == m), None)
        if entry:
            entry[1].append(name)
        else:
            machines.append((m, [name]))
    if len(machines) == 1:
        w(f"* {machines[0][0]}")
    for m, names in machines if len(machines) > 1 else []:
        w(f"* {', '.join(names)}: {m}")
    if renderer:
        w(f"* Renderer for the bakes: `{renderer}`")
    offsets = sorted({j.get("reference_epsilon", 1e-5) for _, _, j in jsons})  # JSONs before 0.4.1 lack it: 1e-5
    if offsets:
        w("* Reference rays start " + " or ".join(f"{e:g}" for e in offsets) + " of the scene's diagonal off the "
          "surface (`--reference-epsilon`, docs/query.md \"The reference's offset\")" +
          ("" if len(offsets) == 1 else ": " + ", ".join(
              f"{name} {j.get('reference_epsilon', 1e-5):g}" for name, _, j in jsons)) + ".")
    w("* The machine is shared with other work (2 cores): bake times and throughputs are indicative; "
      "misclassification counts are deterministic (fixed seeds, deterministic bakes).")
    # The run_sweeps.py commands that measured the scenes (recorded in each scene's JSON; older JSONs lack it).
    runs = []
    for name, _, j in jsons:
        c = j.get("run_sweeps_command")
        if c:
            entry = next((r for r in runs if r[0] == c), None)
            if entry:
                entry[1].append(name)
            else:
                runs.append((c, [name]))
    if runs:
        parts = [f"`{c}` ({', '.join(names)})" for c, names in runs]
        w("* Commands: " + "; ".join(parts) + ". Each runs, per scene, the `cpvs-sweep` command shown in its "
          f"section ({points} surface samples).")
    else:
        command = "* Command: `" + this_command() + "`, " + \
            (f"which runs, per scene, the `cpvs-sweep` command shown in its section (resolutions {resolutions}, "
             f"{points} surface samples).")
        if a.report_only and os.path.exists(doc):  # keep the command of the run that measured the tables
            with open(doc) as f:
                command = next((line.rstrip("\n") for line in f if line.startswith("* Command: `python3 ")), command)
        w(command)
    w("")
    # Summary.
    w("## Summary: error against the equal-bytes shadow map")
    w("")
    w("Per scene and light at each N: how many times more points the equal-bytes shadow map misclassifies than "
      "the CPVS (≥ when the CPVS misclassified none: counted as one). Target: ≥ 10×.")
    w("")
    res_all = sorted({r["resolution"] for _, _, j in jsons for r in j["rows"]})

    def sm_cell(row, n, largest):  # text, whether it counts toward the target line, whether it meets it
        c, s = row["misclassified_count"], row["shadow_map"]["misclassified_count"]
        ratio = s / max(c, 1)
        return ("≥ " if c == 0 else "") + f"{ratio:.1f}×", n == largest, ratio >= TARGET_RATIO

    met, total = summary_table(w, jsons, res_all, sm_cell)
    if total:
        largest = sorted({max(r["resolution"] for r in j["rows"]) for _, _, j in jsons})
        at = (f"the largest N ({res_name(largest[0])})" if len(largest) == 1
              else "each scene's largest N (" + ", ".join(map(res_name, largest)) + ")")
        w(f"At {at}: {met} of {total} scene/light pairs reach the 10× target.")
        w("")
    w("## Summary: compression against a shadow map of the same resolution")
    w("")
    w("Per scene and light at each N: C = (2 N² bytes of a 16-bit N × N shadow map) ÷ (the light's DAG bytes), "
      "and in brackets √C, the ratio of the CPVS's N to the equal-bytes shadow map's M. Errors at shadow edges "
      "fall about as 1 / resolution, so the equal-bytes error ratio above follows √C.")
    w("")

    def compression_cell(row, n, largest):
        c = 2.0 * n * n / max(row["bytes"], 1)
        return f"{c:.0f} ({c ** 0.5:.1f})", False, False

    summary_table(w, jsons, res_all, compression_cell)
    fits = [(r["shadow_map"]["misclassified_count"] / max(r["misclassified_count"], 1)) /
            (2.0 * r["resolution"] ** 2 / max(r["bytes"], 1)) ** 0.5
            for _, _, j in jsons for r in j["rows"] if r["resolution"] >= 8192 and r["misclassified_count"] >= 10]
    if fits:
        fits.sort()
        w(f"Equal-bytes error ratio ÷ √C over the rows at N ≥ 8k with at least 10 CPVS errors ({len(fits)} rows): "
          f"{fits[0]:.2f} to {fits[-1]:.2f}, median {fits[len(fits) // 2]:.2f}; at the median, the 10× target needs "
          f"C ≈ {(TARGET_RATIO / fits[len(fits) // 2]) ** 2:.0f}.")
        w("")
    w("## Summary: lookups against Embree rays")
    w("")
    w("Per scene and light at each N: CPVS lookups per second ÷ Embree occlusion rays per second on the same "
      "points, one thread each, timed beside each other in the same row (best of three interleaved rounds). "
      "Target: ≥ 5×.")
    w("")

    def lookup_cell(row, n, largest):
        if not row.get("rays_per_s"):
            return None
        speedup = row["lookups_per_s"] / row["rays_per_s"]
        return f"{speedup:.1f}×", True, speedup >= 5.0

    fast, pairs = summary_table(w, jsons, res_all, lookup_cell)
    if pairs:
        w(f"{fast} of {pairs} scene/light/resolution rows reach 5×.")
        w("")
    w("## Scenes")
    w("")
    for name, what, j in jsons:
        md = os.path.join(out_dir, name + ".md")
        w(f"<!-- {name}: {what} -->")
        if os.path.exists(md):
            with open(md) as f:
                text = f.read().rstrip()
            rel = os.path.relpath(out_dir, os.path.dirname(doc))
            text = text.replace(f"](speed-vs-error/{name}.svg)", f"]({rel}/{name}.svg)")
            text = text.replace(f"### {name}\n", f"### {name} — {what}\n", 1)
            w(text)
            w("")
    L.extend(kept_analysis(doc, ANALYSIS_MARKER))
    with open(doc + ".tmp", "w") as f:
        f.write("\n".join(L) + "\n")
    os.replace(doc + ".tmp", doc)
    print(f"wrote {os.path.relpath(doc, ROOT)}")


def res_name(n):
    return f"{n // 1024}k" if n >= 1024 and n % 1024 == 0 else str(n)


if __name__ == "__main__":
    sys.exit(main())
