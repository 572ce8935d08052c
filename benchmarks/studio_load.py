"""The studio under load: WATCHERS pages watching an episode at once over loopback for
SECONDS, each at the studio's top frame rate, against one ``flatland-ma studio`` process.

Reports each watcher's frame rate, the latency of a frame (from the start of its step on
the server to its last byte at the page, one clock: the same machine), errors, and the
server's resident memory (every second, from /proc) after a warm-up and at the end. An
episode that ends is started again on the next seed, so worlds are built all along.
Exits 1 if any watcher met an error or memory grew past ``--growth`` after the warm-up.

    python benchmarks/studio_load.py [--watchers 8] [--seconds 60] [--scenario NAME]

Measured (2 CPUs shared with other jobs, load average 14 rising to 18 during the run):
8 watchers of fruits_poisons_multi for 60 s, no error; 1.7 frames a second per watcher
(842 frames in all: the machine's share, not the 30 asked); latency median 457 ms, 95th
percentile 1,026 ms; server memory 329 MiB after 10 s, 334 MiB at the end (+1.5%).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import websockets

ROOT = Path(__file__).resolve().parent.parent
ALIVE_SECONDS = 20.0
"""How often a watcher says it is there (the studio ends episodes of silent pages)."""


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def wait_listening(port: int, bound: float = 120.0) -> None:
    """Until the server accepts connections (bounded for a server that never starts)."""
    began = time.monotonic()
    while time.monotonic() - began < bound:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            return
        except OSError:
            time.sleep(0.2)
    raise RuntimeError("the studio did not start listening")


def rss_mib(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def machine_load() -> str:
    one, five, _ = os.getloadavg()
    return f"load average {one:.2f} (1 min), {five:.2f} (5 min) on {os.cpu_count()} CPUs"


async def watch(url: str, scenario: str, seconds: float, index: int, fps: float) -> dict:
    frames, latencies, errors = 0, [], []
    seed = index * 1000
    async with websockets.connect(url, max_size=2**24) as ws:
        start = {"type": "start", "scenario": scenario, "seed": seed, "fps": fps}
        await ws.send(json.dumps(start))
        began = time.monotonic()
        said = began
        playing = False
        while time.monotonic() - began < seconds:
            if time.monotonic() - said > ALIVE_SECONDS:  # as the pages do
                await ws.send(json.dumps({"type": "alive"}))
                said = time.monotonic()
            message = await ws.recv()
            if isinstance(message, bytes):
                continue
            data = json.loads(message)
            if data["type"] == "error":
                errors.append(data["message"])
            elif data["type"] == "ready" and not playing:
                await ws.send(json.dumps({"type": "play"}))
                playing = True
            elif data["type"] == "state":
                picture = await ws.recv()
                assert isinstance(picture, bytes)
                latencies.append(time.time() - data["began"])
                frames += 1
                if data["done"]:
                    seed += 1
                    await ws.send(json.dumps({"type": "reset", "seed": seed}))
                    await ws.send(json.dumps({"type": "play"}))
        elapsed = time.monotonic() - began
    return {"frames": frames, "fps": frames / elapsed, "latencies": latencies, "errors": errors}


async def sample_memory(pid: int, seconds: float, samples: list) -> None:
    began = time.monotonic()
    while time.monotonic() - began < seconds:
        samples.append((time.monotonic() - began, rss_mib(pid)))
        await asyncio.sleep(1.0)


async def run(args, port: int, pid: int) -> tuple[list[dict], list]:
    url = f"ws://127.0.0.1:{port}/api/episode"
    samples: list = []
    watchers = [watch(url, args.scenario, args.seconds, i, args.fps) for i in range(args.watchers)]
    results = await asyncio.gather(
        sample_memory(pid, args.seconds + 1, samples), *watchers, return_exceptions=True
    )
    out = []
    for result in results[1:]:
        if isinstance(result, BaseException):
            out.append({"frames": 0, "fps": 0.0, "latencies": [], "errors": [repr(result)]})
        else:
            out.append(result)
    return out, samples


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--watchers", type=int, default=8)
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--scenario", default="fruits_poisons_multi")
    parser.add_argument("--fps", type=float, default=30.0, help="asked of each watcher")
    parser.add_argument("--warmup", type=float, default=10.0, help="seconds before memory counts")
    parser.add_argument("--growth", type=float, default=0.10, help="memory growth allowed")
    parser.add_argument(
        "--gif-frames",
        type=int,
        default=20,
        help="frames each episode keeps for its GIF (the studio's bounded buffer, which "
        "fills during the run; kept small so that memory shows everything else)",
    )
    args = parser.parse_args()
    port = free_port()
    folder = tempfile.mkdtemp(prefix="studio-load-")
    command = [sys.executable, "-m", "flatland_ma.cli", "studio", "--port", str(port)]
    command += ["--scenarios", folder, "--episodes", str(args.watchers), "--fps", str(args.fps)]
    command += ["--gif-frames", str(args.gif_frames)]
    server = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.PIPE, text=True)
    try:
        assert server.stdout is not None
        print(server.stdout.readline().strip())  # the line with the URL
        wait_listening(port)
        before = machine_load()
        results, samples = asyncio.run(run(args, port, server.pid))
        after = machine_load()
    finally:
        server.terminate()
        server.wait(timeout=30)
    errors = [e for r in results for e in r["errors"]]
    latencies = sorted(x for r in results for x in r["latencies"])
    rates = [r["fps"] for r in results]
    warm = [m for t, m in samples if t >= args.warmup]
    growth = (warm[-1] - warm[0]) / warm[0] if len(warm) > 1 else float("nan")
    asked = f"{args.fps:g} fps asked"
    print(f"{args.watchers} watchers of {args.scenario} for {args.seconds:g} s, {asked}")
    print(f"machine: before {before}; after {after}")
    print(
        f"frame rate per watcher: mean {statistics.mean(rates):.1f}, min {min(rates):.1f}, "
        f"max {max(rates):.1f} fps; {sum(r['frames'] for r in results):,} frames in all"
    )
    if latencies:
        p50 = latencies[len(latencies) // 2]
        p95 = latencies[int(len(latencies) * 0.95)]
        worst = latencies[-1]
        print(
            f"latency (step start to frame received): median {p50 * 1000:.0f} ms, "
            f"95th percentile {p95 * 1000:.0f} ms, max {worst * 1000:.0f} ms"
        )
    if warm:
        print(
            f"server memory: {samples[0][1]:.0f} MiB at start, {warm[0]:.0f} MiB after "
            f"{args.warmup:g} s, {warm[-1]:.0f} MiB at the end (growth {growth:+.1%}), "
            f"peak {max(m for _, m in samples):.0f} MiB"
        )
    print(f"errors: {len(errors)}" + (f" (first: {errors[0]})" if errors else ""))
    return 1 if errors or not growth <= args.growth else 0


if __name__ == "__main__":
    sys.exit(main())
