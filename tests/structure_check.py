#!/usr/bin/env python3
"""Sizes the code may not pass (docs/architecture.md, "Sizes"): no function longer than MAX_FUNCTION lines and no
file longer than MAX_FILE lines in the given folders (default: the library). A function is measured from its
header's first line to its closing brace, lambdas and local classes included. Exit 1 and one line per offender, else a summary line.
Usage: structure_check.py SOURCE_DIR [FOLDER...]"""
import os
import re
import sys

MAX_FUNCTION = 120
MAX_FILE = 800
FOLDERS = ["libcpvs"]
NOT_A_FUNCTION = re.compile(r"^\s*(?:template\s*<.*>\s*)?(namespace|struct|class|union|enum)\b|=\s*$|\b(?:if|for|while|switch|catch|do|else)\b\s*\(?")


def strip(text):
    """The text with comments, string and character literals blanked (newlines kept)."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append("\n" * text.count("\n", i, j))
            i = j
        elif text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            k = text.find("(", i)
            close = ")" + text[i + 2:k] + '"'
            j = text.find(close, k)
            j = n if j < 0 else j + len(close)
            out.append('""' + "\n" * text.count("\n", i, j))
            i = j
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            out.append(c + c)
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def without_preprocessor(code):
    """The code with its preprocessor lines (and their continuations) blanked, newlines kept: an #if's
    parentheses would otherwise make the declaration after it look like a function's header."""
    lines, continued = code.split("\n"), False
    for k, line in enumerate(lines):
        directive = continued or line.lstrip().startswith("#")
        continued = directive and line.rstrip().endswith("\\")
        if directive:
            lines[k] = ""
    return "\n".join(lines)


def functions(text):
    """(name, first line, line count) of every outermost function body: a '{' whose header, the text since the
    previous ';', '{' or '}', ends in ')' (plus qualifiers, an initialiser list or a trailing return type)."""
    code = without_preprocessor(strip(text))
    found, stack, start = [], [], 0
    for i, c in enumerate(code):
        if c == "{":
            header = code[start:i]
            in_function = any(kind == "function" for kind, _, _ in stack)
            is_function = (not in_function and ")" in header and not NOT_A_FUNCTION.search(header.strip().split("\n")[0])
                           and not header.strip().startswith(("=", ",", "(", "return")))
            first = start + len(header) - len(header.lstrip())
            stack.append(("function" if is_function else "block", first, header))
            start = i + 1
        elif c == "}":
            if stack:
                kind, first, header = stack.pop()
                if kind == "function":
                    line0 = code.count("\n", 0, first) + 1
                    line1 = code.count("\n", 0, i) + 1
                    name = re.findall(r"([~\w:]+)\s*\(", header)
                    found.append((name[0] if name else "?", line0, line1 - line0 + 1))
            start = i + 1
        elif c == ";":
            start = i + 1
    return found


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "."
    folders = sys.argv[2:] or FOLDERS
    wrong, files, count = [], 0, 0
    for folder in folders:
        for dirpath, _, names in os.walk(os.path.join(root, folder)):
            for name in sorted(names):
                if not name.endswith((".h", ".cpp")) or name.endswith("_test.cpp"):
                    continue
                path = os.path.join(dirpath, name)
                rel = os.path.relpath(path, root)
                text = open(path, encoding="utf-8").read()
                files += 1
                lines = text.count("\n")
                if lines > MAX_FILE:
                    wrong.append(f"{rel}: {lines} lines (at most {MAX_FILE})")
                for fn, line, length in functions(text):
                    count += 1
                    if length > MAX_FUNCTION:
                        wrong.append(f"{rel}:{line}: {fn} is {length} lines (at most {MAX_FUNCTION})")
    for line in wrong:
        print(line)
    if wrong:
        return 1
    print(f"{count} functions in {files} files: none over {MAX_FUNCTION} lines, no file over {MAX_FILE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
