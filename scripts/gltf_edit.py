#!/usr/bin/env python3
"""Scripted edits of a binary glTF (.glb), as an artist's save would make them: move a node, delete a node, add a
copy of a node, or set a material's alpha mode. Only the JSON chunk changes; the binary chunk is kept as it is.

  python3 scripts/gltf_edit.py IN.glb OUT.glb move NODE DX DY DZ
  python3 scripts/gltf_edit.py IN.glb OUT.glb delete NODE
  python3 scripts/gltf_edit.py IN.glb OUT.glb copy NODE DX DY DZ
  python3 scripts/gltf_edit.py IN.glb OUT.glb alpha MATERIAL MODE [CUTOFF]
  python3 scripts/gltf_edit.py IN.glb OUT.glb move-instance NODE[,NODE...] INSTANCE DX DY DZ

NODE and MATERIAL are names (or indices); the output is written to a temporary and renamed. move-instance moves
one instance of nodes placed by EXT_mesh_gpu_instancing (a tree of a forest: its trunk and crown nodes), which
changes its float TRANSLATION in the binary chunk; the other edits change the JSON chunk only."""
import json
import os
import struct
import sys


def read_glb(path):
    data = open(path, "rb").read()
    magic, version, _ = struct.unpack_from("<4sII", data, 0)
    if magic != b"glTF" or version != 2:
        sys.exit(f"{path}: not a binary glTF 2.0 file")
    length, kind = struct.unpack_from("<I4s", data, 12)
    if kind != b"JSON":
        sys.exit(f"{path}: the first chunk is not JSON")
    return json.loads(data[20:20 + length]), data[20 + length:]


def write_glb(path, document, rest):
    text = json.dumps(document, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<I4s", len(text), b"JSON") + text + rest
    temp = path + ".edit-tmp"
    with open(temp, "wb") as out:
        out.write(struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)
    os.replace(temp, path)


def find(items, key, what):
    for i, item in enumerate(items):
        if item.get("name") == key or str(i) == key:
            return i
    sys.exit(f"no {what} named {key!r}")


def move_instance(document, rest, names, instance, offset):
    """Moves instance `instance` of each named node's EXT_mesh_gpu_instancing TRANSLATION; returns the new binary
    chunk (its 8-byte chunk header included)."""
    body = bytearray(rest)
    for name in names.split(","):
        node = document["nodes"][find(document["nodes"], name, "node")]
        attributes = node.get("extensions", {}).get("EXT_mesh_gpu_instancing", {}).get("attributes", {})
        if "TRANSLATION" not in attributes:
            sys.exit(f"node {name!r} has no EXT_mesh_gpu_instancing TRANSLATION")
        accessor = document["accessors"][attributes["TRANSLATION"]]
        if accessor["componentType"] != 5126 or accessor["type"] != "VEC3" or instance >= accessor["count"]:
            sys.exit(f"node {name!r}: no float translation for instance {instance}")
        view = document["bufferViews"][accessor["bufferView"]]
        stride = view.get("byteStride", 12)
        at = 8 + view.get("byteOffset", 0) + accessor.get("byteOffset", 0) + stride * instance
        values = struct.unpack_from("<3f", body, at)
        struct.pack_into("<3f", body, at, *(v + d for v, d in zip(values, offset)))
    return bytes(body)


def edit(document, action, args):
    nodes = document["nodes"]
    if action in ("move", "copy"):
        i = find(nodes, args[0], "node")
        node = json.loads(json.dumps(nodes[i])) if action == "copy" else nodes[i]
        t = node.setdefault("translation", [0.0, 0.0, 0.0])
        for k in range(3):
            t[k] += float(args[1 + k])
        if action == "copy":
            node["name"] = node.get("name", str(i)) + " copy"
            nodes.append(node)
            document["scenes"][document.get("scene", 0)]["nodes"].append(len(nodes) - 1)
    elif action == "delete":
        i = find(nodes, args[0], "node")
        for scene in document["scenes"]:
            scene["nodes"] = [n for n in scene["nodes"] if n != i]
        for node in nodes:
            if "children" in node:
                node["children"] = [c for c in node["children"] if c != i]
    elif action == "alpha":
        material = document["materials"][find(document["materials"], args[0], "material")]
        material["alphaMode"] = args[1]
        if len(args) > 2:
            material["alphaCutoff"] = float(args[2])
    else:
        sys.exit(f"unknown edit {action!r}: move, delete, copy or alpha")


def main():
    if len(sys.argv) < 5:
        sys.exit(__doc__)
    document, rest = read_glb(sys.argv[1])
    if sys.argv[3] == "move-instance":
        rest = move_instance(document, rest, sys.argv[4], int(sys.argv[5]), [float(x) for x in sys.argv[6:9]])
    else:
        edit(document, sys.argv[3], sys.argv[4:])
    write_glb(sys.argv[2], document, rest)


if __name__ == "__main__":
    main()
