"""``flatland-ma studio``: the studio's options, and the server (uvicorn) that runs it."""

from __future__ import annotations

import argparse
import secrets
import sys
from pathlib import Path

import flatland_ma.cli.options as options
from flatland_ma.cli.options import OptionError
from flatland_ma.studio.config import LOOPBACK, Limits, StudioConfig

DEFAULT_PORT = 8765
SCORES_FILE = "play_scores.csv"
DESCRIPTION = (
    "A local web app to design, watch and play scenarios in a browser: a gallery, an "
    "editor with completion and located errors, watching policies and playing at the "
    "keyboard. It listens on 127.0.0.1; with --host another address, it prints a token "
    "that every request must carry. Files are read and written only inside --scenarios "
    "folders; checkpoints are loaded only from --checkpoints. On a remote machine, forward "
    "the port: ssh -L 8765:127.0.0.1:8765 server, then open http://127.0.0.1:8765/."
)


def add_parser(commands) -> argparse.ArgumentParser:
    studio = commands.add_parser(
        "studio", help="design, watch and play scenarios in a browser", description=DESCRIPTION
    )
    studio.add_argument(
        "--port",
        type=options.count(1, 65535, "a TCP port"),
        default=DEFAULT_PORT,
        help=f"the port to listen on (default: {DEFAULT_PORT})",
    )
    studio.add_argument(
        "--host",
        default="127.0.0.1",
        help="the address to listen on (default: 127.0.0.1, this machine only); any other "
        "needs the token the studio prints",
    )
    studio.add_argument(
        "--scenarios",
        type=options.existing_folder,
        action="append",
        default=None,
        metavar="DIR",
        help="a folder of scenario files to list, edit and save into (repeat for more)",
    )
    studio.add_argument(
        "--checkpoints",
        type=options.existing_folder,
        default=None,
        metavar="DIR",
        help="a folder of checkpoint files (.safetensors) the policies may play",
    )
    studio.add_argument(
        "--scores",
        type=options.output_file(".csv"),
        default=None,
        help=f"CSV that each played episode's scores are appended to (default: {SCORES_FILE} "
        "in the first --scenarios folder; none written without one)",
    )
    studio.add_argument(
        "--episodes",
        type=options.positive(64),
        default=Limits.episodes,
        help=f"episodes (watch or play) at once (default: {Limits.episodes})",
    )
    studio.add_argument(
        "--fps",
        type=options.number(0.0, 120.0),
        default=Limits.fps,
        help=f"frames a second an episode sends at most (default: {Limits.fps:g})",
    )
    studio.add_argument(
        "--gif-frames",
        type=options.positive(options.MAX_FRAMES),
        default=Limits.recorded_frames,
        help="frames an episode keeps for its GIF, the latest ones (default: "
        f"{Limits.recorded_frames}; tens of kB each)",
    )
    return studio


def check(args) -> None:
    """A host is a name or an address without a port or spaces."""
    host = args.host
    if not host or len(host) > 253 or any(c in host for c in " /?#@") or host.count(":") == 1:
        raise OptionError("--host", f"{host!r} is not an address to listen on")
    try:
        import starlette  # noqa: F401
        import uvicorn  # noqa: F401
    except ImportError:
        raise OptionError(
            "studio",
            "the studio needs its extra: in a clone of flatland_ma, pip install -e '.[studio]'",
        ) from None


def config_of(args) -> StudioConfig:
    """The studio's configuration from its options (a token if not on the loopback)."""
    local = args.host in LOOPBACK
    folders = tuple(Path(f) for f in (args.scenarios or []))
    scores = args.scores
    if scores is None and folders:
        scores = folders[0] / SCORES_FILE
    return StudioConfig(
        folders=folders,
        checkpoints=args.checkpoints,
        token=None if local else secrets.token_urlsafe(24),
        scores=Path(scores) if scores is not None else None,
        limits=Limits(episodes=args.episodes, fps=args.fps, recorded_frames=args.gif_frames),
    )


def run(args) -> int:
    import uvicorn

    from flatland_ma.studio.app import create_app
    from flatland_ma.studio.serving import browser_hosts, server_options, url_of

    config = config_of(args)
    app = create_app(config, local=config.token is None)
    hosts = browser_hosts(args.host)
    if config.token is not None:
        print("Listening beyond this machine: every request needs the token in this URL.")
    print(f"flatland-ma studio: open {url_of(hosts[0], args.port, config.token)}")
    for host in hosts[1:]:
        print(f"  or {url_of(host, args.port, config.token)}")
    if config.scores is not None:
        print(f"Played episodes' scores go to {config.scores}.")
    sys.stdout.flush()
    uvicorn.run(app, host=args.host, port=args.port, **server_options(config.limits))
    return 0


if __name__ == "__main__":  # pragma: no cover
    parser = argparse.ArgumentParser(prog="flatland-ma")
    add_parser(parser.add_subparsers(dest="command"))
    sys.exit(run(parser.parse_args(["studio", *sys.argv[1:]])))
