#!/usr/bin/env python3
"""Writes tiny.gltf: the smallest scene that exercises what the importer must get right.

* "Box": a closed unit cube (8 vertices, UNSIGNED_SHORT indices) placed by two nodes: "BoxA" and "BoxB";
  BoxB has scale (-1, 2, 1), a mirroring transform, so its winding must be flipped when flattened.
* "Ground": an open 10 x 10 quad at y = 0 (positions interleaved with normals, byteStride 24,
  UNSIGNED_BYTE indices).
* KHR_lights_punctual: a directional "Sun" on node "Sun" (child of "Lights", rotated -45 degrees about X,
  so it travels along (0, -0.7071, -0.7071)), and an unnamed spot on node "SpotNode" (a matrix that
  puts it at (0, 4, 0) pointing down -Y; outer cone 0.6, spec defaults otherwise).

Run `python3 make_tiny.py` in this directory; the output is deterministic.
"""
import base64
import json
import math
import struct
from pathlib import Path

box_positions = [(x, y, z) for z in (-0.5, 0.5) for y in (-0.5, 0.5) for x in (-0.5, 0.5)]
# Vertex i has x = bit 0, y = bit 1, z = bit 2. Each face as two counter-clockwise triangles seen from outside.
box_faces = [(0, 4, 6, 2), (1, 3, 7, 5), (0, 1, 5, 4), (2, 6, 7, 3), (0, 2, 3, 1), (4, 5, 7, 6)]
box_indices = [i for a, b, c, d in box_faces for i in (a, b, c, a, c, d)]

ground_vertices = [((-5.0, 0.0, -5.0), (0.0, 1.0, 0.0)), ((-5.0, 0.0, 5.0), (0.0, 1.0, 0.0)),
                   ((5.0, 0.0, 5.0), (0.0, 1.0, 0.0)), ((5.0, 0.0, -5.0), (0.0, 1.0, 0.0))]
ground_indices = [0, 1, 2, 0, 2, 3]  # counter-clockwise seen from +Y


def padded(data: bytes) -> bytes:
    return data + b"\0" * (-len(data) % 4)


chunks = [
    padded(b"".join(struct.pack("<3f", *p) for p in box_positions)),
    padded(struct.pack("<%dH" % len(box_indices), *box_indices)),
    padded(b"".join(struct.pack("<3f3f", *p, *n) for p, n in ground_vertices)),
    padded(struct.pack("<%dB" % len(ground_indices), *ground_indices)),
]
offsets = [sum(len(c) for c in chunks[:i]) for i in range(len(chunks))]
buffer = b"".join(chunks)

buffer_views = [
    {"buffer": 0, "byteOffset": offsets[0], "byteLength": 12 * len(box_positions), "target": 34962},
    {"buffer": 0, "byteOffset": offsets[1], "byteLength": 2 * len(box_indices), "target": 34963},
    {"buffer": 0, "byteOffset": offsets[2], "byteLength": 24 * len(ground_vertices), "byteStride": 24,
     "target": 34962},
    {"buffer": 0, "byteOffset": offsets[3], "byteLength": len(ground_indices), "target": 34963},
]
accessors = [
    {"bufferView": 0, "componentType": 5126, "count": len(box_positions), "type": "VEC3",
     "min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5]},
    {"bufferView": 1, "componentType": 5123, "count": len(box_indices), "type": "SCALAR"},
    {"bufferView": 2, "componentType": 5126, "count": len(ground_vertices), "type": "VEC3",
     "min": [-5.0, 0.0, -5.0], "max": [5.0, 0.0, 5.0]},
    {"bufferView": 2, "byteOffset": 12, "componentType": 5126, "count": len(ground_vertices), "type": "VEC3"},
    {"bufferView": 3, "componentType": 5121, "count": len(ground_indices), "type": "SCALAR"},
]

half = math.radians(-45.0) / 2
gltf = {
    "asset": {"version": "2.0", "generator": "cpvs data/scenes/Tiny/make_tiny.py"},
    "extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [
        {"name": "Sun", "type": "directional", "color": [1.0, 0.95, 0.9], "intensity": 3.0},
        {"type": "spot", "spot": {"outerConeAngle": 0.6}},
    ]}},
    "scene": 0,
    "scenes": [{"name": "Tiny", "nodes": [0, 1, 2, 3, 5]}],
    "nodes": [
        {"name": "BoxA", "mesh": 0, "translation": [-1.5, 0.5, 0.0]},
        {"name": "BoxB", "mesh": 0, "translation": [1.5, 1.0, 0.0], "scale": [-1.0, 2.0, 1.0]},
        {"name": "Ground", "mesh": 1},
        {"name": "Lights", "translation": [0.0, 10.0, 0.0], "children": [4]},
        {"name": "Sun", "rotation": [math.sin(half), 0.0, 0.0, math.cos(half)],
         "extensions": {"KHR_lights_punctual": {"light": 0}}},
        {"name": "SpotNode", "matrix": [1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 0, 4, 0, 1],
         "extensions": {"KHR_lights_punctual": {"light": 1}}},
    ],
    "meshes": [
        {"name": "Box", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4}]},
        {"name": "Ground", "primitives": [{"attributes": {"POSITION": 2, "NORMAL": 3}, "indices": 4}]},
    ],
    "accessors": accessors,
    "bufferViews": buffer_views,
    "buffers": [{"byteLength": len(buffer),
                 "uri": "data:application/octet-stream;base64," + base64.b64encode(buffer).decode("ascii")}],
}

out = Path(__file__).with_name("tiny.gltf")
out.write_text(json.dumps(gltf, indent=1) + "\n")
print(f"wrote {out} ({len(buffer)} buffer bytes)")
