#!/usr/bin/env python3
"""What a format-2 .cpvs DAG would weigh with a "repeat" child code: the study for a possible format 3.0.

Format 2.0 (formats/cpvs/format.md) stores a node as a u16 header, 2 bits per child (0 lit, 1 shadowed, 2 one-unit
reference, 3 two-unit reference), then the references: many of them repeat another child's. Leaf parents
split z only, and a Kampe chain keeps one mask for many slices, so child c often names the same leaf as child
c - 1; an octree node's far child c (c >= 4) often equals its near child c - 4 (the Z-neighbour that node
reuse, Kämpe et al. 2015, §3.2, exploits while building). This script re-encodes every view of a file, bottom-up and
exactly, as

  * "as stored": the 2.0 encoding of the file's own order (checked against the file: it must match);
  * "repeat codes": code 3 means "the same as child c - 1" in a leaf parent and "the same as child c - 4" in
    an octree node (c >= 4); a stored reference is one unit below 0x8000 and two units otherwise (the top bit
    of the first unit marks the wide form, since code 3 no longer does); each level and the leaves are stored
    most referenced first, as cpvs-bake 0.3 stores them.

Nothing is rewritten. Leaves stay 8 bytes each in both.

    python3 benchmarks/node_code_estimate.py FILE.cpvs [FILE.cpvs ...]
"""
import sys
from collections import Counter

from cpvs_views import views

def parse(levels, units):
    """Per level: (units in the level, [(unit offset in level, [(child, code, target)])]); targets are unit
    offsets into the next level, or leaf indices below leaf parents."""
    at, out = 0, []
    for count in levels:
        start, nodes = at, []
        for _ in range(count):
            offset = at - start
            header = units[at]
            at += 1
            children = []
            for c in range(8):
                code = (header >> (2 * c)) & 3
                if code == 2:
                    children.append((c, code, units[at]))
                    at += 1
                elif code == 3:
                    children.append((c, code, units[at] | (units[at + 1] << 16)))
                    at += 2
                else:
                    children.append((c, code, None))
            nodes.append((offset, children))
        out.append((at - start, nodes))
    return out


def encode(parsed, leaf_count, repeats):
    """Total units of the re-encoded levels (bottom-up; most referenced first when `repeats`)."""
    levels = len(parsed)

    def stored_refs(lv, children):
        leaf_parent = lv == levels - 1
        by_child = {c: t for c, code, t in children if code >= 2}
        out = []
        for c, code, t in children:
            if code < 2:
                continue
            if repeats:
                source = c - 1 if leaf_parent else c - 4
                if source >= 0 and by_child.get(source) == t:
                    continue
            out.append(t)
        return out

    # Reference counts of every target, over the references that would be stored.
    counts = [Counter() for _ in range(levels + 1)]
    for lv, (_, nodes) in enumerate(parsed):
        for _, children in nodes:
            for t in stored_refs(lv, children):
                counts[lv + 1][t] += 1
    if repeats:
        leaf_order = sorted(range(leaf_count), key=lambda i: (-counts[levels][i], i))
        child_position = {old: new for new, old in enumerate(leaf_order)}
    else:
        child_position = {i: i for i in range(leaf_count)}
    total, wide_count = 0, 0
    for lv in range(levels - 1, -1, -1):
        nodes = parsed[lv][1]
        order = range(len(nodes))
        if repeats and lv > 0:
            order = sorted(order, key=lambda i: (-counts[lv][nodes[i][0]], i))
        position, at = {}, 0
        for i in order:
            offset, children = nodes[i]
            position[offset] = at
            size = 1
            for t in stored_refs(lv, children):
                target = child_position[t]
                wide = target >= (0x8000 if repeats else 0x10000)
                size += 2 if wide else 1
                wide_count += wide
            at += size
        total += at
        child_position = position
    return total, wide_count


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    print("| file | view | nodes | units as stored | with repeat codes | wide refs (stored → repeat codes) "
          "| DAG MB (stored → repeat codes) | ratio |")
    print("|---|---:|---:|---:|---:|---|---|---:|")
    for path in sys.argv[1:]:
        data = open(path, "rb").read()
        for v, levels, units, leaf_count in views(data, 2):
            if not levels:
                continue
            parsed = parse(levels, units)
            stored, stored_wide = encode(parsed, leaf_count, repeats=False)
            if stored != len(units):
                sys.exit(f"{path} view {v}: re-encoding gives {stored} units, the file has {len(units)}")
            repeated, repeated_wide = encode(parsed, leaf_count, repeats=True)
            before = (2 * stored + 8 * leaf_count) / 1e6
            after = (2 * repeated + 8 * leaf_count) / 1e6
            print(f"| {path} | {v} | {sum(levels):,} | {stored:,} | {repeated:,} | {stored_wide:,} → "
                  f"{repeated_wide:,} | {before:.2f} → {after:.2f} | {before / after:.2f}× |")


if __name__ == "__main__":
    main()
