import os
from pathlib import Path

# Rendering tests open the human window on SDL's dummy driver: no display needed.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
# Before any test imports torch, which loads libgomp: OpenMP threads that sleep when idle
# (what flatland_ma asks for), so that the ray kernel's threads leave the cores to torch.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

HERE = Path(__file__).resolve().parent
APART = tuple(HERE / name for name in ("clients", "rllib", "docs", "studio/pages"))
"""Suites kept out of the default run, each run by its own make target in the environment
it needs (other venvs, a built site, headless Chromium): ``make test-clients``,
``make test-rllib``, ``make docs-check``, ``make studio-check``."""


def pytest_ignore_collect(collection_path, config):
    """Leave out a folder of ``APART`` unless the command line names it (or a path in it)."""
    path = Path(collection_path).resolve()
    if path not in APART:
        return None
    invoked = config.invocation_params.dir
    for arg in config.args:
        named = (invoked / arg.split("::")[0]).resolve()
        if named == path or path in named.parents:
            return None
    return True
