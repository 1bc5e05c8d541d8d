#!/usr/bin/env python3
"""What a .cpvs DAG would weigh with narrower node encodings: the design study behind format 2.0.

Format 1.0 stores every node as a u32 header (2 bits per child) and one u32 per referenced child: a word offset
into NODE, or a leaf index (formats/cpvs/format.md). Most of those references need far fewer than 32 bits. This script
reads a baked file and prints, per view, the DAG bytes as written and as they would be with

  * "16/32-bit refs": a u16 header whose code 3 (invalid in 1.0) marks a 32-bit reference and code 2 a 16-bit
    one; references count u16 units from the start of the child level (leaf indices stay indices), so a
    reference is 16-bit when its target starts within the first 65,536 units of its level;
  * the same with each level sorted by how often its nodes are referenced (most first; leaves likewise), so
    the 16-bit range holds the most popular targets.

Nothing is rewritten; the numbers are exact for those encodings (every node is re-encoded bottom-up).

    python3 benchmarks/ref_width_estimate.py FILE.cpvs [FILE.cpvs ...]
"""
import sys
from collections import Counter

from cpvs_views import views

NARROW_LIMIT = 1 << 16


def parse_levels(levels, words):
    """Per level, the list of (word offset, [child references]) in file order."""
    at, out = 0, []
    for count in levels:
        nodes = []
        for _ in range(count):
            header = words[at]
            refs = bin(header & 0xAAAA).count("1")
            nodes.append((at, list(words[at + 1:at + 1 + refs])))
            at += 1 + refs
        out.append(nodes)
    return out


def encoded_bytes(nodes_by_level, leaf_count, popularity):
    """Bytes of nodes (u16 units) and leaves under the 16/32-bit encoding, re-encoded bottom-up."""
    def order_of(keys, parents):
        if not popularity:
            return list(keys)
        uses = Counter(r for _, refs in parents for r in refs)
        return sorted(keys, key=lambda k: -uses[k])  # stable: ties keep file order

    # Position of each leaf / child node in u16 units (leaves: index) inside its level.
    position = {leaf: rank for rank, leaf in enumerate(order_of(range(leaf_count), nodes_by_level[-1]))}
    total_units = 0
    for level in range(len(nodes_by_level) - 1, -1, -1):
        size = {offset: 1 + sum(1 if position[r] < NARROW_LIMIT else 2 for r in refs)
                for offset, refs in nodes_by_level[level]}
        total_units += sum(size.values())
        if level == 0:
            break
        position, at = {}, 0
        for offset in order_of(size.keys(), nodes_by_level[level - 1]):
            position[offset] = at
            at += size[offset]
    return total_units * 2 + leaf_count * 8


def main(paths):
    if not paths:
        sys.exit(__doc__)
    print("| file | view | nodes | DAG bytes (1.0) | 16/32-bit refs | ratio | + popularity order | ratio |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for path in paths:
        with open(path, "rb") as f:
            data = f.read()
        for v, levels, words, leaf_count in views(data, 1):
            if not levels:
                continue
            by_level = parse_levels(levels, words)
            current = len(words) * 4 + leaf_count * 8
            plain = encoded_bytes(by_level, leaf_count, popularity=False)
            popular = encoded_bytes(by_level, leaf_count, popularity=True)
            print(f"| {path} | {v} | {sum(levels):,} | {current / 1e6:.2f} MB | {plain / 1e6:.2f} MB | "
                  f"{current / plain:.2f}x | {popular / 1e6:.2f} MB | {current / popular:.2f}x |")


if __name__ == "__main__":
    main(sys.argv[1:])
