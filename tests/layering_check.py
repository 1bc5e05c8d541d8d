#!/usr/bin/env python3
"""Includes run one way, down the pipeline: every #include "..." of a library folder must name a folder that
its CMake target links. The layers are read from the build itself: each `cpvs_stage(cpvs_X ... LINKS ...)` in
libcpvs/CMakeLists.txt is folder libcpvs/X, and a folder may include the folders of the stages it links,
directly or through them (cpvs_runtime, defined in libcpvs/runtime/, is the lowest); formats/cpvs, the file's
definition, is below them all and includes nothing outside itself. Exit 1 and one line per
wrong-way include (or per stage without a folder), else a summary line. Usage: layering_check.py SOURCE_DIR"""
import os
import re
import sys

STAGE = re.compile(r"^cpvs_stage\((cpvs_\w+)\s+SOURCES\s+\S+\s+LINKS\s+([^)]*)\)", re.M)
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)
# Generated into build/generated/libcpvs/ at configure time; only the bake stage writes the version.
GENERATED = {"cpvs_bake": {"libcpvs/version.h"}}


def stage_links(root):
    """cpvs_X -> the cpvs_ targets it links, as libcpvs/CMakeLists.txt declares them."""
    text = open(os.path.join(root, "libcpvs/CMakeLists.txt"), encoding="utf-8").read()
    links = {"cpvs_runtime": set()}
    for name, linked in STAGE.findall(text):
        links[name] = {t for t in linked.split() if t.startswith("cpvs_")}
    return links


def allowed_folders(links):
    """folder -> the folders it may include: its own and those of every stage below it."""
    def below(stage, seen):
        if stage in seen:
            raise SystemExit(f"layering_check: {stage} links itself through {sorted(seen)}")
        result = {stage}
        for linked in links.get(stage, ()):
            result |= below(linked, seen | {stage})
        return result

    folder = lambda stage: "libcpvs/" + stage[len("cpvs_"):]
    allowed = {}
    for stage in links:
        reach = below(stage, set())
        allowed[folder(stage)] = {folder(s) for s in reach} | set().union(*(GENERATED.get(s, set()) for s in reach))
    # formats/cpvs defines the file for its writer and its reader: every layer may include it, and it includes
    # nothing but itself (an engine vendors it with the runtime).
    for folder_name in allowed:
        allowed[folder_name].add("formats/cpvs")
    allowed["formats/cpvs"] = {"formats/cpvs"}
    allowed["examples/lookup"] = {"libcpvs/runtime", "formats/cpvs"}
    return allowed


def folder_of(path, folders):
    for f in sorted(folders, key=len, reverse=True):
        if path == f or path.startswith(f + "/"):
            return f
    return None


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "."
    allowed = allowed_folders(stage_links(root))
    wrong, checked = [], 0
    for folder in sorted(allowed):
        base = os.path.join(root, folder)
        if not os.path.isdir(base):
            wrong.append(f"{folder}: a stage of libcpvs/CMakeLists.txt without its folder")
            continue
        for dirpath, _, files in os.walk(base):
            for name in sorted(files):
                if not name.endswith((".h", ".cpp")):
                    continue
                rel = os.path.relpath(os.path.join(dirpath, name), root)
                if folder_of(rel, allowed) != folder:
                    continue
                text = open(os.path.join(root, rel), encoding="utf-8").read()
                for target in INCLUDE.findall(text):
                    checked += 1
                    if "/" not in target:
                        continue  # a sibling header
                    if not any(target == a or target.startswith(a + "/") for a in allowed[folder]):
                        wrong.append(f"{rel}: includes {target}, which {folder} does not link")
    # Every library folder is a stage: a folder outside the build's layers would escape the check.
    for entry in sorted(os.listdir(os.path.join(root, "libcpvs"))):
        if os.path.isdir(os.path.join(root, "libcpvs", entry)) and "libcpvs/" + entry not in allowed:
            wrong.append(f"libcpvs/{entry}: a folder that is no stage of libcpvs/CMakeLists.txt")
    for line in wrong:
        print(line)
    if wrong:
        return 1
    print(f"{checked} includes in {len(allowed)} folders run down the pipeline")
    return 0


if __name__ == "__main__":
    sys.exit(main())
