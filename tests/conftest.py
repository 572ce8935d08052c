import os

# Rendering tests open the human window on SDL's dummy driver: no display needed.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
# Before any test imports torch, which loads libgomp: OpenMP threads that sleep when idle
# (what flatland_ma asks for), so that the ray kernel's threads leave the cores to torch.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
