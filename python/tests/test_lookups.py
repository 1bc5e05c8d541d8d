"""ShadowFile lookups: the answers of cpvs-query bit for bit, arrays in the shapes and dtypes documented,
threads that agree."""
import csv
import os
import threading

import numpy as np
import pytest

import cpvs
from conftest import run, tool


def query_tool(bake, points, normals, light, pcf, tmp_path):
    """cpvs-query's answers for the points (written with 17 digits: they read back bit for bit)."""
    inp, out = tmp_path / "points.csv", tmp_path / "answers.csv"
    with open(inp, "w") as f:
        f.write("x,y,z,nx,ny,nz\n")
        for p, n in zip(points, normals):
            f.write("%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n" % (*p, *n))
    cmd = [tool("cpvs-query"), bake, "--points", inp, "-o", out, "--light", str(light), "--quiet"]
    if pcf:
        cmd += ["--pcf", str(pcf)]
    run(*cmd)
    with open(out) as f:
        rows = list(csv.reader(f))
    column = rows[0].index(rows[0][-1])
    return np.array([float(r[column]) for r in rows[1:]], dtype=np.float32)


@pytest.fixture(scope="module")
def samples(city):
    return cpvs.sample(city, 3000, seed=7)


def test_lookups_equal_cpvs_query(city_bake, samples, tmp_path):
    f = cpvs.open(city_bake)
    points, normals = samples
    for light in range(len(f)):
        for pcf in (None, 3, 9):
            expected = query_tool(city_bake, points, normals, light, pcf, tmp_path)
            got = f.lookup(points, normals, light=light, pcf=pcf)
            if pcf is None:
                assert got.dtype == np.bool_
                np.testing.assert_array_equal(got, expected == 1.0)
            else:
                assert got.dtype == np.float32
                np.testing.assert_array_equal(got, expected)
        lit = f.lookup(points, normals, light=light).mean()
        assert (0.05 < lit < 0.98) if light == 0 else (0 < lit < 0.98), (light, lit)


def test_shapes_dtypes_and_broadcast(city_bake, samples):
    f = cpvs.open(city_bake)
    points, normals = samples
    flat = f.lookup(points, normals, light="sun0")
    # float32 is read where it lies; other dtypes are converted once: the same values, the same answers.
    p32, n32 = points.astype(np.float32), normals.astype(np.float32)
    assert np.array_equal(f.lookup(p32, n32, light=0), f.lookup(p32.astype(np.float64), n32.astype(np.float64), light=0))
    # Any leading shape; normals of the points' shape or one (3,) for all.
    grid = f.lookup(points[:3000].reshape(30, 100, 3), normals[:3000].reshape(30, 100, 3), light=0)
    assert grid.shape == (30, 100) and np.array_equal(grid.reshape(-1), flat[:3000])
    up = f.lookup(points, np.array([0.0, 1.0, 0.0]), light=0)
    assert up.shape == (len(points),)
    # A list of lights: a last axis, one column per light, in the order asked.
    both = f.lookup(points, normals, light=["sun0", 1])
    assert both.shape == (len(points), 2)
    assert np.array_equal(both[:, 0], flat) and np.array_equal(both[:, 1], f.lookup(points, normals, light=1))
    # out= is written and returned.
    out = np.empty((len(points), 2), dtype=np.float32)
    res = f.lookup(points, normals, light=[0, 1], pcf=3, out=out)
    assert res is out or np.shares_memory(res, out)
    assert np.array_equal(out[:, 0], f.lookup(points, normals, light=0, pcf=3))


def test_threads_agree(city_bake, samples):
    f = cpvs.open(city_bake)
    points, normals = samples
    points = np.tile(points, (20, 1))
    normals = np.tile(normals, (20, 1))
    expected = f.lookup(points, normals, light=[0, 1, 2], pcf=3, threads=1)
    results = [None] * 4

    def work(i):
        results[i] = f.lookup(points, normals, light=[0, 1, 2], pcf=3)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results:
        assert np.array_equal(r, expected)


def test_info_without_the_dags(city_bake):
    info = cpvs.read_info(city_bake)
    opened = cpvs.open(city_bake).info
    assert info == opened
    assert info["format_version"] == "2.0"
    assert info["bytes"] == os.path.getsize(city_bake)
    assert [l["name"] for l in info["lights"]] == [l["name"] for l in cpvs.open(city_bake).lights]
    assert [l["type"] for l in info["lights"]] == ["directional", "spot", "point"]
    assert len(info["lights"][2]["views"]) == 6 and info["lights"][0]["resolution"] == 1024
    assert len(info["input_hash"]) == 16
