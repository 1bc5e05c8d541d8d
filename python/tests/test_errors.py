"""Bad input of every kind raises the documented exception with a message; none crashes the interpreter."""
import numpy as np
import pytest

import cpvs


@pytest.fixture(scope="module")
def f(city_bake):
    return cpvs.open(city_bake)


GOOD = np.zeros((4, 3))


@pytest.mark.parametrize("points, normals, kwargs, error, message", [
    (np.zeros((4, 2)), None, {"light": 0}, cpvs.ArgumentError, r"shape \(\.\.\., 3\), got \(4, 2\)"),
    (np.zeros(3), None, {"light": 0}, None, None),  # one point: answers of shape ()
    (np.zeros((0, 3)), None, {"light": 0}, None, None),
    (np.zeros((4, 3), dtype=np.complex64), None, {"light": 0}, cpvs.ArgumentError, "real numbers"),
    (np.array([["a", "b", "c"]]), None, {"light": 0}, cpvs.ArgumentError, "real numbers"),
    (np.zeros((4, 3), dtype=bool), None, {"light": 0}, cpvs.ArgumentError, "real numbers"),
    ("not an array", None, {"light": 0}, cpvs.ArgumentError, "real numbers|shape"),
    (np.array([[0, 0, np.nan]]), None, {"light": 0}, cpvs.ArgumentError, "point 0 .* not finite"),
    (GOOD, np.array([[0, np.inf, 0]] * 4), {"light": 0}, cpvs.ArgumentError, "not finite"),
    (GOOD, np.zeros((5, 3)), {"light": 0}, cpvs.ArgumentError, "normals"),
    (GOOD, None, {}, cpvs.ArgumentError, "holds 3 lights"),
    (GOOD, None, {"light": 3}, IndexError, "out of range"),
    (GOOD, None, {"light": -1}, cpvs.LightNotFoundError, "out of range"),
    (GOOD, None, {"light": "lantern"}, cpvs.LightNotFoundError, "no light named 'lantern'"),
    (GOOD, None, {"light": []}, cpvs.ArgumentError, "empty"),
    (GOOD, None, {"light": 1.5}, cpvs.ArgumentError, "an index, a name"),
    (GOOD, None, {"light": 0, "pcf": 4}, cpvs.ArgumentError, "pcf"),
    (GOOD, None, {"light": 0, "pcf": True}, cpvs.ArgumentError, "pcf"),
    (GOOD, None, {"light": 0, "bias": -1}, cpvs.ArgumentError, "bias"),
    (GOOD, None, {"light": 0, "threads": -2}, cpvs.ArgumentError, "threads"),
    (GOOD, None, {"light": 0, "out": np.zeros(4, dtype=np.float32)}, cpvs.ArgumentError, "out"),
    (GOOD, None, {"light": 0, "out": np.zeros(5, dtype=bool)}, cpvs.ArgumentError, "out"),
    (GOOD, None, {"light": 0, "out": np.zeros((4, 2), dtype=bool)[:, 0]}, cpvs.ArgumentError, "out"),
])
def test_bad_lookups_raise(f, points, normals, kwargs, error, message):
    if error is None:
        result = f.lookup(points, normals, **kwargs)
        assert result.shape == np.asarray(points).shape[:-1]
        return
    with pytest.raises(error, match=message):
        f.lookup(points, normals, **kwargs)


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("where", ["point", "normal", "single normal"])
def test_the_first_non_finite_point_is_named(f, dtype, where):
    # Several chunks of lookups, run on both cores: the error names the first bad point, whichever chunk
    # finished first.
    rng = np.random.default_rng(3)
    points = rng.uniform(-50, 50, (20000, 3)).astype(dtype)
    normals = np.tile(np.array([0, 1, 0], dtype=dtype), (20000, 1))
    if where == "point":
        points[17000, 1] = np.inf
        points[9321, 2] = np.nan
        first = 9321
    elif where == "normal":
        normals[19999, 0] = -np.inf
        normals[5000, 0] = np.nan
        first = 5000
    else:
        normals = np.array([0, np.nan, 0], dtype=dtype)
        first = 0
    with pytest.raises(cpvs.ArgumentError, match=f"point {first} .* not finite"):
        f.lookup(points, normals, light=0, threads=2)


def test_bad_files_raise(city_bake, tmp_path):
    with pytest.raises(cpvs.MissingFileError):
        cpvs.open(str(tmp_path / "missing.cpvs"))
    with pytest.raises(FileNotFoundError):
        cpvs.read_info(str(tmp_path / "missing.cpvs"))
    data = bytearray(open(city_bake, "rb").read())
    for name, damage in [("truncated", data[: len(data) // 2]), ("text", b"not a cpvs file at all"),
                         ("flipped", data[:5000] + bytes([data[5000] ^ 0x40]) + data[5001:])]:
        path = tmp_path / (name + ".cpvs")
        path.write_bytes(bytes(damage))
        with pytest.raises(cpvs.FormatError, match=name + ".cpvs"):
            cpvs.open(str(path))
    # read_info reads the header and the small sections: damage there is refused, damage in a DAG is for open.
    with pytest.raises(cpvs.FormatError):
        cpvs.read_info(str(tmp_path / "text.cpvs"))
    with pytest.raises(ValueError):
        cpvs.read_info(str(tmp_path / "truncated.cpvs"))


def test_bad_scenes_raise(city, tmp_path):
    broken = tmp_path / "broken.gltf"
    broken.write_text('{"asset": {"version": "2.0"}, "meshes": [{"primitives": [{"attributes": {"POSITION": 7}}]}]}')
    with pytest.raises(cpvs.FormatError, match="broken.gltf"):
        cpvs.sample(str(broken), 10)
    with pytest.raises(cpvs.MissingFileError):
        cpvs.reference(str(tmp_path / "missing.glb"))
    with pytest.raises(cpvs.ArgumentError):
        cpvs.sample(city, 0)
    ref = cpvs.reference(city)
    with pytest.raises(cpvs.LightNotFoundError):
        ref.lookup(GOOD, light=5)
    with pytest.raises(cpvs.ArgumentError):
        ref.lookup(np.zeros((2, 4)), light=0)
