#!/usr/bin/env python3
"""Uniform tiles against the per-texel path: the closed city's sun at growing resolutions, both ways, alternating.

    python3 benchmarks/uniform_tiles.py [--bin build/bin] [--out out/uniform-tiles] [--json docs/depth-maps/uniform-tiles.json]
                                        [--resolutions 1k,4k,16k,32k,64k] [--per-texel-up-to 64k] [--rounds 2]
                                        [--scene SPEC] [--light ARGS] [--threads 2] [--versus per-texel|scalar|avx2]

For each resolution and round, `cpvs-bake` bakes the scene (default `cpvs-scenegen city --triangles 100000`, lit
by `--sun 0.4,-1,0.3`) with uniform tiles and then with `--per-texel` (the reference path; only up to
--per-texel-up-to, as it grows x4 per doubling), one after the other, and checks that both files are identical.
Wall time, CPU time (user + system) and peak RSS come from the operating system (wait4); the phases, the tiles
taken by each path and the bytes from the bake's report. The load average is read before and after every run.
`--versus scalar` (or `avx2`) replaces the per-texel arm by the same bake on the rasteriser's baseline (or AVX2)
copy, CPVS_RASTER_ISA=scalar (avx2), to measure the widest copy the CPU runs; the files must be identical too.
(`--versus avx2` measured an AVX-512 copy of the rasteriser, which gained nothing and was not kept.)
Prints a markdown table (the best round of each) and writes every run to --json. Python 3 standard library only.
"""

import argparse
import filecmp
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bake_scale import measured  # noqa: E402
from machine import machine_info  # noqa: E402


def parse_resolution(text):
    text = text.strip().lower()
    return int(text[:-1]) * 1024 if text.endswith("k") else int(text)


def load_average():
    with open("/proc/loadavg") as f:
        return float(f.read().split()[0])


def bake(a, scene, resolution, out, per_texel):
    report = out + ".json"
    versus_scalar = per_texel and a.versus != "per-texel"  # an instruction set instead of the per-texel path
    cmd = [os.path.join(a.bin, "cpvs-bake"), scene, "-r", resolution, "-j", str(a.threads), "-o", out + ".cpvs",
           "--report", report, "-q"] + a.light.split() + (["--per-texel"] if per_texel and not versus_scalar else [])
    load_before = load_average()
    if versus_scalar:  # the same bake on a narrower copy of the rasteriser than the widest the CPU runs
        os.environ["CPVS_RASTER_ISA"] = a.versus
    try:
        run = measured(cmd)
    finally:
        os.environ.pop("CPVS_RASTER_ISA", None)
    with open(report) as f:
        r = json.load(f)
    phases = {}
    tiles = uniform = summarized = 0
    for light in r["lights"]:
        for v in light["views"]:
            for k, ms in v["phases_ms"].items():
                phases[k] = phases.get(k, 0.0) + ms / 1000.0
            tiles += v.get("tiles", 0)
            uniform += v.get("uniform_tiles", 0)
            summarized += v.get("summarized_tiles", 0)
    run.update({"command": ("CPVS_RASTER_ISA=%s " % a.versus if versus_scalar else "") + " ".join(cmd), "resolution": resolution, "per_texel": per_texel,
                "file_bytes": r["file_bytes"], "phases_s": phases, "tiles": tiles, "uniform_tiles": uniform,
                "summarized_tiles": summarized, "load_before": load_before, "load_after": load_average(),
                "file": out + ".cpvs"})
    return run


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--bin", default="build/bin")
    p.add_argument("--out", default="out/uniform-tiles")
    p.add_argument("--json", default="")
    p.add_argument("--resolutions", default="1k,4k,16k,32k,64k")
    p.add_argument("--per-texel-up-to", default="64k")
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--scene", default="city --triangles 100000",
                   help="cpvs-scenegen arguments, or the path of a scene file")
    p.add_argument("--light", default="--sun 0.4,-1,0.3", help="cpvs-bake's light arguments")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--versus", choices=["per-texel", "scalar", "avx2"], default="per-texel",
                   help="the other arm: the per-texel path, or the same bake on a narrower copy of the rasteriser "
                        "(CPVS_RASTER_ISA=scalar: the baseline build; avx2: no wider, for a build with wider copies)")
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)
    if os.path.exists(a.scene):
        scene = a.scene
    else:
        scene = os.path.join(a.out, "scene-" + "-".join(a.scene.split()).replace("--", "") + ".glb")
        if not os.path.exists(scene):
            subprocess.run([os.path.join(a.bin, "cpvs-scenegen")] + a.scene.split() + ["-o", scene], check=True)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    runs = []
    limit = parse_resolution(a.per_texel_up_to)
    for resolution in a.resolutions.split(","):
        for round_ in range(a.rounds):
            fast = bake(a, scene, resolution, os.path.join(a.out, "fast-%s" % resolution), False)
            runs.append(fast)
            if parse_resolution(resolution) <= limit:
                slow = bake(a, scene, resolution, os.path.join(a.out, "texels-%s" % resolution), True)
                slow["same_bytes"] = filecmp.cmp(fast["file"], slow["file"], shallow=False)
                if not slow["same_bytes"]:
                    sys.exit("different bytes at %s: %s and %s" % (resolution, fast["file"], slow["file"]))
                runs.append(slow)
    info = machine_info("cpvs CPU rasteriser")
    result = {"machine": info, "commit": commit, "scene": a.scene, "light": a.light, "threads": a.threads,
              "versus": a.versus, "runs": runs}
    if a.json:
        os.makedirs(os.path.dirname(a.json) or ".", exist_ok=True)
        with open(a.json, "w") as f:
            json.dump(result, f, indent=1)

    def best(resolution, per_texel):
        rs = [r for r in runs if r["resolution"] == resolution and r["per_texel"] == per_texel]
        return min(rs, key=lambda r: r["cpu_s"]) if rs else None

    print("\n%s, %d CPUs, commit %s, `%s`, `%s`, -j %d, best of %d rounds, alternating\n" %
          (info["model"], info["cpus"], commit, a.scene, a.light, a.threads, a.rounds))
    print("| N | uniform tiles | summarised | %s CPU-s / wall | uniform CPU-s / wall | CPU ratio | " % a.versus +
          "phases (uniform): depth / peel / masks / dag s | peak RSS | bytes | load |")
    print("|---|---:|---:|---:|---:|---:|---|---:|---:|---|")
    previous = None
    for resolution in a.resolutions.split(","):
        f, s = best(resolution, False), best(resolution, True)
        ph = f["phases_s"]
        growth = " (x%.2f)" % (f["cpu_s"] / previous) if previous else ""
        previous = f["cpu_s"]
        loads = [r["load_before"] for r in runs if r["resolution"] == resolution] + \
                [r["load_after"] for r in runs if r["resolution"] == resolution]
        print("| %s | %.1f %% | %.1f %% | %s | %.1f / %.1f%s | %s | %.1f / %.1f / %.1f / %.1f | %.0f MB | %.2f MB | %.2f-%.2f |" % (
            resolution, 100.0 * f["uniform_tiles"] / max(1, f["tiles"]),
            100.0 * f["summarized_tiles"] / max(1, f["tiles"]),
            "%.1f / %.1f" % (s["cpu_s"], s["wall_s"]) if s else "-", f["cpu_s"], f["wall_s"], growth,
            "%.2fx" % (s["cpu_s"] / f["cpu_s"]) if s else "-", ph.get("depth", 0), ph.get("peel", 0),
            ph.get("masks", 0), ph.get("dag", 0), f["peak_rss_bytes"] / 1e6, f["file_bytes"] / 1e6,
            min(loads), max(loads)))


if __name__ == "__main__":
    main()
