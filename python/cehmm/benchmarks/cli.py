"""The command line: ``python -m cehmm.benchmarks`` runs the jobs, writes the data and the report."""

from __future__ import annotations

import argparse
import datetime as _dt
import shlex
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .._files import MAX_TEXT_BYTES, read_bytes, write_text
from ..reproduce.machine import machine_info, source_commit
from ..reproduce.records import append_record, read_records
from ..reproduce.text import _fmt_duration
from . import config
from .files import file_facts, find_files, parse_sarsop
from .report import page_text, write_page
from .run import run_jobs

#: The command as its records write it (``cehmm benchmarks`` is the same; help and errors name
#: the one that was run: ``main``'s ``prog``).
PROG = "python -m cehmm.benchmarks"


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=prog,
        description="Learns controllers by CE on every .pomdp file of the data folder (each file × controller a "
        "job), evaluates each exactly and writes OUT/data/benchmarks.jsonl (rewritten by each run: one line per "
        "file and per finished job) and the report OUT/benchmarks.md, against SARSOP's bounds from SOURCES.md.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    p.add_argument("--files", nargs="+", metavar="GLOB", help="files whose name or stem matches (default: all)")
    p.add_argument(
        "--controllers",
        nargs="+",
        metavar="NAME",
        help=f"controllers, by name or comma-separated (default: all of {', '.join(config.CONTROLLERS)})",
    )
    p.add_argument(
        "--time-limit",
        type=float,
        default=None,
        help=f"CE seconds per job (default {config.TIME_LIMIT:g}; a controller search gets "
        f"{config.CONTROLLER_TIME_FACTOR} times as long)",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help=f"files {', '.join(config.QUICK_FILES)}, controllers {', '.join(config.QUICK_CONTROLLERS)}, "
        f"{config.QUICK_TIME_LIMIT:g} s per job (each unless given)",
    )
    p.add_argument("--report-only", action="store_true", help="run nothing: rebuild the report from the data")
    p.add_argument(
        "--check", action="store_true", help="with --report-only: write nothing, exit 1 if the report differs"
    )
    p.add_argument(
        "--jobs", type=int, default=1, help="worker processes of one engine thread each (1: every core for each job)"
    )
    p.add_argument("--out", type=Path, default=config.DEFAULT_OUT, help="report folder (the data goes to OUT/data/)")
    p.add_argument("--data-dir", type=Path, default=config.DEFAULT_DATA_DIR, help="the .pomdp files and SOURCES.md")
    p.add_argument("--samples", type=int, default=config.SAMPLES, help="episodes per CE iteration")
    p.add_argument("--rho", type=float, default=config.RHO, help="selective rate")
    p.add_argument("--smoothing", type=float, default=config.SMOOTHING, help="CE smoothing")
    p.add_argument("--patience", type=int, default=config.PATIENCE, help="iterations without gain before stopping")
    p.add_argument("--init", default=config.INIT, choices=["random", "uniform"], help="starting tables")
    p.add_argument("--reward", default=config.REWARD, choices=["belief", "sampled"], help="the world's reward")
    p.add_argument("--seed", type=int, default=config.SEED, help="seed of every job")
    return p


def select_controllers(names: Sequence[str] | None, prog: str = PROG) -> dict[str, list[int]]:
    """The controllers named (``"1 node"`` or ``"1 node,2 nodes"``; case-insensitive), in CONTROLLERS order
    (``prog``: the command that names them, in errors)."""
    if not names:
        return dict(config.CONTROLLERS)
    known = {name.lower(): name for name in config.CONTROLLERS}
    # A name may hold a comma ("8 nodes, slow h0"): an item that is a name is taken whole.
    wanted = {
        n.strip().lower()
        for item in names
        for n in ([item] if item.strip().lower() in known else item.split(","))
        if n.strip()
    }
    unknown = sorted(wanted - set(known))
    if unknown:
        raise SystemExit(f"{prog}: error: unknown controller(s) {unknown}; known: {', '.join(config.CONTROLLERS)}")
    return {name: levels for name, levels in config.CONTROLLERS.items() if name.lower() in wanted}


def _job_settings(settings: dict[str, Any], controller: str) -> dict[str, Any]:
    """The settings of one job: the common ones with the controller's own; a controller search gets
    CONTROLLER_TIME_FACTOR times the time limit."""
    own = config.CONTROLLER_SETTINGS.get(controller, {})
    if own.get("method") == "controller":
        return {**settings, **own, "time_limit": settings["time_limit"] * config.CONTROLLER_TIME_FACTOR}
    return {**settings, **own}


def _paths(out: Path) -> tuple[Path, Path]:
    return out / config.REPORT_NAME, out / "data" / config.JSONL_NAME


def _report_only(args: argparse.Namespace, prog: str) -> int:
    report, jsonl = _paths(args.out)
    records = read_records(jsonl)
    if not any(r.get("record") == "file" for r in records):
        print(f"{prog}: error: {jsonl} has no records; run without --report-only first", file=sys.stderr)
        return 2
    text = page_text(args.out)
    if args.check:
        if (report.read_text() if report.exists() else None) != text:
            print(f"{report} is not what {jsonl} gives: run {prog} --report-only", file=sys.stderr)
            return 1
        print(f"{report} is what {jsonl} gives")
        return 0
    write_text(report, text)
    print(f"wrote {report} from {jsonl}")
    return 0


def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    """Runs the benchmarks as ``prog ARGS...`` (``argv``; default: the process's); returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser(prog).parse_args(argv)
    if args.check and not args.report_only:
        raise SystemExit(f"{prog}: error: --check goes with --report-only")
    if args.report_only:
        return _report_only(args, prog)
    if args.quick:
        args.files = args.files or list(config.QUICK_FILES)
        args.controllers = args.controllers or list(config.QUICK_CONTROLLERS)
        args.time_limit = config.QUICK_TIME_LIMIT if args.time_limit is None else args.time_limit
    time_limit = config.TIME_LIMIT if args.time_limit is None else args.time_limit
    controllers = select_controllers(args.controllers, prog)
    files = find_files(args.data_dir, args.files)
    if not files:
        print(f"{prog}: error: no .pomdp file in {args.data_dir} matches {args.files}", file=sys.stderr)
        return 2
    sources = args.data_dir / "SOURCES.md"
    sarsop = parse_sarsop(read_bytes(sources, MAX_TEXT_BYTES, "SOURCES.md").decode()) if sources.exists() else {}
    settings = {**config.default_settings(), "time_limit": time_limit}
    flags = ("samples", "rho", "smoothing", "patience", "init", "reward", "seed")
    settings.update({k: getattr(args, k) for k in flags})

    report, jsonl = _paths(args.out)
    n_jobs = max(1, args.jobs)
    facts = [file_facts(path, sarsop) for path in files]
    readable = [f for f in facts if f["parse"] == "ok"]
    out_flag = "" if args.out == config.DEFAULT_OUT else f" --out {shlex.quote(str(args.out))}"
    meta: dict[str, Any] = {
        "command": " ".join([PROG, *(shlex.quote(a) for a in argv)]),
        "run": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "machine": machine_info(),
        "commit": source_commit(),
        "data": jsonl.as_posix(),
        "report_only_command": f"{PROG} --report-only{out_flag}",
        "planned": len(readable) * len(controllers),
        "parallel": n_jobs,
        "tolerance": config.TOLERANCE,
        "controllers": controllers,
        "settings": settings,
    }
    jsonl.parent.mkdir(parents=True, exist_ok=True)
    jsonl.write_text("")  # each run rewrites the data: the report always describes one run
    for f in facts:
        append_record(jsonl, {"record": "file", **f, **meta})
    jobs = [
        {
            "file": f["file"],
            "path": str(args.data_dir / f["file"]),
            "controller": name,
            "levels": levels,
            "horizon": f["horizon"],
            "threads": None if n_jobs == 1 else 1,
            "settings": _job_settings(settings, name),
            "meta": meta,
        }
        for f in readable
        for name, levels in controllers.items()
    ]
    refused = len(facts) - len(readable)
    print(
        f"{len(jobs)} job(s): {len(readable)} file(s) × {len(controllers)} controller(s), {time_limit:g} s each"
        + (f" ({refused} file(s) refused by the reader)" if refused else "")
        + f"; {n_jobs} at a time; data {jsonl}",
        flush=True,
    )
    start = time.perf_counter()
    outcome = run_jobs(jobs, jsonl, n_jobs)
    if outcome.stopping:
        print(f"interrupted: {outcome.finished} job(s) finished and kept in {jsonl}", file=sys.stderr, flush=True)
    if outcome.failed:
        print(f"{len(outcome.failed)} job(s) failed:\n  " + "\n  ".join(outcome.failed), file=sys.stderr, flush=True)
    write_page(args.out)
    print(f"wrote {report} ({_fmt_duration(time.perf_counter() - start)})", flush=True)
    return 130 if outcome.stopping else (1 if outcome.failed else 0)
