#!/usr/bin/env python3
"""The runtime's lookups on ARM64, as work: instructions per lookup of the NEON path against the scalar one,
counted under qemu-user (whose time means nothing) by an instruction-counting plugin.

Cross-compiles benchmarks/lookup_work.cpp with the runtime's files (as tests/runtime_cross_test.sh does, with
aarch64-linux-gnu-g++ -O2, -ffp-contract=off) and benchmarks/qemu_instruction_count.c for the host, bakes each
case with this build's tools, samples surface points with cpvs-sample, then for each case, kernel (K = 1, 9)
and path (CPVS_LOOKUP_ISA=scalar, neon) runs lookup_work under qemu-aarch64 twice, with --repeat 1 and 3:
the difference in guest instructions over the lookups it adds is the work per lookup, opening and reading
excluded; the plugin's count per function splits off the batch mapping's part (the functions of
batch_cells*.cpp). The answers' checksum of every ARM64 run must equal the native build's (exit 2 otherwise).

    python3 benchmarks/arm64_lookup_work.py [--bin build/bin] [--out out/arm64-work]
                                            [--doc docs/runtime/arm64-work.json] [--points 4000]

Python 3 standard library only. Exit status: 0 done, 1 usage or missing tools, 2 a run failed or differs.
"""

import argparse
import json
import os
import re
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TK = os.path.join(ROOT, "data", "scenes", "TorusKnot", "torusknot.gltf")
# (name, scene or scenegen level, bake arguments, points per light): the lookup benchmark's kinds of file.
CASES = [
    ("torusknot-4k", TK, ["-r", "4k", "--sun", "0.3,-1,0.2", "--spot", "10,60,-30,-0.15,-0.85,0.5,0.6,200"], 20000),
    ("city-sun-16k", "city", ["-r", "16k", "--sun", "0.4,-1,0.3"], 20000),
    ("spots165-8k", "city-spots", ["-r", "8k"], 2000),
]


def run(cmd, env=None, stdin=None):
    r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, env=env, stdin=stdin)
    if r.returncode != 0:
        sys.stderr.write("arm64_lookup_work.py: failed (%d): %s\n%s" % (r.returncode, " ".join(cmd), r.stderr))
        sys.exit(2)
    return r.stdout


def build(out):
    """The ARM64 lookup_work and the host plugin; their paths."""
    cxx, qemu = shutil.which("aarch64-linux-gnu-g++"), shutil.which("qemu-aarch64")
    if not cxx or not qemu:
        sys.stderr.write("arm64_lookup_work.py: needs aarch64-linux-gnu-g++ and qemu-aarch64 "
                         "(scripts/install-deps.sh installs them)\n")
        sys.exit(1)
    include = os.path.join(out, "include")
    os.makedirs(include, exist_ok=True)
    for name, target in (("glm", "/usr/include/glm"), ("xxhash.h", "/usr/include/xxhash.h")):
        if not os.path.exists(os.path.join(include, name)):
            os.symlink(target, os.path.join(include, name))
    with open(os.path.join(ROOT, "libcpvs", "runtime", "runtime_sources.cmake")) as f:
        names = re.search(r"set\(_cpvs_runtime_files([^)]*)\)", f.read()).group(1).split()
    sources = [os.path.join(ROOT, "libcpvs", "runtime", n + ".cpp") for n in names]
    program = os.path.join(out, "lookup_work-arm64")
    run([cxx, "-std=c++20", "-O2", "-Wall", "-Wextra", "-Werror", "-ffp-contract=off", "-fno-math-errno",
         "-DXXH_INLINE_ALL", "-I" + ROOT, "-isystem", include, "-static", "-o", program,
         os.path.join(ROOT, "benchmarks", "lookup_work.cpp")] + sources)
    plugin = os.path.join(out, "qemu_instruction_count.so")
    run(["cc", "-shared", "-fPIC", "-O2", "-o", plugin, os.path.join(ROOT, "benchmarks", "qemu_instruction_count.c")])
    return qemu, program, plugin, cxx


# The batch mapping's functions (batch_cells*.cpp: the lane loops and what they call); the rest of a lookup is
# the view selection, the walks and the answers.
MAPPING = re.compile(r"mapCells|mappingLog|laneLog|NeonLanes|ScalarLanes")


def counted(qemu, plugin, program, args, isa, out):
    """(guest instructions, of them in the batch mapping, lookup_work's JSON) of one run under qemu."""
    count_file = out + ".count"
    env = dict(os.environ, CPVS_LOOKUP_ISA=isa)
    report = json.loads(run([qemu, "-plugin", plugin + ",out=" + count_file + ",functions=on", program] + args,
                            env=env))
    with open(count_file) as f:
        lines = f.read().split("\n")
    mapping = sum(int(line.split(" ", 1)[0]) for line in lines[1:] if line and MAPPING.search(line))
    return int(lines[0]), mapping, report


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--bin", default=os.path.join(ROOT, "build", "bin"), help="this build's tools (native)")
    p.add_argument("--out", default=os.path.join(ROOT, "out", "arm64-work"))
    p.add_argument("--doc", default=os.path.join(ROOT, "docs", "runtime", "arm64-work.json"))
    p.add_argument("--points", type=int, default=0, help="points per case (default: each case's own)")
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)
    qemu, program, plugin, cxx = build(a.out)
    commit = run(["git", "rev-parse", "--short", "HEAD"]).strip()
    dirty = run(["git", "status", "--porcelain", "--untracked-files=no"]).strip()
    rows = []
    for name, scene, bake, count in CASES:
        scene_file = scene
        if not os.path.isfile(scene):
            scene_file = os.path.join(a.out, name + ".glb")
            run([os.path.join(a.bin, "cpvs-scenegen"), scene, "-o", scene_file] +
                (["--lights", "165"] if scene == "city-spots" else []))
        cpvs = os.path.join(a.out, name + ".cpvs")
        if not os.path.isfile(cpvs):
            run([os.path.join(a.bin, "cpvs-bake"), scene_file, "-o", cpvs, "--quiet"] + bake)
        points = os.path.join(a.out, name + "-points.csv")
        run([os.path.join(a.bin, "cpvs-sample"), scene_file, "-o", points, "--count", str(a.points or count)])
        for k in (1, 9):
            args = [cpvs, points, "--pcf", str(k)]
            native = json.loads(run([os.path.join(a.bin, "lookup_work")] + args))
            row = {"case": name, "pcf": k, "lights": native["lights"], "points": native["points"],
                   "native_checksum": native["checksum"], "native_isa": native["isa"]}
            for isa in ("scalar", "neon"):
                once, map1, r1 = counted(qemu, plugin, program, args + ["--repeat", "1"], isa,
                                         os.path.join(a.out, "run"))
                thrice, map3, r3 = counted(qemu, plugin, program, args + ["--repeat", "3"], isa,
                                           os.path.join(a.out, "run"))
                if r1["isa"] != isa or r1["checksum"] != native["checksum"] or r3["lookups"] != 3 * r1["lookups"]:
                    sys.stderr.write("arm64_lookup_work.py: %s K=%d %s: ISA %s, checksum %s against the native %s\n"
                                     % (name, k, isa, r1["isa"], r1["checksum"], native["checksum"]))
                    sys.exit(2)
                row[isa + "_instructions_per_lookup"] = (thrice - once) / (2 * r1["lookups"])
                row[isa + "_mapping_instructions_per_lookup"] = (map3 - map1) / (2 * r1["lookups"])
                row[isa + "_instructions_total_repeat1"] = once
            row["neon_over_scalar"] = row["neon_instructions_per_lookup"] / row["scalar_instructions_per_lookup"]
            rows.append(row)
            print("%-14s K=%d  %d lights x %d points  instructions per lookup: scalar %.1f (mapping %.1f), "
                  "neon %.1f (mapping %.1f): %.2fx" %
                  (name, k, row["lights"], row["points"], row["scalar_instructions_per_lookup"],
                   row["scalar_mapping_instructions_per_lookup"], row["neon_instructions_per_lookup"],
                   row["neon_mapping_instructions_per_lookup"], 1 / row["neon_over_scalar"]), flush=True)
    doc = {"what": "instructions per lookup under qemu-aarch64 (guest instructions, counted by "
                   "benchmarks/qemu_instruction_count.c), (repeat 3 - repeat 1) / (2 x lookups)",
           "command": "python3 benchmarks/arm64_lookup_work.py" + (" --points %d" % a.points if a.points else ""),
           "commit": commit + ("-dirty" if dirty else ""),
           "cross_compiler": run([cxx, "--version"]).splitlines()[0],
           "emulator": run([qemu, "--version"]).splitlines()[0],
           "host": machine_info(), "rows": rows}
    os.makedirs(os.path.dirname(a.doc), exist_ok=True)
    with open(a.doc, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    print("wrote %s" % a.doc)


if __name__ == "__main__":
    main()
