#!/usr/bin/env python3
"""The runtime is standard C++20 outside its portability header: no compiler builtin, attribute, pragma,
compiler or system macro, and no system header or call in libcpvs/runtime/ but in portability.h and its two
sources, cpu_features.cpp and read_only_file.cpp (what an engine's MSVC, MinGW or AArch64 build would trip on;
docs/runtime.md, "Compilers and systems"). Comments are not code: a comment may name a builtin. Exit 1 with one
line per use, else a summary line.
Usage: portability_check.py SOURCE_DIR"""
import os
import re
import sys

FORBIDDEN = re.compile(
    r"__builtin_\w+|__attribute__|_Pragma|#\s*pragma\s+(GCC|clang)|__x86_64__|__GNUC__|__clang__|_MSC_VER|"
    r"__declspec|\b_M_X64\b|#\s*include\s*<(sys/|unistd\.h|fcntl\.h|windows\.h|intrin\.h)|\bmmap\s*\(|\bmunmap\s*\(|"
    r"(?<!\w)::(open|close|fstat)\s*\(")
ALLOWED = {"portability.h", "cpu_features.cpp", "read_only_file.cpp"}  # the header and its two sources


def code_of(line):
    """The line without its // comment (the runtime writes no // inside string literals)."""
    return line.split("//", 1)[0]


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "."
    folder = os.path.join(root, "libcpvs", "runtime")
    wrong, files = [], 0
    for name in sorted(os.listdir(folder)):
        if not name.endswith((".h", ".cpp")) or name in ALLOWED:
            continue
        files += 1
        in_block_comment = False
        for number, line in enumerate(open(os.path.join(folder, name), encoding="utf-8"), 1):
            if in_block_comment:
                if "*/" not in line:
                    continue
                line, in_block_comment = line.split("*/", 1)[1], False
            if "/*" in line and "*/" not in line.split("/*", 1)[1]:
                line, in_block_comment = line.split("/*", 1)[0], True
            match = FORBIDDEN.search(code_of(line))
            if match:
                wrong.append(f"libcpvs/runtime/{name}:{number}: {match.group(0)} (belongs in portability.h)")
    for line in wrong:
        print(line)
    if wrong:
        return 1
    print(f"{files} runtime files use nothing of a compiler's or system's own outside portability.h")
    return 0


if __name__ == "__main__":
    sys.exit(main())
