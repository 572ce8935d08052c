"""``flatland-ma lifelong``: the shipped streams, and the report of a run folder."""

from __future__ import annotations

import sys
from pathlib import Path

import flatland_ma.cli.options as options


def add_parser(commands) -> None:
    lifelong = commands.add_parser(
        "lifelong",
        help="task streams: list them, or report a run's continual-learning metrics",
        description="report RUN_DIR: the average performance at the end of the stream, "
        "forgetting, forward and backward transfer per method (mean and 95% t-interval "
        "over seeds), per task, and the task-by-time performance matrix (lifelong.png), "
        "from the evaluation blocks baselines/lifelong.py writes. list: the shipped streams.",
    )
    what = lifelong.add_subparsers(dest="lifelong", required=True)
    report = what.add_parser("report", help="metrics table, lifelong.json and lifelong.png")
    report.add_argument(
        "run_dir",
        type=options.existing_folder,
        help="the run folder baselines/lifelong.py wrote (a method's folder, or one above)",
    )
    report.add_argument(
        "--out",
        type=options.output_folder,
        default=None,
        help="folder for the JSON and the plot, made if missing (default: RUN_DIR)",
    )
    report.add_argument("--no-plot", action="store_true", help="write no lifelong.png")
    report.add_argument("--json", action="store_true", help="print the JSON, not the table")
    what.add_parser("list", help="the shipped streams")


def run(args) -> int:
    if args.lifelong == "list":
        from flatland_ma.lifelong.streams import list_streams, load_stream

        for name in list_streams():
            stream = load_stream(name)
            print(f"{name:<18} {', '.join(stream.task_labels)}: {stream.spec.description}")
        return 0
    from flatland_ma.lifelong.metrics import summary_json
    from flatland_ma.lifelong.report import RunError, load_run, plot, summarise, table

    try:
        data = load_run(args.run_dir)
        summary = summarise(data)
    except (RunError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    out = Path(args.out or args.run_dir)
    out.mkdir(parents=True, exist_ok=True)
    text = summary_json(summary)  # strict JSON: an undefined metric is null
    (out / "lifelong.json").write_text(text + "\n")
    print(text if args.json else table(summary))
    if not args.no_plot and data.learners:
        print(f"wrote {plot(data, summary, out / 'lifelong.png')}")
    return 0
