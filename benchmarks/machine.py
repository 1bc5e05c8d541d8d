"""The machine a benchmark ran on, written next to every figure (shared by the benchmark scripts).

Python 3 standard library only."""

import os
import platform
import subprocess


def run_text(cmd):
    """stdout of cmd, or "" when it cannot run."""
    try:
        return subprocess.run(cmd, capture_output=True, text=True, check=False).stdout
    except OSError:
        return ""


# The instruction sets cpvs's paths choose between, as /proc/cpuinfo (x86) and lscpu (ARM) name them.
VECTOR_ISAS = [("avx2", "AVX2"), ("fma", "FMA"), ("avx512f", "AVX-512F"), ("asimd", "NEON")]


def machine_info(renderer=""):
    """CPU model (with its family and model numbers, the vector instruction sets it has, and any path the
    environment forces: the same CPU name covers different chips in a VM), logical CPUs, threads per core,
    cores per socket, memory (GiB), kernel, renderer."""
    info = {"model": "", "cpus": os.cpu_count(), "threads_per_core": "", "cores_per_socket": "",
            "memory_gib": 0.0, "kernel": platform.release(), "renderer": renderer, "family": "",
            "model_number": "", "isa": []}
    flags = set()
    for line in run_text(["lscpu"]).splitlines():
        key, _, value = line.partition(":")
        value = value.strip()
        if key == "Model name":
            info["model"] = value
        elif key == "Thread(s) per core":
            info["threads_per_core"] = value
        elif key == "Core(s) per socket":
            info["cores_per_socket"] = value
        elif key == "CPU family":
            info["family"] = value
        elif key == "Model":
            info["model_number"] = value
        elif key == "Flags":
            flags = set(value.split())
    info["isa"] = [name for flag, name in VECTOR_ISAS if flag in flags]
    details = []
    if info["family"] and info["model_number"]:
        details.append("family %s model %s" % (info["family"], info["model_number"]))
    if info["isa"]:
        details.append(", ".join(info["isa"]))
    forced = ["%s=%s" % (v, os.environ[v]) for v in ("CPVS_LOOKUP_ISA", "CPVS_RASTER_ISA") if os.environ.get(v)]
    if forced:
        details.append("forced " + " ".join(forced))
    if info["model"] and details:
        info["model"] += " (" + "; ".join(details) + ")"
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemTotal:"):
                    info["memory_gib"] = int(line.split()[1]) / 1024**2
    except OSError:
        pass
    return info


def machine_line(with_load=False):
    """One line: model, CPUs, memory, kernel (and the load average now, when asked)."""
    m = machine_info()
    line = (f"{m['model'] or platform.processor()}, {m['cpus']} logical CPUs, {m['memory_gib']:.1f} GiB RAM, "
            f"Linux {m['kernel']}")
    if with_load:
        line += f"; load average {os.getloadavg()[0]:.2f} when the table was written"
    return line
