"""The command line: the options of ``cehmm reproduce`` and :func:`main`, which runs the jobs and writes the
outputs."""

from __future__ import annotations

import argparse
import datetime as _dt
import shlex
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from .._files import write_text
from ..paper_table import QUICK_ROWS, QUICK_SEEDS, ROWS, SETTINGS
from .figures import make_figures, planned_figures
from .jobs import expected_kwargs, job_kwargs, kwargs_key, load_preset, parse_set, select_rows, settings_label
from .machine import machine_info, source_commit
from .records import DEFAULT_DATA, JSONL_NAME, read_records
from .report import render_report
from .run import run_jobs
from .summary import aggregate, run_stats
from .tables import write_tables
from .text import _fmt_duration, model_text


def regenerate_command(args: argparse.Namespace) -> str:
    """The ``--report-only`` command that rebuilds the outputs of ``args`` (before --quick's defaults)."""
    parts = ["cehmm reproduce --report-only"]
    if args.quick:
        parts.append("--quick")
    if args.out_dir != Path("results"):
        parts.append(f"--out-dir {shlex.quote(str(args.out_dir))}")
    for flag, value in (
        ("--data", args.data),
        ("--report", args.report),
        ("--img-dir", args.img_dir),
        ("--findings", args.findings),
        ("--rollouts", args.rollouts),
    ):
        if value is not None:
            parts.append(f"{flag} {shlex.quote(str(value))}")
    if args.rows:
        parts.append("--rows " + " ".join(shlex.quote(r) for r in args.rows))
    if args.settings != "paper":
        parts.append(f"--settings {shlex.quote(args.settings)}")
    parts.extend(f"--set {shlex.quote(o)}" for o in args.overrides)
    if args.no_figures:
        parts.append("--no-figures")
    return " ".join(parts)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="cehmm reproduce",
        description="Reproduces the paper's results table (model §5, Q-learning rows excepted): every row over "
        "several seeds, resumable, then results.json/csv, a markdown report and figures.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    p.add_argument(
        "--rows",
        nargs="+",
        metavar="ID",
        help="rows to run (ids or glob patterns, e.g. 'c3-*-strong'); default: all. --list-rows shows them",
    )
    p.add_argument("--list-rows", action="store_true", help="list the rows and exit")
    p.add_argument("--seeds", type=int, default=5, help="seeds 0..SEEDS-1 per row")
    p.add_argument(
        "--settings",
        default="paper",
        help=f"settings preset ({', '.join(SETTINGS)}) or a JSON file "
        '{"*": {...}, "row-id": {...}} of optimize() keywords',
    )
    p.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="an optimize() keyword for every row (VALUE as JSON), e.g. smoothing=0.7; part of the jobs' identity",
    )
    p.add_argument(
        "--eval-episodes",
        type=int,
        default=None,
        help="fresh episodes to evaluate each policy (default 10000; 200 with --quick)",
    )
    p.add_argument(
        "--jobs",
        type=int,
        default=1,
        help="worker processes; each runs the engine with one thread (1: one job at a time with every core)",
    )
    p.add_argument(
        "--threads", type=int, default=None, help="engine threads per job (default: every core with --jobs 1, else 1)"
    )
    p.add_argument(
        "--data",
        type=Path,
        default=None,
        help=f"the JSON-lines data, one line per finished job (default {DEFAULT_DATA}; OUT_DIR/{JSONL_NAME} "
        "with --quick)",
    )
    p.add_argument("--out-dir", type=Path, default=Path("results"), help="results.json/csv and the jobs' policies/")
    p.add_argument(
        "--report",
        type=Path,
        default=None,
        help="markdown report (default docs/results.md; OUT_DIR/results.md with --quick)",
    )
    p.add_argument("--img-dir", type=Path, default=None, help="figures (default docs/img; OUT_DIR/img with --quick)")
    p.add_argument(
        "--findings",
        type=Path,
        default=None,
        help="hand-written optimiser findings included verbatim (default: findings.md beside the report)",
    )
    p.add_argument(
        "--rollouts", type=int, default=None, help="episodes of the memory heat map (default 1000; 200 with --quick)"
    )
    p.add_argument("--no-figures", action="store_true", help="skip the figures")
    p.add_argument(
        "--no-progress",
        action="store_true",
        help="no engine progress line (it is shown only with --jobs 1 on a terminal)",
    )
    p.add_argument(
        "--report-only",
        action="store_true",
        help="run nothing: rebuild results.json/csv, the report and the figures from the data (an error if the "
        "data has no finished job for these rows and settings)",
    )
    p.add_argument(
        "--check",
        action="store_true",
        help="with --report-only: write nothing, exit 1 if the report on disk differs from the one the data gives",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help=f"smoke run: rows {', '.join(QUICK_ROWS)}, {QUICK_SEEDS} "
        "seeds, settings 'quick' (100 samples, 5 iterations, small levels)",
    )
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    command = " ".join(["cehmm reproduce", *(sys.argv[1:] if argv is None else list(argv))])
    if args.list_rows:
        for row in ROWS:
            print(
                f"{row['id']:<22} {model_text(row)}, {row['criterion']}; paper {row['paper_text']} "
                f"({row['paper_percent']:.0f} % of 69)"
            )
        return 0
    regen = regenerate_command(args)
    if args.quick:
        if not args.rows:
            args.rows = list(QUICK_ROWS)
        if "--seeds" not in (sys.argv if argv is None else argv):
            args.seeds = QUICK_SEEDS
        if args.settings == "paper":
            args.settings = "quick"
    out_dir: Path = args.out_dir
    report_path: Path = args.report or (out_dir / "results.md" if args.quick else Path("docs/results.md"))
    img_dir: Path = args.img_dir or (out_dir / "img" if args.quick else Path("docs/img"))
    findings: Path = args.findings or report_path.parent / "findings.md"
    rollouts = args.rollouts or (200 if args.quick else 1000)

    if args.check and not args.report_only:
        raise SystemExit("--check goes with --report-only")
    rows = select_rows(args.rows)
    name, preset = load_preset(args.settings)
    extra = parse_set(args.overrides)
    label = settings_label(name, extra)
    if args.eval_episodes is not None:
        extra["eval_episodes"] = args.eval_episodes
    identity = expected_kwargs(rows, preset, extra)
    jsonl: Path = args.data or (out_dir / JSONL_NAME if args.quick else DEFAULT_DATA)
    n_jobs = max(1, args.jobs)
    total_start = time.perf_counter()

    interrupted = False
    failed = 0
    if not args.report_only:
        done = {
            (r.get("row"), r.get("seed"), r.get("settings"), kwargs_key(r.get("kwargs", {})))
            for r in read_records(jsonl)
        }
        machine = machine_info()
        commit = source_commit()
        run_id = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
        threads = args.threads if args.threads is not None else (None if n_jobs == 1 else 1)
        show_engine = n_jobs == 1 and not args.no_progress and sys.stderr.isatty()
        jobs = []
        for seed in range(args.seeds):  # seed-major: every row gets a first result early
            for row in rows:
                if (row["id"], seed, label, identity[row["id"]]) in done:
                    continue
                jobs.append(
                    {
                        "row": row["id"],
                        "seed": seed,
                        "settings": label,
                        "case": row["case"],
                        "kwargs": job_kwargs(row, preset, extra),
                        "threads": threads,
                        "progress": show_engine,
                        "out_dir": str(out_dir),
                        "run": run_id,
                        "command": command,
                        "machine": machine,
                        "commit": commit,
                    }
                )
        skipped = len(rows) * args.seeds - len(jobs)
        print(
            f"{len(jobs)} job(s) to run ({len(rows)} rows × {args.seeds} seeds, settings {label!r}, "
            f"{skipped} already in {jsonl}); {n_jobs} at a time",
            flush=True,
        )
        if jobs:
            outcome = run_jobs(jobs, jsonl, n_jobs)
            interrupted = outcome.interrupted
            failed = len(outcome.failed)
            if interrupted:
                print(
                    f"interrupted: {outcome.finished} job(s) finished and kept in {jsonl}; run the same command "
                    "to resume",
                    file=sys.stderr,
                    flush=True,
                )
            if failed:
                print(f"{failed} job(s) failed:\n  " + "\n  ".join(outcome.failed), file=sys.stderr, flush=True)

    records = read_records(jsonl)
    summary = aggregate(records, rows, label, identity)
    if args.report_only and not summary:
        print(
            f"cehmm reproduce: error: {jsonl} has no finished job of settings {label!r} for the rows asked "
            "(with these settings' keyword arguments); run without --report-only first",
            file=sys.stderr,
        )
        return 2
    used = [r for s in summary for r in s["runs"]]
    meta = {
        "generated": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "settings": label,
        "machine": machine_info(),
        "command": command,
        **run_stats(used),
    }
    figures = {name: img_dir / f"{name}.png" for name in planned_figures(summary)}
    text = render_report(summary, used, label, report_path, figures, findings, regen, rollouts)
    if args.check:
        current = report_path.read_text() if report_path.exists() else None
        if current != text:
            print(f"{report_path} is not what {jsonl} gives: run {regen}", file=sys.stderr)
            return 1
        print(f"{report_path} is what {jsonl} gives")
        return 0
    write_tables(summary, meta, out_dir)
    drawn = {} if args.no_figures else make_figures(summary, out_dir, img_dir, rollouts=rollouts)
    write_text(report_path, text)
    print(
        f"wrote {out_dir / 'results.json'}, {out_dir / 'results.csv'}, {report_path}"
        + (f" and {len(drawn)} figure(s) in {img_dir}" if drawn else "")
        + f" ({_fmt_duration(time.perf_counter() - total_start)})",
        flush=True,
    )
    return 130 if interrupted else (1 if failed else 0)
