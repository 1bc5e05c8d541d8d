#!/usr/bin/env python3
"""The culling papers' claims checked in work units, not llvmpipe milliseconds: per shadow mode of cpvs-view,
the triangles drawn into the maps, the fragments that passed the depth test while drawing them (GL occlusion
queries), the maps drawn, the texels cleared, draw calls, compute dispatches and BVH nodes visited (ManyPSMs),
and the bytes the lookups read (map texels; CPVS's DAG node units and leaves), with each mode's error against
one Embree ray per (pixel, light) pair. These counts do not depend on the machine, so each mode runs once per
camera.

    python3 benchmarks/culling_work.py [--bin build/bin] [--out out/culling-work] [--doc docs/culling-demo]
                                       [--size 1920x1080] [--map-size 512] [--cameras 0,7]
                                       [--only spots,sun,points,spots-tiled,sun-tiled]
                                       [--reuse]

Scenes: the generated city with 165 spot lights (cpvs-scenegen city-spots), the sun-lit city (cpvs-scenegen
city) and the city with 120 point lights (--point-lights: 720 views, the ManyPSMs post's scene size), then the
spot and sun cities again with the ground slab in 32 x 32 tiles (--ground-tiles 32: the settings where the
culling claims do show), each baked at 1k only for its lights (the map modes draw from the scene). Cameras: benchmarks/viewer.py's
flythrough (0: the overview; 7: street level). Claims (docs/culling-demo.md): voxel-grid culling draws
1.5-8.6x fewer than frustum culling (Selgrad et al. 2016); receiver masks 3-10x fewer for a sun (Bittner et al.
2011); LightCluster with 10 clusters about 4.8x fewer map fragments than a map per light (Wiesenhuetter et al.);
ManyPSMs draws all maps with a few dispatches and two draws. Writes DOC/work.json and DOC/work.md. Python 3
standard library only."""

import argparse
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info  # noqa: E402
from viewer import flythrough  # noqa: E402

CPVS = {"CPVS (GPU walk)": ["--shadows", "gpu"]}
MANYPSM = {
    "manypsm 16-512": ["--shadows", "manypsm"],
    "manypsm 16-256 (the post's)": ["--shadows", "manypsm", "--shadow-map-size", "256"],
}
SPOT_MODES = {
    "none": ["--shadows", "shadowmap", "--caster-culling", "none"],
    "frustum": ["--shadows", "shadowmap", "--caster-culling", "frustum"],
    "voxel-grid": ["--shadows", "shadowmap", "--caster-culling", "voxel-grid"],
    "receiver-mask frag": ["--shadows", "shadowmap", "--caster-culling", "receiver-mask", "--mask-variant", "frag"],
    "receiver-mask bvol": ["--shadows", "shadowmap", "--caster-culling", "receiver-mask", "--mask-variant", "bvol"],
    "lightcluster 10 (frustum)": ["--shadows", "lightcluster", "--clusters", "10", "--caster-culling", "frustum"],
}
SPOT_MODES.update(MANYPSM)
SPOT_MODES.update(CPVS)
SUN_MODES = {k: v for k, v in SPOT_MODES.items() if not k.startswith("lightcluster")}
TILED_MODES = {k: v for k, v in SPOT_MODES.items()
               if k in ("frustum", "voxel-grid", "receiver-mask frag", "receiver-mask bvol", "lightcluster 10 (frustum)")}
POINT_MODES = {k: v for k, v in SPOT_MODES.items() if k in ("frustum", "lightcluster 10 (frustum)") or k in MANYPSM or k in CPVS}
COUNTS = ("maps", "triangles_drawn", "fragments", "texels_cleared", "draw_calls", "dispatches", "nodes_visited", "points",
          "atlas_layers", "gpu_bytes")


# name -> (file stem, cpvs-scenegen arguments, modes). The tiled scenes are the same cities with the ground
# slab cut into 32 x 32 tiles of 32.5 units (the voxel grid's cell): a single slab is drawn whole into every map
# whatever the culling, which is what the papers' scenes did not have.
SCENES = {
    "spots": ("city-spots", ["--lights", "165"], SPOT_MODES),
    "sun": ("city", [], SUN_MODES),
    "points": ("city-points", ["--lights", "120", "--point-lights"], POINT_MODES),
    "spots-tiled": ("city-spots-tiled", ["--lights", "165", "--ground-tiles", "TILES"], TILED_MODES),
    "sun-tiled": ("city-tiled", ["--ground-tiles", "TILES"], {k: v for k, v in TILED_MODES.items() if "cluster" not in k}),
}


def complete(report):
    """Whether a report from an earlier run of this benchmark holds everything it reads (--reuse)."""
    try:
        with open(report) as f:
            frame = json.load(f)["frames"][0]
        return "against_rays" in frame and "lookup_bytes" in frame
    except (OSError, ValueError, KeyError, IndexError):
        return False


def work(a, scene, cpvs, camera, flags, tag):
    path = os.path.join(a.out, tag + "-camera.json")
    with open(path, "w") as f:
        json.dump([camera], f)
    report = os.path.join(a.out, tag + ".json")
    size = [] if "--shadow-map-size" in flags else ["--shadow-map-size", str(a.map_size)]
    cmd = [os.path.join(a.bin, "cpvs-view"), scene, cpvs, "--path", path, "--frames", os.path.join(a.out, "frames"),
           "--size", a.size, "--report", report, "-q", "--compare"] + size + flags
    if not (a.reuse and complete(report)):
        print("$ " + " ".join(cmd), flush=True)
        subprocess.run(cmd, check=True)
    with open(report) as f:
        report = json.load(f)
    frame = report["frames"][0]
    sm = frame.get("shadow_maps", {})
    out = {k: sm.get(k, 0) for k in COUNTS}
    if "shadow_maps" not in frame:  # CPVS: its data in GPU memory instead of the maps
        out["gpu_bytes"] = frame.get("cpvs_gpu_bytes", 0)
    out["atlas_levels"] = sm.get("atlas_levels")
    out["lookup_bytes"] = frame.get("lookup_bytes") or 0
    out["pairs"] = frame["light_lists"]["pairs_listed"]
    rays = frame["against_rays"]
    out["wrong_pixels_percent"] = rays["wrong_pixels_percent"]
    out["mean_abs_visibility_difference"] = rays["mean_abs_visibility_difference"]
    out["ms"] = frame["passes_ms"]
    return out


def scene_and_bake(a, kind, extra):
    if "--ground-tiles" in extra:
        kind += "-%s" % extra[extra.index("--ground-tiles") + 1]
    scene = os.path.join(a.out, kind + ".glb")
    generator_kind = "city-spots" if kind.startswith("city-spots") or kind == "city-points" else "city"
    subprocess.run([os.path.join(a.bin, "cpvs-scenegen"), generator_kind, "-o", scene] + extra, check=True)
    cpvs = os.path.join(a.out, kind + "-1k.cpvs")
    if not os.path.exists(cpvs):
        subprocess.run([os.path.join(a.bin, "cpvs-bake"), scene, "-r", "1k", "-o", cpvs, "-q"], check=True)
    return scene, cpvs


def mb(n):
    return "%.1f" % (n / 1e6)


def table(title, rows, modes, cameras):
    lines = ["### " + title, "",
             "| mode | camera | maps | triangles drawn | fragments | texels cleared | draw calls | dispatches | "
             "nodes visited | points | map bytes written (MB) | lookup bytes read (MB) | wrong pixels | mean abs. diff. |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for mode in modes:
        for c in cameras:
            r = rows[mode][str(c)]
            written = 4 * (r["fragments"] + r["texels_cleared"])  # 32-bit depth: every cleared texel and passed fragment
            lines.append("| %s | %d | %d | %s | %s | %s | %d | %d | %s | %s | %s | %s | %.2f %% | %.4f |" % (
                mode, c, r["maps"], format(r["triangles_drawn"], ","), format(r["fragments"], ","),
                format(r["texels_cleared"], ","), r["draw_calls"], r["dispatches"], format(r["nodes_visited"], ","),
                format(r["points"], ","), mb(written), mb(r["lookup_bytes"]), r["wrong_pixels_percent"],
                r["mean_abs_visibility_difference"]))
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
    ap.add_argument("--only", default=",".join(SCENES))
    ap.add_argument("--ground-tiles", type=int, default=32, help="the tiled scenes' tiles per side")
    ap.add_argument("--reuse", action="store_true", help="keep the reports already in --out of an interrupted run")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    os.makedirs(a.doc, exist_ok=True)
    cameras = [int(c) for c in a.cameras.split(",")]
    path = flythrough(8)
    result = {"machine": machine_info(), "size": a.size, "map_size": a.map_size, "cameras": cameras,
              "ground_tiles": a.ground_tiles,
              "commit": subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                                       text=True).stdout.strip(),
              "command": "python3 benchmarks/culling_work.py " + " ".join(sys.argv[1:])}
    only = a.only.split(",")
    for name, (kind, extra, modes) in SCENES.items():
        if name not in only:
            continue
        scene, cpvs = scene_and_bake(a, kind, [str(a.ground_tiles) if x == "TILES" else x for x in extra])
        stem = name + ("%d" % a.ground_tiles if name.endswith("tiled") else "")
        result[name] = {mode: {str(c): work(a, scene, cpvs, path[c], flags, "%s-%s-%d" % (stem, mode.replace(" ", "_"), c))
                               for c in cameras} for mode, flags in modes.items()}
    # A partial run (--only) keeps the other scenes' figures from the last full one.
    previous = os.path.join(a.doc, "work.json")
    if len(only) < len(SCENES) and os.path.exists(previous):
        with open(previous) as f:
            old = json.load(f)
        for name in SCENES:
            if name not in result and name in old:
                result[name] = old[name]
    with open(previous, "w") as f:
        json.dump(result, f, indent=1)
    keys = ["triangles_drawn", "fragments"]
    lines = ["# The culling demo in work units", "",
             "Generated by `benchmarks/culling_work.py`; [culling-demo.md](../culling-demo.md) explains it.", "",
             "* %s, %d² maps (ManyPSMs: the largest), 9×9 PCF; commit %s; counts, so the machine does not matter "
             "(%s); errors against one Embree ray per (pixel, light) pair" % (
                 a.size, a.map_size, result["commit"], result["machine"]["model"]),
             "* Command: `%s`" % result["command"],
             "* Map bytes written: 4 per texel cleared and per fragment that passed the depth test (32-bit depth); "
             "lookup bytes read: 4 per map texel a lookup read, or CPVS's DAG node units (2 bytes) and leaves (8 bytes)",
             ""]

    def claims(name, pairs):
        out = []
        for slow, fast, k in pairs:
            if slow in result[name] and fast in result[name]:
                out += ["* " + s for s in ratios(result[name], slow, fast, cameras, k)]
        return out

    def levels(name):
        out = []
        for mode in result[name]:
            for c in cameras:
                lv = result[name][mode][str(c)].get("atlas_levels")
                if lv:
                    out.append("* %s, camera %d: %s in %d layers" % (mode, c, ", ".join(
                        "%d maps of %d²" % (x["maps"], x["resolution"]) for x in lv),
                        result[name][mode][str(c)]["atlas_layers"]))
        return out

    if "spots" in result:
        modes = list(result["spots"])
        lines += table("165 spot lights (city-spots, 100k triangles)", result["spots"], modes, cameras)
        lines += [""] + claims("spots", [("frustum", "voxel-grid", keys),
                                         ("frustum", "lightcluster 10 (frustum)", ["maps", "triangles_drawn", "fragments"]),
                                         ("frustum", "manypsm 16-512", ["texels_cleared", "fragments", "draw_calls"]),
                                         ("frustum", "manypsm 16-256 (the post's)", ["texels_cleared", "fragments", "draw_calls"]),
                                         ("frustum", "CPVS (GPU walk)", ["lookup_bytes"])])
        lines += levels("spots")
    if "sun" in result:
        lines += [""] + table("The sun-lit city (city, 100k triangles, one sun)", result["sun"], list(result["sun"]), cameras)
        lines += [""] + claims("sun", [("frustum", "receiver-mask frag", keys), ("frustum", "receiver-mask bvol", keys),
                                       ("frustum", "voxel-grid", keys), ("frustum", "CPVS (GPU walk)", ["lookup_bytes"])])
    if "spots-tiled" in result:
        lines += [""] + table("165 spot lights, the ground in %d × %d tiles (city-spots --ground-tiles %d)" % ((a.ground_tiles,) * 3),
                              result["spots-tiled"], list(result["spots-tiled"]), cameras)
        lines += [""] + claims("spots-tiled", [("frustum", "voxel-grid", keys),
                                               ("frustum", "lightcluster 10 (frustum)", ["maps", "triangles_drawn", "fragments"])])
    if "sun-tiled" in result:
        lines += [""] + table("The sun-lit city, the ground in %d × %d tiles (city --ground-tiles %d)" % ((a.ground_tiles,) * 3),
                              result["sun-tiled"],
                              list(result["sun-tiled"]), cameras)
        lines += [""] + claims("sun-tiled", [("frustum", "receiver-mask frag", keys), ("frustum", "receiver-mask bvol", keys),
                                             ("frustum", "voxel-grid", keys)])
    if "points" in result:
        lines += [""] + table("120 point lights, 720 views (city-spots --point-lights, 100k triangles)", result["points"],
                              list(result["points"]), cameras)
        lines += [""] + claims("points", [("frustum", "lightcluster 10 (frustum)", ["maps", "triangles_drawn", "fragments"]),
                                          ("frustum", "manypsm 16-512", ["texels_cleared", "fragments", "draw_calls"]),
                                          ("frustum", "manypsm 16-256 (the post's)", ["texels_cleared", "fragments", "draw_calls"]),
                                          ("frustum", "CPVS (GPU walk)", ["lookup_bytes"])])
        lines += levels("points")
    text = "\n".join(lines) + "\n"
    with open(os.path.join(a.doc, "work.md"), "w") as f:
        f.write(text)
    print(text)


if __name__ == "__main__":
    main()
