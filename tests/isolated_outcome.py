"""What running an isolated case gave (``tests/isolated.py``): the ``Outcome`` a test checks."""

from __future__ import annotations

from dataclasses import dataclass, field

TIME_LIMIT = 30.0
"""Wall-clock seconds a case may take, by default (load, two resets and the steps)."""
MEMORY_BUDGET_MB = 1024
"""Address space a case may add to the zygote's, in MiB, by default. The zygote maps
about 500 MiB (most of it reserved, not resident: numba, llvmlite, numpy); a case that
needs more than this much on top is refused by the kernel and sees ``MemoryError``."""
OVERRIDES = "<overrides>"
"""The source of a problem in the keyword overrides."""

KINDS = (
    "works",  # loaded, reset and stepped (see finite, in_space, rewards_finite)
    "located",  # ScenarioError whose every problem names its source
    "internal-error",  # ScenarioError wrapping an unexpected exception ("internal error")
    "unlocated",  # ScenarioError with a problem that names no source
    "other-exception",  # any other exception, while loading or running
    "memory",  # MemoryError
    "timeout",  # killed after the wall-clock limit
    "crashed",  # died by a signal (SIGABRT from a C assertion, SIGSEGV) or exited early
    "exited",  # a command line ran to its exit status (see exit_code, stderr)
    "returned",  # a snippet ran to its end
    "raised",  # a snippet raised (see raised_types, detail, problems)
)


@dataclass
class Outcome:
    """What running a case gave; ``kind`` is one of ``KINDS``."""

    kind: str
    wall_s: float = 0.0
    """Wall-clock seconds from fork to the child's exit."""
    peak_rss_mb: float = 0.0
    """The child's peak resident memory (it starts as a copy of the zygote's)."""
    start_rss_mb: float = 0.0
    """The child's resident memory when it started (the pages it shares with the zygote
    count once it touches them, so its peak counts some of the zygote's too)."""
    detail: str = ""
    """The first problem (``str(problem)``), the exception, or why the child died."""
    problems: list[dict] = field(default_factory=list)
    """Each problem of a ScenarioError: source, line, key (as printed) and message."""
    phase: str = ""
    """Where an exception came from: load, reset or step."""
    traceback: str = ""
    warnings: list[str] = field(default_factory=list)
    load_s: float | None = None
    reset_s: float | None = None
    steps: int = 0
    finite: bool | None = None
    """Every observation finite."""
    in_space: bool | None = None
    """Every observation inside its agent's observation space."""
    bad_observation: str = ""
    """The first observation not finite or outside its space."""
    rewards_finite: bool | None = None
    rewards_nan: bool | None = None
    """Some reward was NaN."""
    bad_reward: str = ""
    """The first reward not finite."""
    time_limit: float = TIME_LIMIT
    memory_limit_mb: float = MEMORY_BUDGET_MB
    exit_code: int | None = None
    """A command line's exit status (1 for an uncaught exception, as Python gives)."""
    stdout: str = ""
    stderr: str = ""
    """What a command printed (long output keeps its head and its tail)."""
    printed_traceback: bool = False
    """A command printed a Python traceback (it let an exception escape)."""
    internal_error: bool = False
    """A command printed, or a snippet's exception said, "internal error"."""
    raised_types: list[str] = field(default_factory=list)
    """The names of the classes of a snippet's exception (its type first, then its bases)."""

    @property
    def messages(self) -> str:
        return "\n".join(p["message"] for p in self.problems)

    def unplaced(self) -> list[dict]:
        """The problems that do not say where they are: without a source, or at a key of a
        file without its line (overrides have no lines)."""
        return [
            p
            for p in self.problems
            if not p["source"] or (p["key"] and p["source"] != OVERRIDES and p["line"] is None)
        ]

    @property
    def grown_mb(self) -> float:
        """Resident memory the child added to what it started with."""
        return self.peak_rss_mb - self.start_rss_mb

    def summary(self) -> str:
        """One paragraph saying what happened, with the figures, for assertion messages."""
        head = (
            f"{self.kind} in {self.wall_s:.2f} s (limit {self.time_limit:g} s), "
            f"peak RSS {self.peak_rss_mb:.0f} MiB (+{self.grown_mb:.0f} MiB from its start; "
            f"address space limit +{self.memory_limit_mb:g} MiB)"
        )
        if self.kind == "works":
            head += (
                f"; load {self.load_s:.2f} s, first reset {self.reset_s:.2f} s, "
                f"{self.steps} steps, finite={self.finite}, in_space={self.in_space}, "
                f"rewards_finite={self.rewards_finite}"
            )
            faults = [fault for fault in (self.bad_observation, self.bad_reward) if fault]
            if faults:
                head += f" ({'; '.join(faults)})"
        if self.kind == "exited":
            head += f"; exit status {self.exit_code}"
        lines = [head]
        if self.stderr:
            lines.append(f"stderr: {self.stderr}")
        if self.stdout:
            lines.append(f"stdout: {self.stdout}")
        if self.phase:
            lines.append(f"during {self.phase}")
        if self.detail:
            lines.append(self.detail)
        if self.traceback:
            lines.append(self.traceback)
        if self.warnings:
            lines.append("warnings: " + "; ".join(self.warnings))
        return "\n".join(lines)
