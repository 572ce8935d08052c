"""Threads that fit the machine: the CPUs this process may use, and the choice between the
parallel and the one-thread ray kernel as the machine's load changes (the speed itself is
measured by ``flatland-ma bench``, not here)."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from flatland_ma.envs.vector import BatchedParallelEnv
from flatland_ma.sensors.threads import Chooser, cgroup_cpus, usable_cpus


class Costly:
    """A version of the call that advances a fake clock by its current cost."""

    def __init__(self, clock: list[float], cost: float):
        self.clock, self.cost, self.calls = clock, cost, 0

    def __call__(self) -> None:
        self.calls += 1
        self.clock[0] += self.cost


def chooser(parallel_cost: float, serial_cost: float, threads: int = 2):
    now = [0.0]
    parallel, serial = Costly(now, parallel_cost), Costly(now, serial_cost)
    return Chooser(parallel, serial, threads, clock=lambda: now[0]), parallel, serial


def test_a_stalling_parallel_kernel_gives_way_to_one_thread_and_costs_little():
    choose, parallel, serial = chooser(parallel_cost=10.0, serial_cost=1.0)
    assert choose.parallel  # it starts on every thread
    for _ in range(100_000):
        choose()
    assert not choose.parallel
    assert choose.patience == Chooser.MAX_PATIENCE
    # Tried again now and then, less often each time it loses: a few calls in 100,000.
    assert parallel.calls < 200
    assert serial.calls > 99_800


def test_the_parallel_kernel_comes_back_when_the_machine_is_free_again():
    choose, parallel, serial = chooser(parallel_cost=10.0, serial_cost=1.0)
    for _ in range(20_000):
        choose()
    assert not choose.parallel
    parallel.cost = 0.5  # the other process has finished
    for _ in range(Chooser.MAX_PATIENCE + Chooser.TRIAL + 1):
        choose()
    assert choose.parallel
    before = serial.calls
    for _ in range(10_000):
        choose()
    assert serial.calls - before < 10_000 // Chooser.FIRST_PATIENCE * Chooser.TRIAL


def test_one_usable_cpu_never_tries_the_parallel_kernel():
    choose, parallel, serial = chooser(parallel_cost=0.1, serial_cost=1.0, threads=1)
    for _ in range(10_000):
        choose()
    assert parallel.calls == 0 and serial.calls == 10_000


def test_usable_cpus_follows_affinity_and_quota(tmp_path):
    assert 1 <= usable_cpus() <= len(os.sched_getaffinity(0))
    (tmp_path / "cpu.max").write_text("150000 100000\n")
    assert cgroup_cpus(tmp_path) == 1.5
    (tmp_path / "cpu.max").write_text("max 100000\n")
    assert cgroup_cpus(tmp_path) is None
    assert cgroup_cpus(tmp_path / "missing") is None


@pytest.mark.parametrize("scenario", ["fruits_poisons", "fruits_poisons_multi"])
def test_switching_kernels_mid_run_changes_no_observation(scenario):
    """The chooser may switch at any step: a batch made to switch every few steps gives
    exactly what a batch on one thread gives."""
    fixed = BatchedParallelEnv(scenario, num_worlds=4, parallel=False)
    switching = BatchedParallelEnv(scenario, num_worlds=4, parallel=True)
    a, _ = fixed.reset(seed=3)
    b, _ = switching.reset(seed=3)
    rays = switching.core.kernel
    rays.observe(np.arange(4))  # compile, then force a switch every few calls
    function = rays.function
    assert isinstance(function, Chooser)
    function.FIRST_PATIENCE = function.MAX_PATIENCE = 3
    function.patience = 3
    rng = np.random.default_rng(0)
    for _ in range(60):
        actions = rng.integers(0, 3, size=fixed.num_slots)
        out_a, out_b = fixed.step(actions), switching.step(actions)
        np.testing.assert_array_equal(out_a[0], out_b[0])
        np.testing.assert_array_equal(out_a[1], out_b[1])
    assert function.calls <= 3  # it went on switching to the end


def _python(code: str) -> subprocess.CompletedProcess:
    """``code`` in a fresh interpreter, without the suite's OMP_WAIT_POLICY."""
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    return subprocess.run(
        [sys.executable, "-W", "always", "-c", code], env=env, capture_output=True, text=True
    )


def test_openmp_started_first_is_warned_about_and_flatland_first_is_not():
    late = _python("import torch\nimport flatland_ma\n")
    assert late.returncode == 0 and "OMP_WAIT_POLICY" in late.stderr
    assert "RuntimeWarning" in late.stderr
    early = _python(
        "import flatland_ma\nimport torch\nimport os\nprint(os.environ['OMP_WAIT_POLICY'])"
    )
    assert early.returncode == 0 and "RuntimeWarning" not in early.stderr
    assert early.stdout.strip() == "PASSIVE"
    chosen = _python(
        "import os\nos.environ['OMP_WAIT_POLICY'] = 'ACTIVE'\nimport torch, flatland_ma\n"
    )
    assert chosen.returncode == 0 and "RuntimeWarning" not in chosen.stderr
