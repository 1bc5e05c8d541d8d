"""cpvs.bake: cpvs-bake's bytes and report from Python; progress on the calling thread; a cancel leaves no file
and no cache entry."""
import os
import threading

import pytest

import cpvs
from conftest import LIGHT_OPTIONS, run, tool


def test_bake_equals_cpvs_bake(city, tmp_path):
    by_tool = tmp_path / "tool.cpvs"
    run(tool("cpvs-bake"), city, "-o", by_tool, "-r", "512", "--sun", "0.4,-1,0.3", "--point", LIGHT_OPTIONS["point"],
        "--max-edge-error", "1", "--threads", "1", "--quiet")
    calls = []
    report = cpvs.bake(city, str(tmp_path / "python.cpvs"), resolution=512, sun="0.4,-1,0.3",
                       point=LIGHT_OPTIONS["point"], max_edge_error=1, threads=2,
                       progress=lambda f: calls.append((f, threading.get_ident())))
    assert (tmp_path / "python.cpvs").read_bytes() == by_tool.read_bytes()
    assert report["tool"] == "cpvs-bake" and [l["name"] for l in report["lights"]] == ["sun0", "point0"]
    assert report["settings"]["resolution"] == 512 and report["settings"]["max_edge_error"] == 1
    # Called on the calling thread, ending at 1.
    assert calls and calls[-1][0] == 1.0 and {t for _, t in calls} == {threading.get_ident()}


def test_a_part_and_the_cache(city, tmp_path):
    cache = tmp_path / "cache"
    first = cpvs.bake(city, str(tmp_path / "a.cpvs"), resolution="512", lights="sun0", sun="0.4,-1,0.3",
                      cache=str(cache))
    again = cpvs.bake(city, str(tmp_path / "b.cpvs"), resolution="512", lights=["sun0"], sun="0.4,-1,0.3",
                      cache=str(cache))
    assert [l["cache"] for l in first["lights"]] == ["miss"] and [l["cache"] for l in again["lights"]] == ["hit"]
    assert (tmp_path / "a.cpvs").read_bytes() == (tmp_path / "b.cpvs").read_bytes()


@pytest.mark.parametrize("how", ["false", "raise"])
def test_cancel_leaves_no_file_and_no_cache_entry(city, tmp_path, how):
    out, cache = tmp_path / "cancelled.cpvs", tmp_path / "cache"
    seen = []

    def progress(fraction):
        seen.append(fraction)
        if len(seen) >= 2:
            if how == "raise":
                raise KeyError("stop here")
            return False
        return None

    expected = cpvs.Cancelled if how == "false" else KeyError
    with pytest.raises(expected):
        cpvs.bake(city, str(out), resolution="16k", sun="0.4,-1,0.3", cache=str(cache), progress=progress)
    assert not out.exists()
    assert not cache.exists() or os.listdir(cache) == []
    assert [f for f in os.listdir(tmp_path) if f != "cache"] == []


def test_bake_options_are_checked(city, tmp_path):
    with pytest.raises(cpvs.ArgumentError, match="resolution"):
        cpvs.bake(city, str(tmp_path / "x.cpvs"), resolution="3k")
    with pytest.raises(cpvs.ArgumentError, match="no_such_option|no-such-option"):
        cpvs.bake(city, str(tmp_path / "x.cpvs"), no_such_option=1)
    with pytest.raises(cpvs.ArgumentError, match="watch"):
        cpvs.bake(city, str(tmp_path / "x.cpvs"), watch=True)
    with pytest.raises(cpvs.MissingFileError):
        cpvs.bake(str(tmp_path / "missing.glb"), str(tmp_path / "x.cpvs"))
    with pytest.raises(cpvs.MemoryBudgetError):
        cpvs.bake(city, str(tmp_path / "x.cpvs"), resolution="64k", sun="0.4,-1,0.3", max_memory="100M")
    assert not (tmp_path / "x.cpvs").exists()
