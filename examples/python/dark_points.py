#!/usr/bin/env python3
"""A level-build step in Python: bake a level's lights, sample its surfaces, find the points every light leaves
dark, and write them for the level designer (a CSV with the nearest light's name, and a PLY point cloud to load
beside the level in a DCC). The bake's own error against Embree ray tracing is printed beside it, so the step
can refuse a bake that is not good enough.

    PYTHONPATH=build/python python3 examples/python/dark_points.py [--scene LEVEL.glb] [--out DIR] [--quick]

Without --scene it bakes the bundled demo scene (data/scenes/SubpassSceneOpaque) with a sun and a spot light, as
scripts/demo.sh does. docs/python.md walks through it."""

import argparse
import os
import sys

import numpy as np

import cpvs

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
DEMO = os.path.join(ROOT, "data", "scenes", "SubpassSceneOpaque", "subpass_scene_opaque.gltf")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default=DEMO)
    p.add_argument("--out", default=os.path.join(ROOT, "out", "dark-points"))
    p.add_argument("--quick", action="store_true", help="a 1k bake and 20,000 points (the test's run)")
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)
    lights = {} if a.scene != DEMO else {"sun": "0.35,1,0.25", "spot": "9,-6,9,-5,6.5,-5,0.7,30,40"}

    # 1. Bake, with a cache so that the next run after an edit re-bakes only what the edit reaches.
    shadows = os.path.join(a.out, "level.cpvs")
    last = [-1.0]

    def progress(fraction):
        if fraction - last[0] >= 0.25 or fraction == 1.0:
            print(f"baking: {100 * fraction:.0f} %", flush=True)
            last[0] = fraction

    report = cpvs.bake(a.scene, shadows, resolution="1k" if a.quick else "4k", cache=os.path.join(a.out, "cache"),
                       progress=progress, **lights)
    print(f"baked {len(report['lights'])} light(s) in {report['total_ms'] / 1000:.2f} s -> {shadows}")

    # 2. Sample the surfaces and look every light up at once: one column per light.
    points, normals = cpvs.sample(a.scene, 20000 if a.quick else 200000, seed=1)
    f = cpvs.open(shadows)
    names = [light["name"] for light in f.lights]
    lit = f.lookup(points, normals, light=list(range(len(names))), pcf=3)  # float32 (n, lights)

    # 3. How far to trust it: the unfiltered answers against ray tracing, per light.
    ref = cpvs.reference(a.scene)
    for light in f.lights:
        baked = f.lookup(points, normals, light=light["index"])
        traced = ref.lookup(points, normals, light=light)
        print(f"light '{light['name']}': {100 * np.mean(baked != traced):.2f} % of points differ from Embree rays")

    # 4. The points every light leaves dark, with the light that comes nearest to reaching them.
    dark = np.all(lit == 0.0, axis=1)
    print(f"{np.count_nonzero(dark)} of {len(points)} sampled points ({100 * np.mean(dark):.1f} %) are dark to "
          f"every light")
    nearest = [names[int(np.argmin(np.linalg.norm(points[i] - light_position(f.lights), axis=1)))]
               for i in np.flatnonzero(dark)]
    with open(os.path.join(a.out, "dark_points.csv"), "w") as out:
        out.write("x,y,z,nx,ny,nz,nearest_light\n")
        for (x, y, z), (nx, ny, nz), name in zip(points[dark], normals[dark], nearest):
            out.write(f"{x:.6f},{y:.6f},{z:.6f},{nx:.4f},{ny:.4f},{nz:.4f},{name}\n")
    write_ply(os.path.join(a.out, "dark_points.ply"), points[dark])
    print(f"wrote {os.path.join(a.out, 'dark_points.csv')} and dark_points.ply")
    if not 0 < np.count_nonzero(dark) < len(points):
        sys.exit("expected some points, not all, to be dark")


def light_position(lights):
    """Where each light is (a sun: far along its reversed direction), to tell the designer which one to move."""
    positions = []
    for light in lights:
        if light["position"] is not None:
            positions.append(light["position"])
        else:
            positions.append(tuple(-1e6 * np.asarray(light["direction"])))
    return np.asarray(positions)


def write_ply(path, points):
    with open(path, "w") as out:
        out.write(f"ply\nformat ascii 1.0\nelement vertex {len(points)}\n")
        out.write("property float x\nproperty float y\nproperty float z\nend_header\n")
        for x, y, z in points:
            out.write(f"{x:.6f} {y:.6f} {z:.6f}\n")


if __name__ == "__main__":
    main()
