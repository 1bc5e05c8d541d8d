"""The views of a .cpvs file as the node-encoding studies read them (formats/cpvs/format.md): per view its level node
counts, its NODE section as an array of node words (format 1.x, u32) or units (2.x, u16), and its leaf count.
The studies trust the file (validate it with cpvs-info first)."""
import array
import struct
import sys

VIEW_RECORD = 472


def sections(data):
    count = struct.unpack_from("<I", data, 16)[0]
    table = struct.unpack_from("<Q", data, 24)[0]
    out = []
    for i in range(count):
        kind, _, offset, size, _ = struct.unpack_from("<4sIQQQ", data, table + 32 * i)
        out.append((kind, offset, size))
    return out


def views(data, major_wanted):
    """Yields (view index, node counts per level, node array, leaf count); exits unless the file's major
    version is `major_wanted` (1: u32 words, 2: u16 units)."""
    major = struct.unpack_from("<H", data, 8)[0]
    if major != major_wanted:
        width = "32-bit node words" if major_wanted == 1 else "16-bit node units"
        sys.exit(f"format {major}.x file: this study reads format {major_wanted}.x files ({width}) only")
    secs = sections(data)
    view_sec = next(s for s in secs if s[0] == b"VIEW")
    for v in range(view_sec[2] // VIEW_RECORD):
        at = view_sec[1] + v * VIEW_RECORD
        node_index, leaf_index = struct.unpack_from("<II", data, at + 16)
        levels = [n for n in struct.unpack_from("<32Q", data, at + 216) if n]
        node_sec, leaf_sec = secs[node_index], secs[leaf_index]
        nodes = array.array("I" if major_wanted == 1 else "H")
        nodes.frombytes(data[node_sec[1]:node_sec[1] + node_sec[2]])
        if sys.byteorder != "little":
            nodes.byteswap()
        yield v, levels, nodes, leaf_sec[2] // 8
