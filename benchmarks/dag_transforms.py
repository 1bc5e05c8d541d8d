#!/usr/bin/env python3
"""Would subtrees merged up to a shift along the light or an x/y mirror make the DAG smaller? The estimator's run
over the bakes the smaller-DAG goals name (docs/smaller-dags.md).

Bakes (skipping files already there, with the binaries in --bin): the closed city's sun at 16k and 64k (256k with
--large), the Macross diorama's sun at 16k, the 165 spots of `cpvs-scenegen city-spots` at 8k, the foliage
level's sun at 16k. Runs build/bin/dag_transform_estimate on each (every group on the files whose shifted
subtrees fit in memory; on the 256k sun and the foliage only the groups that shift nothing above leaf parents),
and writes every row, with the machine, the commit and the load average, to DOC/estimate.json; prints the table
docs/smaller-dags.md quotes.

    python3 benchmarks/dag_transforms.py [--bin build/bin] [--out out/dag-transforms] [--doc docs/smaller-dags]
                                         [--large] [--tables]
"""
import argparse
import json
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
from machine import machine_info  # noqa: E402

ALL_GROUPS = ("none,in-leaf-parents,half,by8,slices,leaf-mirrors,mirrors,in-leaf-parents+leaf-mirrors,"
              "in-leaf-parents+mirrors,half+mirrors,by8+mirrors,slices+mirrors")
# Shifts above leaf parents make new subtrees (windows over two stacked ones) that take several times the file's
# DAG in memory: on the largest bakes only the groups that make none.
SMALL_GROUPS = "none,in-leaf-parents,leaf-mirrors,mirrors,in-leaf-parents+leaf-mirrors,in-leaf-parents+mirrors"


def load():
    with open("/proc/loadavg") as f:
        return " ".join(f.read().split()[:3])


def run(cmd, **kw):
    print("$ " + " ".join(cmd), flush=True)
    return subprocess.run(cmd, check=True, stdout=subprocess.PIPE, text=True, **kw).stdout


def parse(text):
    """The estimator's rows: one dict per group."""
    rows, stored = [], None
    for line in text.splitlines():
        if ": " in line and "DAGs as stored" in line:
            stored = float(line.split("DAGs as stored")[1].split()[0])
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 12 or cells[0] in ("shift", "---") or not cells[2].isdigit():
            continue
        rows.append({"shift": cells[0], "mirrors": cells[1], "nodes": int(cells[2]), "references": int(cells[3]),
                     "leaves": int(cells[4]), "mb": float(cells[5].split()[0]),
                     "saving_percent": float(cells[6].split()[0]), "bits_mb": float(cells[7].split()[0]),
                     "bits_saving_percent": float(cells[8].split()[0]), "bound_mb": float(cells[9].split()[0]),
                     "bound_saving_percent": float(cells[10].split()[0]), "seconds": float(cells[11])})
    return stored, rows


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--bin", default=os.path.join(ROOT, "build", "bin"))
    p.add_argument("--out", default=os.path.join(ROOT, "out", "dag-transforms"))
    p.add_argument("--doc", default=os.path.join(ROOT, "docs", "smaller-dags"))
    p.add_argument("--large", action="store_true", help="also the closed city's sun at 256k (minutes, ~2 GB to bake)")
    p.add_argument("--tables", action="store_true", help="only print the tables of DOC/estimate.json")
    a = p.parse_args()
    if a.tables:
        with open(os.path.join(a.doc, "estimate.json")) as f:
            return print_tables(json.load(f))
    os.makedirs(a.out, exist_ok=True)
    os.makedirs(a.doc, exist_ok=True)
    b = lambda name: os.path.join(a.bin, name)
    o = lambda name: os.path.join(a.out, name)
    scenes = {"city.glb": ["city"], "city-spots.glb": ["city-spots", "--lights", "165"], "foliage.glb": ["foliage"]}
    for name, args in scenes.items():
        if not os.path.exists(o(name)):
            run([b("cpvs-scenegen")] + args + ["-o", o(name)])
    macross = os.path.join(ROOT, "data", "scenes", "MacrossCityDiorama", "scene.glb")
    city_sun = ["--sun", "0.4,-1,0.3"]
    cases = [("closed city's sun at 16k", "city-sun-16k.cpvs", [o("city.glb"), "-r", "16k"] + city_sun, ALL_GROUPS),
             ("closed city's sun at 64k", "city-sun-64k.cpvs", [o("city.glb"), "-r", "64k"] + city_sun, ALL_GROUPS),
             ("Macross diorama's sun at 16k", "macross-sun-16k.cpvs", [macross, "-r", "16k", "--sun", "0.3,-1,0.2"],
              ALL_GROUPS),
             ("165 spots at 8k", "spots-8k.cpvs", [o("city-spots.glb"), "-r", "8k"], ALL_GROUPS),
             ("foliage level's sun at 16k", "foliage-sun-16k.cpvs", [o("foliage.glb"), "-r", "16k", "--lights", "sun"],
              SMALL_GROUPS)]
    if a.large:
        cases.insert(2, ("closed city's sun at 256k", "city-sun-256k.cpvs", [o("city.glb"), "-r", "256k"] + city_sun,
                         SMALL_GROUPS))
    for _, name, args, _ in cases:
        if not os.path.exists(o(name)):
            run([b("cpvs-bake")] + args + ["-o", o(name), "-q"])
    commit = run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"]).strip()
    dirty = run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no"]).strip()
    result = {"machine": machine_info(), "commit": commit + ("-dirty" if dirty else ""),
              "date": time.strftime("%Y-%m-%d"), "command": " ".join(sys.argv), "cases": []}
    for title, name, args, groups in cases:
        before = load()
        text = run([b("dag_transform_estimate"), "--groups", groups, o(name)])
        print(text, flush=True)
        stored, rows = parse(text)
        result["cases"].append({"case": title, "file": name, "bake": ["cpvs-bake"] + args[1:], "stored_mb": stored,
                                "groups": groups, "rows": rows, "load_before": before, "load_after": load()})
    with open(os.path.join(a.doc, "estimate.json"), "w") as f:
        json.dump(result, f, indent=1)
        f.write("\n")
    print_tables(result)


def print_tables(result):
    """The tables docs/smaller-dags.md quotes: the base sizes per case, then every group's savings per case."""
    cases = result["cases"]
    print("| | " + " | ".join(c["case"] for c in cases) + " |\n|---|" + "---|" * len(cases))
    print("| 2.0 as stored | " + " | ".join("%.2f MB" % c["stored_mb"] for c in cases) + " |")
    base = [c["rows"][0] for c in cases]
    print("| 3.0 widths / bit widths / order-0 bound, no transform | " +
          " | ".join("%.2f / %.2f / %.2f MB" % (r["mb"], r.get("bits_mb", float("nan")), r["bound_mb"]) for r in base) +
          " |")
    groups = []
    for c in cases:
        for r in c["rows"][1:]:
            if (r["shift"], r["mirrors"]) not in groups:
                groups.append((r["shift"], r["mirrors"]))
    print("\nSavings against no transform, in 3.0 widths / bit widths / the order-0 bound (— not run: its shifted "
          "subtrees do not fit in memory):\n")
    print("| shift | mirrors | " + " | ".join(c["case"] for c in cases) + " |\n|---|---|" + "---|" * len(cases))
    for shift, mirrors in groups:
        cells = []
        for c in cases:
            row = next((r for r in c["rows"] if (r["shift"], r["mirrors"]) == (shift, mirrors)), None)
            cells.append("—" if row is None else "%.1f / %.1f / %.1f %%" % (
                row["saving_percent"], row.get("bits_saving_percent", float("nan")), row["bound_saving_percent"]))
        print("| %s | %s | %s |" % (shift, mirrors, " | ".join(cells)))

if __name__ == "__main__":
    main()
