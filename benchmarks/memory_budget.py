#!/usr/bin/env python3
"""A bake that outgrows the machine, run with no memory option: does the default budget stop it cleanly?

    python3 benchmarks/memory_budget.py [--bin build/bin] [--out out/memory-budget] [--resolution 128k]
                                        [--json docs/robustness/default-budget.json] [--threads 2]

Bakes the sun of the generated foliage level (`cpvs-scenegen foliage`, `--lights sun`) at --resolution with no
--max-memory, so cpvs-bake takes its default budget (the cgroup limit or CPVS_MEMORY_LIMIT, else physical
memory, less a margin). Every second it samples the bake's resident memory and the system's MemAvailable; at the
end it records the exit code, the message, the wall and CPU time and the peak RSS (wait4), whether the output
file exists, and the kernel's OOM-kill counter (/proc/vmstat oom_kill) before and after, which shows whether the
kernel killed anything meanwhile. Writes everything to --json. Python 3 standard library only.
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info  # noqa: E402
from uniform_tiles import load_average  # noqa: E402


def meminfo(key):
    with open("/proc/meminfo") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
    return 0


def oom_kills():
    try:
        with open("/proc/vmstat") as f:
            for line in f:
                if line.startswith("oom_kill "):
                    return int(line.split()[1])
    except OSError:
        pass
    return None


def rss_of(pid):
    try:
        with open("/proc/%d/statm" % pid) as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGESIZE")
    except OSError:
        return 0


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bin", default="build/bin")
    parser.add_argument("--out", default="out/memory-budget")
    parser.add_argument("--resolution", default="128k")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--json", default="docs/robustness/default-budget.json")
    a = parser.parse_args()
    os.makedirs(a.out, exist_ok=True)
    scene = os.path.join(a.out, "foliage.glb")
    if not os.path.exists(scene):
        subprocess.run([os.path.join(a.bin, "cpvs-scenegen"), "foliage", "-o", scene], check=True)
    output = os.path.join(a.out, "foliage-sun-%s.cpvs" % a.resolution)
    if os.path.exists(output):
        os.remove(output)
    help_text = subprocess.run([os.path.join(a.bin, "cpvs-bake"), "--help"], capture_output=True, text=True).stdout
    default_line = " ".join(help_text[help_text.find("--max-memory"):].split("\n  --")[0].split())
    cmd = [os.path.join(a.bin, "cpvs-bake"), scene, "--lights", "sun", "-r", a.resolution, "-j", str(a.threads),
           "-o", output]
    print("$ " + " ".join(cmd), flush=True)
    load_before, oom_before = load_average(), oom_kills()
    start = time.time()
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True)
    samples = []
    while proc.poll() is None:
        samples.append({"s": round(time.time() - start, 1), "rss_bytes": rss_of(proc.pid),
                        "mem_available_bytes": meminfo("MemAvailable")})
        time.sleep(1)
    # poll() reaped it: its CPU time and peak RSS are in this process's children's totals (the scene generator and
    # --help before it are small and short).
    wall = time.time() - start
    stderr = proc.stderr.read()
    usage = os.times()
    result = {
        "command": " ".join(cmd),
        "help_default": default_line,
        "exit_code": proc.returncode,
        "message": stderr.strip(),
        "wall_s": wall,
        "cpu_s": usage.children_user + usage.children_system,
        "peak_rss_bytes": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024,
        "peak_sampled_rss_bytes": max((s["rss_bytes"] for s in samples), default=0),
        "least_mem_available_bytes": min((s["mem_available_bytes"] for s in samples), default=0),
        "swap_total_bytes": meminfo("SwapTotal"),
        "output_exists": os.path.exists(output),
        "oom_kills_before": oom_before,
        "oom_kills_after": oom_kills(),
        "load_before": load_before,
        "load_after": load_average(),
        "machine": machine_info(),
        "samples": samples,
    }
    try:
        result["commit"] = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                                          text=True).stdout.strip()
    except OSError:
        pass
    print(stderr.strip())
    print("exit %d after %.1f s (%.1f CPU-s), peak RSS %.2f GiB, least MemAvailable %.2f GiB, output %s, "
          "OOM kills %s -> %s, load %.2f -> %.2f" %
          (proc.returncode, wall, result["cpu_s"], result["peak_rss_bytes"] / 2**30,
           result["least_mem_available_bytes"] / 2**30, "left" if result["output_exists"] else "none",
           oom_before, result["oom_kills_after"], load_before, result["load_after"]))
    os.makedirs(os.path.dirname(a.json) or ".", exist_ok=True)
    with open(a.json, "w") as f:
        json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
