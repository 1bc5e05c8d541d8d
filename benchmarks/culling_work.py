#!/usr/bin/env python3
"""The culling papers' claims checked in work units, not llvmpipe milliseconds: per shadow-map mode of cpvs-view,
the triangles drawn into the maps, the fragments that passed the depth test while drawing them (GL occlusion
queries), the maps drawn and the texels cleared. These counts do not depend on the machine, so each mode runs
once per camera.

    python3 benchmarks/culling_work.py [--bin build/bin] [--out out/culling-work] [--doc docs/culling-demo]
                                       [--size 1920x1080] [--map-size 512] [--cameras 0,7]

Scenes: the generated city with 165 spot lights (cpvs-scenegen city-spots) and the sun-lit city (cpvs-scenegen
city), each baked at 1k only for its lights (the map modes draw from the scene). Cameras: benchmarks/viewer.py's
flythrough (0: the overview; 7: street level). Claims (docs/culling-demo.md): voxel-grid culling draws
1.5-8.6x fewer than frustum culling (Selgrad et al. 2016); receiver masks 3-10x fewer for a sun (Bittner et al.
2011); LightCluster with 10 clusters about 4.8x fewer map fragments than a map per light (Wiesenhuetter et al.).
Writes DOC/work.json and DOC/work.md. Python 3 standard library only."""

import argparse
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info  # noqa: E402
from viewer import flythrough  # noqa: E402

SPOT_MODES = {
    "none": ["--shadows", "shadowmap", "--caster-culling", "none"],
    "frustum": ["--shadows", "shadowmap", "--caster-culling", "frustum"],
    "voxel-grid": ["--shadows", "shadowmap", "--caster-culling", "voxel-grid"],
    "receiver-mask frag": ["--shadows", "shadowmap", "--caster-culling", "receiver-mask", "--mask-variant", "frag"],
    "receiver-mask bvol": ["--shadows", "shadowmap", "--caster-culling", "receiver-mask", "--mask-variant", "bvol"],
    "lightcluster 10 (frustum)": ["--shadows", "lightcluster", "--clusters", "10", "--caster-culling", "frustum"],
}
SUN_MODES = {k: v for k, v in SPOT_MODES.items() if not k.startswith("lightcluster")}


def work(a, scene, cpvs, camera, flags, tag):
    path = os.path.join(a.out, tag + "-camera.json")
    with open(path, "w") as f:
        json.dump([camera], f)
    report = os.path.join(a.out, tag + ".json")
    cmd = [os.path.join(a.bin, "cpvs-view"), scene, cpvs, "--path", path, "--frames", os.path.join(a.out, "frames"),
           "--size", a.size, "--shadow-map-size", str(a.map_size), "--report", report, "-q"] + flags
    print("$ " + " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True)
    with open(report) as f:
        sm = json.load(f)["frames"][0]["shadow_maps"]
    return {k: sm[k] for k in ("maps", "triangles_drawn", "fragments", "texels_cleared", "draw_calls")}


def scene_and_bake(a, kind, extra):
    scene = os.path.join(a.out, kind + ".glb")
    subprocess.run([os.path.join(a.bin, "cpvs-scenegen"), kind, "-o", scene] + extra, check=True)
    cpvs = os.path.join(a.out, kind + "-1k.cpvs")
    if not os.path.exists(cpvs):
        subprocess.run([os.path.join(a.bin, "cpvs-bake"), scene, "-r", "1k", "-o", cpvs, "-q"], check=True)
    return scene, cpvs


def table(title, rows, modes, cameras):
    lines = ["### " + title, "", "| mode | camera | maps | triangles drawn | fragments | texels cleared | draw calls |",
             "|---|---|---:|---:|---:|---:|---:|"]
    for mode in modes:
        for c in cameras:
            r = rows[mode][str(c)]
            lines.append("| %s | %d | %d | %s | %s | %s | %d |" % (mode, c, r["maps"], format(r["triangles_drawn"], ","),
                                                                 format(r["fragments"], ","),
                                                                 format(r["texels_cleared"], ","), r["draw_calls"]))
    return lines


def ratios(rows, slow, fast, cameras, keys):
    out = []
    for key in keys:
        values = ["%.2f" % (rows[slow][str(c)][key] / max(1, rows[fast][str(c)][key])) for c in cameras]
        out.append("%s: %s over %s = %s× (cameras %s)" % (key.replace("_", " "), slow, fast, " / ".join(values),
                                                            ", ".join(str(c) for c in cameras)))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="build/bin")
    ap.add_argument("--out", default="out/culling-work")
    ap.add_argument("--doc", default="docs/culling-demo")
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--map-size", type=int, default=512)
    ap.add_argument("--cameras", default="0,7")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    os.makedirs(a.doc, exist_ok=True)
    cameras = [int(c) for c in a.cameras.split(",")]
    path = flythrough(8)
    result = {"machine": machine_info(), "size": a.size, "map_size": a.map_size, "cameras": cameras,
              "commit": subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                                       text=True).stdout.strip(),
              "command": "python3 benchmarks/culling_work.py " + " ".join(sys.argv[1:])}
    for name, kind, extra, modes in (("spots", "city-spots", ["--lights", "165"], SPOT_MODES),
                                     ("sun", "city", [], SUN_MODES)):
        scene, cpvs = scene_and_bake(a, kind, extra)
        result[name] = {mode: {str(c): work(a, scene, cpvs, path[c], flags, "%s-%s-%d" % (name, mode.replace(" ", "_"), c))
                               for c in cameras} for mode, flags in modes.items()}
    with open(os.path.join(a.doc, "work.json"), "w") as f:
        json.dump(result, f, indent=1)
    keys = ["triangles_drawn", "fragments"]
    lines = ["# The culling demo in work units", "",
             "Generated by `benchmarks/culling_work.py`; [culling-demo.md](../culling-demo.md) explains it.", "",
             "* %s, %d² maps; commit %s; counts, so the machine does not matter (%s)" % (
                 a.size, a.map_size, result["commit"], result["machine"]["model"]),
             "* Command: `%s`" % result["command"], ""]
    lines += table("165 spot lights (city-spots, 100k triangles)", result["spots"], list(SPOT_MODES), cameras)
    lines += [""] + ["* " + s for s in ratios(result["spots"], "frustum", "voxel-grid", cameras, keys)]
    lines += ["* " + s for s in ratios(result["spots"], "frustum", "lightcluster 10 (frustum)", cameras,
                                          ["maps", "triangles_drawn", "fragments"])]
    lines += [""] + table("The sun-lit city (city, 100k triangles, one sun)", result["sun"], list(SUN_MODES), cameras)
    lines += [""] + ["* " + s for s in ratios(result["sun"], "frustum", "receiver-mask frag", cameras, keys)]
    lines += ["* " + s for s in ratios(result["sun"], "frustum", "receiver-mask bvol", cameras, keys)]
    lines += ["* " + s for s in ratios(result["sun"], "frustum", "voxel-grid", cameras, keys)]
    text = "\n".join(lines) + "\n"
    with open(os.path.join(a.doc, "work.md"), "w") as f:
        f.write(text)
    print(text)


if __name__ == "__main__":
    main()
