#!/usr/bin/env python3
"""Includes run one way, down the pipeline: every #include "..." of a library folder must name a folder that
its CMake target links (libcpvs/CMakeLists.txt, docs/architecture.md). Exit 1 and one line per wrong-way
include, else a summary line. Usage: layering_check.py SOURCE_DIR"""
import os
import re
import sys

RUNTIME = {"libcpvs/runtime", "formats/cpvs"}
BELOW = {
    "libcpvs/runtime": RUNTIME,
    "formats/cpvs": RUNTIME,
    "libcpvs/base": RUNTIME | {"libcpvs/base"},
}
BELOW["libcpvs/scene"] = BELOW["libcpvs/base"] | {"libcpvs/scene"}
BELOW["libcpvs/views"] = BELOW["libcpvs/scene"] | {"libcpvs/views"}
BELOW["libcpvs/gl"] = BELOW["libcpvs/base"] | {"libcpvs/gl"}
BELOW["libcpvs/raster"] = BELOW["libcpvs/views"] | BELOW["libcpvs/gl"] | {"libcpvs/raster"}
BELOW["libcpvs/tiles"] = BELOW["libcpvs/raster"] | {"libcpvs/tiles"}
BELOW["libcpvs/dag"] = BELOW["libcpvs/tiles"] | {"libcpvs/dag"}
BELOW["libcpvs/bake"] = BELOW["libcpvs/dag"] | {"libcpvs/bake", "libcpvs/version.h"}
BELOW["libcpvs/reference"] = BELOW["libcpvs/scene"] | {"libcpvs/reference"}
BELOW["libcpvs/eval"] = BELOW["libcpvs/bake"] | BELOW["libcpvs/reference"] | {"libcpvs/eval"}
BELOW["formats/gltf"] = BELOW["libcpvs/scene"] | {"formats/gltf"}
BELOW["formats/io"] = BELOW["libcpvs/base"] | {"formats/io"}
BELOW["libcpvs/preview"] = BELOW["libcpvs/eval"] | BELOW["formats/io"] | {"libcpvs/preview"}
BELOW["examples/lookup"] = RUNTIME

INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def folder_of(path):
    for f in sorted(BELOW, key=len, reverse=True):
        if path == f or path.startswith(f + "/"):
            return f
    return None


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "."
    wrong, checked = [], 0
    for folder in BELOW:
        base = os.path.join(root, folder)
        for dirpath, _, files in os.walk(base):
            for name in sorted(files):
                if not name.endswith((".h", ".cpp")):
                    continue
                rel = os.path.relpath(os.path.join(dirpath, name), root)
                if folder_of(rel) != folder:
                    continue
                text = open(os.path.join(root, rel), encoding="utf-8").read()
                for target in INCLUDE.findall(text):
                    checked += 1
                    if "/" not in target:
                        continue  # a sibling header
                    allowed = BELOW[folder]
                    if not any(target == a or target.startswith(a + "/") for a in allowed):
                        wrong.append(f"{rel}: includes {target}, which {folder} does not link")
    for line in wrong:
        print(line)
    if wrong:
        return 1
    print(f"{checked} includes in {len(BELOW)} folders run down the pipeline")
    return 0


if __name__ == "__main__":
    sys.exit(main())
