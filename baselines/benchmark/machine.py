"""The machine a benchmark seed ran on, for its record: package versions, the checkout's
commit, the load and CPUs, CPU time, and a calibration (a fixed piece of work's rate)."""

from __future__ import annotations

import os
import platform
import resource
import subprocess
from importlib import metadata

from baselines.benchmark.settings import ROOT
from baselines.common import calibration


def versions() -> dict[str, str]:
    out = {"python": platform.python_version()}
    for package in ("flatland_ma", "numpy", "pymunk", "numba", "torch"):
        try:
            out[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            out[package] = "absent"
    return out


def commit() -> str:
    """The checkout's commit, with ``-modified`` if the library or the baselines differ from it."""
    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True
        )
        changed = subprocess.run(
            ["git", "diff", "--quiet", "HEAD", "--", "flatland_ma", "baselines", "scenarios"],
            cwd=ROOT,
        )
    except OSError:
        return "unknown"
    name = head.stdout.strip() or "unknown"
    return name + ("-modified" if changed.returncode == 1 else "")


def machine() -> dict:
    return {
        "load_1min": round(os.getloadavg()[0], 2),
        "cpus_usable": len(os.sched_getaffinity(0)),
        "cpus": os.cpu_count(),
        "machine": platform.machine(),
    }


def cpu_seconds() -> float:
    """CPU time of this process (every thread) and of its finished children."""
    own, children = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def calibrate() -> dict:
    """The machine's speed at the start of a run: ``calibration``'s fixed matrix
    products, per CPU-second of this thread."""
    return {"matmuls_256_per_cpu_second": round(calibration(), 1)}
