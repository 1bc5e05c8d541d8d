"""cpvs.preview: cpvs-view's pixels, from the same options, as a numpy image."""
import struct
import zlib

import numpy as np
import pytest

import cpvs
from conftest import run, tool


def read_png(path):
    """An 8-bit RGB PNG as an (H, W, 3) array (the kind cpvs-view writes; no other kind is needed here)."""
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    at, idat, width, height = 8, b"", 0, 0
    while at < len(data):
        length, kind = struct.unpack(">I4s", data[at:at + 8])
        body = data[at + 8:at + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour = struct.unpack(">IIBB", body[:10])
            assert (depth, colour) == (8, 2), "8-bit RGB expected"
        elif kind == b"IDAT":
            idat += body
        at += 12 + length
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(height, 1 + 3 * width)
    out = np.zeros((height, 3 * width), np.int32)
    for y in range(height):
        kind, row = raw[y, 0], raw[y, 1:].astype(np.int32)
        up = out[y - 1] if y else np.zeros(3 * width, np.int32)
        if kind in (0, 2):
            out[y] = (row + (up if kind == 2 else 0)) & 255
            continue
        line = np.zeros(3 * width + 3, np.int32)  # three zero bytes to the left of the row
        upleft = np.concatenate([np.zeros(3, np.int32), up])
        for x in range(3 * width):
            a, b, c = line[x], up[x], upleft[x]
            if kind == 1:
                predicted = a
            elif kind == 3:
                predicted = (a + b) // 2
            else:  # Paeth
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                predicted = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            line[x + 3] = (row[x] + predicted) & 255
        out[y] = line[3:]
    return out.reshape(height, width, 3).astype(np.uint8)


@pytest.mark.parametrize("options", [
    {},
    {"shadows": "cpu", "pcf": 3, "exposure": 1, "eye": "-150,120,-150", "target": "0,0,0"},
    {"shadows": "none", "overlay": "lights-per-tile", "ambient": 0},
])
def test_preview_is_cpvs_views_png(city, city_bake, tmp_path, options):
    try:
        image = cpvs.preview(city, city_bake, size=(160, 90), **options)
    except cpvs.NotSupportedError as e:  # no OSMesa where this runs: cpvs-view cannot render either
        pytest.skip(str(e))
    assert image.shape == (90, 160, 3) and image.dtype == np.uint8
    png = tmp_path / "view.png"
    flags = []
    for key, value in options.items():
        flags += ["--" + key.replace("_", "-"), str(value)]
    run(tool("cpvs-view"), city, city_bake, "-o", png, "--size", "160x90", "--quiet", *flags)
    np.testing.assert_array_equal(image, read_png(png))
    assert 10 < image.mean() < 245  # a picture, not a blank


def test_preview_sizes_and_errors(city, city_bake):
    try:
        small = cpvs.preview(city, city_bake, size="64x48", shadows="none")
    except cpvs.NotSupportedError as e:
        pytest.skip(str(e))
    assert small.shape == (48, 64, 3)
    with pytest.raises(cpvs.ArgumentError, match="size"):
        cpvs.preview(city, city_bake, size=(64, 48, 3))
    with pytest.raises(cpvs.ArgumentError, match="--size"):
        cpvs.preview(city, city_bake, size="64 by 48")
    with pytest.raises(cpvs.ArgumentError, match="output: not an option of cpvs.preview"):
        cpvs.preview(city, city_bake, output="x.png")
    with pytest.raises(cpvs.ArgumentError, match="--pcf"):
        cpvs.preview(city, city_bake, size="64x48", pcf=4)
    with pytest.raises(cpvs.ArgumentError, match="--eye and --target"):
        cpvs.preview(city, city_bake, size="64x48", eye="0,10,0")
    with pytest.raises(cpvs.ArgumentError, match="cpvs.preview"):
        cpvs.preview(city, city_bake, no_such_option=1)
    with pytest.raises(cpvs.ArgumentError, match="cpvs.preview"):  # swapped inputs: named as such
        cpvs.preview(city_bake, city)
    with pytest.raises(FileNotFoundError):
        cpvs.preview(city, city_bake + ".missing")
