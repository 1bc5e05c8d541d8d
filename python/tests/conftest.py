"""Fixtures of the Python module's tests: the tools (CPVS_BIN, default build/bin), a generated city with a sun,
a spot and a point light, and its bake at 1k, made once per run in a temporary folder."""
import os
import subprocess

import pytest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("CPVS_BIN", os.path.join(ROOT, "build", "bin"))


def tool(name):
    return os.path.join(BIN, name)


def run(*cmd):
    subprocess.run([str(c) for c in cmd], check=True, capture_output=True, text=True)


@pytest.fixture(scope="session")
def city(tmp_path_factory):
    """A small generated city (its sun) with a spot and a point light given on the command line."""
    path = tmp_path_factory.mktemp("scenes") / "city.glb"
    run(tool("cpvs-scenegen"), "city", "--triangles", "20000", "-o", path)
    return str(path)


LIGHT_OPTIONS = {"spot": "-60,90,-40,0.2,-1,0.1,0.5,300", "point": "100,40,120,200"}


@pytest.fixture(scope="session")
def city_bake(city, tmp_path_factory):
    """The city baked by cpvs-bake at 1k with its sun, a spot and a point light."""
    path = tmp_path_factory.mktemp("bakes") / "city.cpvs"
    run(tool("cpvs-bake"), city, "-o", path, "-r", "1k", "--sun", "0.4,-1,0.3", "--spot", LIGHT_OPTIONS["spot"],
        "--point", LIGHT_OPTIONS["point"], "--quiet")
    return str(path)
