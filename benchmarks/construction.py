#!/usr/bin/env python3
"""Construction benchmark: the generated closed city and its open version baked with a sun at
4k, 8k, 16k and 64k, with and without node reuse (Kämpe et al. 2015, §3.2), with --undefined kampe and sintorn, and
compared with a 16-bit shadow map of the same resolution. Writes docs/benchmarks.md with tables modelled on
Kämpe et al. 2015, Tables 1-4, the machine, and the exact commands.

Python 3 standard library only. Rerunnable: every bake's report JSON is cached under out/bench/ (git-ignored)
with the hash of the scene file and of the cpvs-bake binary, so an interrupted run resumes where it stopped
and a finished configuration is not baked again; a rebuilt baker or a changed scene invalidates the cache.

    python3 benchmarks/construction.py                 # full run (64k bakes take a long time on 2 cores)
    python3 benchmarks/construction.py --quick         # smoke run: 4k only, writes out/bench/benchmarks-quick.md
    python3 benchmarks/construction.py --report-only   # rewrite the markdown from the cached reports

Exit status: 0 done (targets met or not: the report says), 1 usage, 2 a bake or the scene generator failed.
"""

import argparse
import datetime
import hashlib
import json
import os
import shlex
import subprocess
import sys
import time

from kept_analysis import kept_analysis
from machine import machine_info, run_text

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# (key, cpvs-scenegen kind, label)
SCENES = [("closed", "city", "closed city"), ("open", "open-city", "open city")]
RESOLUTIONS = ["4k", "8k", "16k", "64k"]

# The construction targets, measured in one run.
TARGET_DAG_SPEEDUP = {"16k": 15.0, "64k": 40.0}
TARGET_KAMPE_VS_SINTORN_16K = 1.5
TARGET_SM_RATIO_16K = 100.0
TARGET_PEAK_RSS_64K = 4 * 1024**3

ANALYSIS_MARKER = "<!-- analysis: everything from this line on is hand-written and kept by construction.py -->"


def res_value(res):
    return int(res[:-1]) * 1024 if res.endswith("k") else int(res)


def configs_for(scene_key):
    """(undefined mode, node reuse) pairs baked for a scene."""
    if scene_key == "closed":
        return [("kampe", True), ("kampe", False), ("sintorn", True)]
    # Open geometry has no free voxels: kampe == sintorn == none; only reuse on/off matters.
    return [("kampe", True), ("kampe", False)]


def sha256_file(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def git_commit():
    out = run_text(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"]).strip()
    dirty = run_text(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no"]).strip()
    return out + (" (working tree has uncommitted changes)" if dirty else "")


class Bench:
    def __init__(self, args):
        self.args = args
        self.bin = os.path.abspath(args.bin)
        self.out = os.path.abspath(args.out)
        self.scene_dir = os.path.join(self.out, "scenes")
        self.report_dir = os.path.join(self.out, "reports")
        self.bake = os.path.join(self.bin, "cpvs-bake")
        self.scenegen = os.path.join(self.bin, "cpvs-scenegen")
        self.scenes = {}  # key -> (path, sha, generator output)
        self.results = {}  # (scene, res, undefined, reuse) -> {"report": ..., "meta": ...}
        self.commands = []

    # ---- inputs -------------------------------------------------------------------------------------------
    def check_tools(self):
        for tool in (self.bake, self.scenegen):
            if not os.access(tool, os.X_OK):
                sys.exit(f"construction.py: {tool} not found; build it first:\n"
                         f"  cmake -S . -B build-bench -G Ninja -DCMAKE_BUILD_TYPE=Release && "
                         f"ninja -C build-bench cpvs-bake cpvs-scenegen")
        self.bake_sha = sha256_file(self.bake)[:16]
        self.bake_version = run_text([self.bake, "--version"]).strip()

    def scene_path(self, kind):
        return os.path.join(self.scene_dir, f"{kind}-t{self.args.triangles}-s{self.args.seed}.glb")

    def generate_scenes(self):
        os.makedirs(self.scene_dir, exist_ok=True)
        for key, kind, _ in SCENES:
            path = self.scene_path(kind)
            cmd = [self.scenegen, kind, "-o", path, "--triangles", str(self.args.triangles),
                   "--seed", str(self.args.seed)]
            # Always regenerate (fast, deterministic): a changed generator changes the hash and the cache key.
            proc = subprocess.run(cmd, capture_output=True, text=True)
            if proc.returncode != 0:
                print(proc.stderr, file=sys.stderr)
                sys.exit(2)
            self.commands.append(self.rel_cmd(cmd))
            self.scenes[key] = (path, sha256_file(path)[:16], proc.stdout.strip().replace(ROOT + os.sep, ""))
            print(proc.stdout.strip(), flush=True)

    def rel_cmd(self, cmd):
        def rel(a):
            return os.path.relpath(a, ROOT) if os.path.isabs(a) and a.startswith(ROOT) else a
        return " ".join(shlex.quote(rel(a)) for a in cmd)

    # ---- bakes --------------------------------------------------------------------------------------------
    def cache_path(self, scene_key, res, undefined, reuse):
        name = f"{scene_key}-{res}-{undefined}-{'reuse' if reuse else 'noreuse'}.json"
        return os.path.join(self.report_dir, name)

    def bake_cmd(self, scene_key, res, undefined, reuse, report, output):
        cmd = [self.bake, self.scenes[scene_key][0], "-o", output, "--resolution", res, "--sun", self.args.sun,
               "--undefined", undefined, "--threads", str(self.args.threads), "--report", report, "--quiet"]
        if not reuse:
            cmd.append("--no-node-reuse")
        return cmd

    def load_cached(self, path, scene_key):
        try:
            with open(path) as f:
                cached = json.load(f)
        except (OSError, ValueError):
            return None
        meta = cached.get("meta", {})
        if (meta.get("scene_sha") != self.scenes[scene_key][1] or meta.get("sun") != self.args.sun or
                meta.get("threads") != self.args.threads):
            return None
        if meta.get("bake_sha") != self.bake_sha and not self.args.keep_stale:
            return None
        return cached

    def run_one(self, scene_key, res, undefined, reuse):
        path = self.cache_path(scene_key, res, undefined, reuse)
        key = (scene_key, res, undefined, reuse)
        cached = None if self.args.force else self.load_cached(path, scene_key)
        tmp_report = path + ".partial.json"
        output = os.path.join(self.out, "tmp-bake.cpvs")
        cmd = self.bake_cmd(scene_key, res, undefined, reuse, tmp_report, output)
        # The report is written beside the cache file, then wrapped into it with the run's metadata.
        self.commands.append(self.rel_cmd(cmd).replace(os.path.relpath(tmp_report, ROOT), os.path.relpath(path, ROOT)))
        if cached is not None:
            self.results[key] = cached
            print(f"  cached  {os.path.basename(path)}", flush=True)
            return True
        if self.args.report_only:
            return False
        label = f"{scene_key} {res} --undefined {undefined}{'' if reuse else ' --no-node-reuse'}"
        print(f"  baking  {label} ...", end="", flush=True)
        load_before = os.getloadavg()
        started = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M:%SZ")
        t0 = time.monotonic()
        proc = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.monotonic() - t0
        load_after = os.getloadavg()
        if proc.returncode != 0:
            print(f" FAILED (exit {proc.returncode})\n{proc.stderr}", file=sys.stderr, flush=True)
            return None
        with open(tmp_report) as f:
            report = json.load(f)
        os.remove(tmp_report)
        if os.path.exists(output):
            os.remove(output)
        meta = {"scene_sha": self.scenes[scene_key][1], "bake_sha": self.bake_sha, "sun": self.args.sun,
                "threads": self.args.threads, "run_command": this_command(),
                "started": started, "wall_s": wall, "loadavg_before": load_before[0], "loadavg_after": load_after[0],
                "command": self.rel_cmd(cmd)}
        result = {"meta": meta, "report": report}
        with open(path + ".tmp", "w") as f:
            json.dump(result, f, indent=1)
        os.replace(path + ".tmp", path)
        self.results[key] = result
        print(f" {wall:.1f} s (load {load_before[0]:.2f} -> {load_after[0]:.2f})", flush=True)
        return True

    def run_all(self):
        os.makedirs(self.report_dir, exist_ok=True)
        # Resolution by resolution, so a partial run still fills whole rows; the 64k sintorn bake (only for
        # the bytes ratio table) goes last.
        order = []
        for res in self.resolutions:
            for key, _, _ in SCENES:
                for undefined, reuse in configs_for(key):
                    order.append((key, res, undefined, reuse))
        order.sort(key=lambda c: (res_value(c[1]), c[1] == "64k" and c[2] == "sintorn"))
        failed = False
        for c in order:
            if self.run_one(*c) is None:
                failed = True
        return not failed

    # ---- report -------------------------------------------------------------------------------------------
    def view(self, key):
        r = self.results.get(key)
        if not r:
            return None
        return r["report"]["lights"][0]["views"][0]

    def write_markdown(self, path):
        A = self.args
        renderer = next((r["report"].get("renderer", "") for r in self.results.values()), "")
        m = machine_info(renderer)
        L = []
        w = L.append
        w("# Construction benchmark")
        w("")
        w("Generated by `benchmarks/construction.py`; do not edit by hand. [Kämpe et al. 2015](references.md), Tables 1-4, are "
          "the model: construction time with and without node reuse (§3.2), size with the §3.4 undefined-region "
          "rule (`kampe`) against Sintorn 2014's (`sintorn`), the phase breakdown, and the size against a 16-bit "
          "shadow map.")
        w("")
        w("## Machine and command")
        w("")
        w(f"* CPU: {m['model']} — {m['cpus']} logical CPUs ({m['cores_per_socket']} cores per socket, "
          f"{m['threads_per_core']} thread(s) per core), {m['memory_gib']:.1f} GiB RAM, Linux {m['kernel']}")
        w(f"* Renderer (from the bake report): `{m['renderer']}`")
        built = os.path.join(self.bin, "COMMIT")  # written by whoever copied the binaries (see README)
        commit = open(built).read().strip() if os.path.exists(built) else git_commit()
        w(f"* Baker: `{self.bake_version}` (binary sha256 {self.bake_sha}…), built from commit {commit}")
        loads = [r["meta"]["loadavg_before"] for r in self.results.values()]
        starts = sorted(r["meta"]["started"] for r in self.results.values())
        if loads:
            w(f"* Bakes run one at a time with `--threads {A.threads}` between {starts[0]} and {starts[-1]}; "
              f"1-minute load average before each bake {min(loads):.2f}–{max(loads):.2f} (the machine is shared: "
              "a load above about 2 — the rasteriser's threads — means other work competed for the 2 cores).")
        runs = sorted({r["meta"].get("run_command", "") for r in self.results.values()} - {""})
        w("* Command (the run that baked; an interrupted run resumes with the same command):")
        w("")
        w("```")
        for c in runs or [this_command()]:
            w(c)
        w("```")
        if this_command() not in runs:
            w("")
            w(f"  This file was last written by `{this_command()}` from the cached reports.")
        w("")
        for key, kind, label in SCENES:
            text = self.scenes[key][2]
            text = text[len(kind) + 2:] if text.startswith(kind + ": ") else text
            w(f"* {label} (`cpvs-scenegen {kind}`): {text}")
        w(f"* Sun direction (the way the light travels): `{A.sun}`; one orthographic view fitted to the scene; "
          "N = resolution in x, y and depth slices.")
        w("")
        w("<details><summary>Every bake command (one cached report JSON per line under out/bench/reports/)</summary>")
        w("")
        w("```")
        L.extend(self.commands)
        w("```")
        w("")
        w("</details>")
        w("")

        targets = []

        # Table 1
        w("## Table 1 — construction time with and without node reuse")
        w("")
        w("Total bake time and the DAG phase (insertion and merging of nodes: the builder's recursion, hash-consing "
          "and the min-max hierarchy) with `--no-node-reuse` and with reuse (the default), `--undefined kampe`. "
          "*Speed-up* is DAG without reuse / DAG with reuse. *Built* counts interned nodes (duplicates included); "
          "with reuse, volumes equal to their Z-neighbour are taken without being built. *Built ratio* (no reuse / "
          "reuse) is the same comparison in work done, which does not depend on what else the machine was doing.")
        w("")
        w("| Scene | N | total, no reuse | DAG, no reuse | total, reuse | DAG, reuse | DAG speed-up | nodes built (no reuse → reuse) | built ratio |")
        w("|---|---|---:|---:|---:|---:|---:|---|---:|")
        for key, _, label in SCENES:
            for res in self.resolutions:
                a, b = self.view((key, res, "kampe", False)), self.view((key, res, "kampe", True))
                ta = self.results.get((key, res, "kampe", False))
                tb = self.results.get((key, res, "kampe", True))
                if not a or not b:
                    w(f"| {label} | {res} | — | — | — | — | — | not measured | — |")
                    continue
                speed = a["phases_ms"]["dag"] / max(b["phases_ms"]["dag"], 1e-9)
                built = a.get("nodes_built", 0) / max(b.get("nodes_built", 0), 1)
                w(f"| {label} | {res} | {fmt_ms(ta['report']['total_ms'])} | {fmt_ms(a['phases_ms']['dag'])} | "
                  f"{fmt_ms(tb['report']['total_ms'])} | {fmt_ms(b['phases_ms']['dag'])} | **{speed:.2f}×** | "
                  f"{a.get('nodes_built', 0):,} → {b.get('nodes_built', 0):,} | {built:.2f}× |")
                if key == "closed" and res in TARGET_DAG_SPEEDUP:
                    targets.append((f"closed city {res}: DAG phase with reuse ≥ {TARGET_DAG_SPEEDUP[res]:.0f}× faster "
                                    "than without", f"{speed:.2f}×", speed >= TARGET_DAG_SPEEDUP[res]))
        w("")

        # Table 2
        w("## Table 2 — size with the §3.4 undefined-region rule (kampe) vs Sintorn 2014 (closed city)")
        w("")
        w("DAG bytes (node units + leaf masks) and the whole `.cpvs` file, node reuse on. *Ratio* = sintorn / kampe.")
        w("")
        w("| N | kampe DAG MB | sintorn DAG MB | ratio | kampe file MB | sintorn file MB | unique leaves (kampe / sintorn) |")
        w("|---|---:|---:|---:|---:|---:|---|")
        for res in self.resolutions:
            k, s = self.view(("closed", res, "kampe", True)), self.view(("closed", res, "sintorn", True))
            if not k or not s:
                w(f"| {res} | — | — | — | — | — | not measured |")
                continue
            rk = self.results[("closed", res, "kampe", True)]["report"]
            rs = self.results[("closed", res, "sintorn", True)]["report"]
            ratio = s["bytes"] / max(k["bytes"], 1)
            w(f"| {res} | {mb(k['bytes'])} | {mb(s['bytes'])} | **{ratio:.2f}×** | {mb(rk['file_bytes'])} | "
              f"{mb(rs['file_bytes'])} | {k['unique_leaves']:,} / {s['unique_leaves']:,} |")
            if res == "16k":
                ratio_file = rs["file_bytes"] / max(rk["file_bytes"], 1)
                targets.append((f"closed city 16k: kampe ≥ {TARGET_KAMPE_VS_SINTORN_16K}× smaller than sintorn",
                                f"{ratio:.2f}× (DAG bytes), {ratio_file:.2f}× (file)",
                                ratio >= TARGET_KAMPE_VS_SINTORN_16K))
        w("")

        # Table 3
        w("## Table 3 — time per phase (node reuse on, kampe)")
        w("")
        w("Milliseconds per phase as the bake report gives them: *depth* = enter-depth rendering, *peel* = exit-depth "
          "peeling of closed solids, *masks* = 8×8 tile visibility masks, *dag* = DAG construction, *write* = "
          "serialising the file. " + ("With `--threads 1` the phases run one after the other and add up to "
          "about the total." if A.threads == 1 else f"With `--threads {A.threads}` masks and DAG of one region "
          "overlap the rendering of the next, so the phases can add up to more than the total."))
        w("")
        w("| Scene | N | regions | depth | peel | masks | dag | write | total | peel iterations (max) |")
        w("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
        for key, _, label in SCENES:
            for res in self.resolutions:
                v = self.view((key, res, "kampe", True))
                if not v:
                    w(f"| {label} | {res} | — | — | — | — | — | — | — | — |")
                    continue
                p = v["phases_ms"]
                total = self.results[(key, res, "kampe", True)]["report"]["total_ms"]
                w(f"| {label} | {res} | {v.get('regions', '')} | {fmt_ms(p['depth'])} | {fmt_ms(p['peel'])} | "
                  f"{fmt_ms(p['masks'])} | {fmt_ms(p['dag'])} | {fmt_ms(p['write'])} | {fmt_ms(total)} | "
                  f"{v.get('peel_iterations', '')} |")
        w("")

        # Table 4
        w("## Table 4 — size against a 16-bit shadow map, total time and peak memory")
        w("")
        w("*Shadow map* = N × N × 2 bytes (the report's `shadow_map_bytes`); *ratio* = shadow map / `.cpvs` file. "
          "Peak RSS is the baker process's maximum resident set size (`peak_rss_bytes`).")
        w("")
        w("| Scene | N | file MB | shadow map MB | ratio | total | peak RSS |")
        w("|---|---|---:|---:|---:|---:|---:|")
        for key, _, label in SCENES:
            for res in self.resolutions:
                v = self.view((key, res, "kampe", True))
                if not v:
                    w(f"| {label} | {res} | — | — | — | — | — |")
                    continue
                rep = self.results[(key, res, "kampe", True)]["report"]
                ratio = v["shadow_map_bytes"] / max(rep["file_bytes"], 1)
                w(f"| {label} | {res} | {mb(rep['file_bytes'])} | {mb(v['shadow_map_bytes'])} | **{ratio:.1f}×** | "
                  f"{fmt_ms(rep['total_ms'])} | {rep['peak_rss_bytes'] / 1024**3:.2f} GiB |")
                if key == "closed" and res == "16k":
                    targets.append((f"closed city 16k: file ≥ {TARGET_SM_RATIO_16K:.0f}× smaller than the 16-bit "
                                    "shadow map", f"{ratio:.1f}×", ratio >= TARGET_SM_RATIO_16K))
                if key == "closed" and res == "64k":
                    targets.append(("closed city 64k: peak RSS < 4 GB",
                                    f"{rep['peak_rss_bytes'] / 1024**3:.2f} GiB",
                                    rep["peak_rss_bytes"] < TARGET_PEAK_RSS_64K))
        peaks = [(r["report"]["peak_rss_bytes"], k) for k, r in self.results.items() if k[1] == "64k"]
        if peaks:
            peak, k = max(peaks)
            w("")
            w(f"Largest peak RSS of any 64k bake: {peak / 1024**3:.2f} GiB ({k[0]} city, --undefined {k[2]}, "
              f"{'reuse' if k[3] else 'no reuse'}).")
        w("")

        w("## Targets")
        w("")
        w("| Target | Measured | Met |")
        w("|---|---|---|")
        for name, measured, ok in targets:
            w(f"| {name} | {measured} | {'yes' if ok else '**no**'} |")
        missing = [t for t in ["16k", "64k"] if t in self.resolutions and
                   not self.view(("closed", t, "kampe", True))]
        if missing:
            w(f"| (not measured in this run: {', '.join(missing)}) | | |")
        w("")
        # Hand-written analysis below the marker in the existing document is kept across regenerations.
        L.extend(kept_analysis(path, ANALYSIS_MARKER))
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        with open(path + ".tmp", "w") as f:
            f.write("\n".join(L) + "\n")
        os.replace(path + ".tmp", path)
        print(f"wrote {os.path.relpath(os.path.abspath(path), ROOT)}")
        for name, measured, ok in targets:
            print(f"  {'MET ' if ok else 'MISS'} {name}: {measured}")


def this_command():
    return "python3 " + " ".join(shlex.quote(a) for a in [os.path.relpath(os.path.abspath(sys.argv[0]), ROOT)] + sys.argv[1:])


def fmt_ms(ms):
    if ms >= 10000:
        return f"{ms / 1000:.1f} s"
    if ms >= 1000:
        return f"{ms / 1000:.2f} s"
    return f"{ms:.0f} ms" if ms >= 10 else f"{ms:.1f} ms"


def mb(b):
    return f"{b / 1e6:.2f}"


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="smoke run: 4k only, markdown to out/bench/benchmarks-quick.md")
    p.add_argument("--resolutions", default=None, help="comma list (default 4k,8k,16k,64k; --quick: 4k)")
    p.add_argument("--bin", default=os.path.join(ROOT, "build-bench", "bin"), help="folder with cpvs-bake and cpvs-scenegen")
    p.add_argument("--out", default=os.path.join(ROOT, "out", "bench"), help="cache folder (scenes, report JSONs)")
    p.add_argument("--doc", default=None, help="markdown output (default docs/benchmarks.md; --quick: out/bench/benchmarks-quick.md)")
    p.add_argument("--triangles", type=int, default=100000, help="cpvs-scenegen --triangles for both cities")
    p.add_argument("--seed", type=int, default=1, help="cpvs-scenegen --seed")
    p.add_argument("--sun", default="0.4,-1,0.3", help="sun direction X,Y,Z (the way the light travels)")
    p.add_argument("--threads", type=int, default=1,
                   help="cpvs-bake --threads (default 1: masks and DAG then run after each region's rendering "
                        "instead of beside it, so the DAG phase is timed without competing with the "
                        "rasteriser's own threads; llvmpipe still renders on every core)")
    p.add_argument("--force", action="store_true", help="bake again even when a cached report exists")
    p.add_argument("--keep-stale", action="store_true", help="use cached reports of a different cpvs-bake binary")
    p.add_argument("--report-only", action="store_true", help="do not bake; write the markdown from cached reports")
    args = p.parse_args()
    res = args.resolutions or ("4k" if args.quick else ",".join(RESOLUTIONS))
    resolutions = [r.strip() for r in res.split(",") if r.strip()]
    for r in resolutions:
        v = res_value(r) if r[:-1].isdigit() or r.isdigit() else 0
        if v < 1024 or v & (v - 1):
            p.error(f"--resolutions: '{r}' is not a power of two from 1k up")
    doc = args.doc or (os.path.join(args.out, "benchmarks-quick.md") if args.quick
                       else os.path.join(ROOT, "docs", "benchmarks.md"))
    bench = Bench(args)
    bench.resolutions = resolutions
    bench.check_tools()
    bench.generate_scenes()
    ok = bench.run_all()
    bench.write_markdown(doc)
    return 0 if ok else 2


if __name__ == "__main__":
    sys.exit(main())
