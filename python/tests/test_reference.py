"""cpvs.sample and cpvs.reference: the points cpvs-sample writes, and Embree's answers against which a pipeline
measures its bake."""
import csv

import numpy as np

import cpvs
from conftest import run, tool


def test_sample_equals_cpvs_sample(city, tmp_path):
    out = tmp_path / "points.csv"
    run(tool("cpvs-sample"), city, "-o", out, "-n", "500", "--seed", "3")
    with open(out) as f:
        rows = np.array([[float(x) for x in r] for r in list(csv.reader(f))[1:]])
    points, normals = cpvs.sample(city, 500, seed=3)
    assert points.shape == (500, 3) and points.dtype == np.float64
    np.testing.assert_array_equal(points, rows[:, :3])
    np.testing.assert_allclose(normals, rows[:, 3:], rtol=1e-7)


def test_bake_agrees_with_the_reference(city, city_bake):
    points, normals = cpvs.sample(city, 20000, seed=11)
    f = cpvs.open(city_bake)
    ref = cpvs.reference(city)
    for light in f.lights:
        baked = f.lookup(points, normals, light=light["index"])
        traced = ref.lookup(points, normals, light=light)
        assert traced.shape == baked.shape and traced.dtype == np.bool_
        # A 1k bake of a 1 km city: voxels of about a metre, so the answers differ along shadow edges only.
        assert np.count_nonzero(traced) > 0
        assert np.mean(baked != traced) < 0.03, (light["name"], np.mean(baked != traced))
