"""The controller search beside the anchors (``python -m cehmm.benchmarks.anchors``): every
discounted model with a published or computed reference, searched with the defaults of
``ceworld controller --pomdp FILE --time-limit T --threads 1`` (:func:`cehmm.optimize_controller`
on the file's exact values), set against SARSOP's lower bound and PAYNT/SAYNT's controllers.

The models: every discounted ``.pomdp`` file of ``data/pomdp/`` that SOURCES.md gives SARSOP's
bounds for, and every ``.pomdpx`` file of ``data/pomdpx/`` (APPL's examples, read as they are;
one past the reader's size limit is a row that says so), each compared with the bounds of the
``.pomdp`` file of the same model (:data:`SAME_MODEL`). A cell is one model at one time limit and
seed, one line of ``OUT/data/anchors.jsonl``: a cell already there is not run again, so a run cut
short goes on where it stopped; ``--jobs`` runs cells at once, one core each (the seconds are the
budget: cells beside each other share the machine). Each run rewrites the table in
``OUT/benchmarks.md`` (:mod:`~cehmm.benchmarks.anchors_report`), and ``--report-only`` rebuilds
the page from the data alone.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import multiprocessing
import sys
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import cehmm

from .._files import MAX_TEXT_BYTES, read_bytes
from ..reproduce.machine import load, machine_text, source_commit
from ..reproduce.records import append_record, read_records
from .anchors_report import ANCHORS_JSONL
from .config import DEFAULT_DATA_DIR, DEFAULT_OUT
from .files import parse_paynt, parse_sarsop, scan_preamble, stem
from .report import write_page

PROG = "python -m cehmm.benchmarks.anchors"
#: The issue's budget: ten minutes on one core.
TIME_LIMIT = 600.0
#: APPL's ``.pomdpx`` examples (data/pomdpx/SOURCES.md).
POMDPX_DIR = DEFAULT_DATA_DIR.parent / "pomdpx"
#: A ``.pomdpx`` file -> the stem of the ``.pomdp`` file whose references it takes, and why
#: (data/pomdpx/SOURCES.md: what the tests check of each).
SAME_MODEL: dict[str, tuple[str, str]] = {
    "Tiger.pomdpx": ("tiger.95", "the model of tiger.95.POMDP"),
    "Hallway.pomdpx": ("hallway", "the model of hallway.POMDP (the same T, O, start and expected rewards)"),
    "TagAvoid.pomdpx": ("tagavoid", "TagAvoid.pomdp's references: T differs in 16 of its 4,350 rows"),
    "RockSample_7_8.pomdpx": ("rocksample_7_8", "no reference here"),
}


def models(data_dir: Path, pomdpx_dir: Path, sarsop: dict[str, Any]) -> list[tuple[Path, str]]:
    """``(path, reference stem)``: the discounted ``.pomdp`` files that ``sarsop`` has bounds for,
    by name, then the ``.pomdpx`` files."""
    found: list[tuple[Path, str]] = []
    for path in sorted(data_dir.glob("*"), key=lambda p: p.name.lower()):
        key = stem(path.name).lower()
        if path.suffix.lower() != ".pomdp" or key not in sarsop:
            continue
        declared = scan_preamble(read_bytes(path, MAX_TEXT_BYTES, "pomdp file").decode("utf-8", errors="replace"))
        if (declared["discount"] or 1.0) < 1.0:
            found.append((path, key))
    found += [(p, SAME_MODEL.get(p.name, (p.stem.lower(), ""))[0]) for p in sorted(pomdpx_dir.glob("*.pomdpx"))]
    return found


def _references(data_dir: Path) -> tuple[dict[str, Any], dict[str, Any]]:
    """SARSOP's bounds and PAYNT's values, by lower-cased stem (data/pomdp/SOURCES.md)."""
    sources = data_dir / "SOURCES.md"
    text = read_bytes(sources, MAX_TEXT_BYTES, "SOURCES.md").decode() if sources.exists() else ""
    return parse_sarsop(text), parse_paynt(text)


def run_cell(path: str, time_limit: float, seed: int) -> dict[str, Any]:
    """One model searched with the defaults on one core: its record (a refusal is one too)."""
    name = Path(path).name
    record: dict[str, Any] = {"model": name, "time_limit": time_limit, "seed": seed}
    try:
        world = cehmm.PomdpWorld.from_file(path)
    except cehmm.CehmmError as e:
        return {**record, "refused": str(e).replace(str(path), name)}
    beside = load()
    started = time.perf_counter()
    found = cehmm.optimize_controller(world, time_limit=time_limit, threads=1, seed=seed, progress=False)
    return {
        **record,
        "sizes": [len(world.states), len(world.actions), len(world.observations)],
        "gamma": float(world.discount),
        "value": found.value,
        "nodes": found.policy.levels[-1],
        "seconds": time.perf_counter() - started,
        "iterations": len(found.history["iteration"]),
        "runs": len(found.run_values),
        "best_run": found.restart,
        "best_iteration": found.best_iteration,
        "start": found.start,
        "stop": found.stop_reason,
        "load": beside,
    }


def _run_all(todo: list[str], time_limit: float, seed: int, workers: int) -> Any:
    """Each cell's record as it finishes: here one after another, or in ``workers`` processes."""
    if workers == 1:
        for path in todo:
            yield run_cell(path, time_limit, seed)
        return
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        for future in as_completed([pool.submit(run_cell, path, time_limit, seed) for path in todo]):
            yield future.result()


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0] if __doc__ else None)
    p.add_argument("--files", nargs="+", metavar="NAME", help="models by file name or stem (default: every one)")
    p.add_argument("--time-limit", type=float, default=TIME_LIMIT, help="seconds of each search, on one core")
    p.add_argument("--seed", type=int, default=0, help="seed of every search")
    p.add_argument("--jobs", type=int, default=1, help="cells run at once, one core each")
    p.add_argument("--out", type=Path, default=DEFAULT_OUT, help="where data/anchors.jsonl and benchmarks.md go")
    p.add_argument("--data-dir", type=Path, default=DEFAULT_DATA_DIR, help="the .pomdp files and SOURCES.md")
    p.add_argument("--pomdpx-dir", type=Path, default=POMDPX_DIR, help="the .pomdpx files")
    p.add_argument("--report-only", action="store_true", help="run nothing: rebuild the page from the data")
    args = p.parse_args(argv)
    if args.time_limit <= 0 or args.jobs < 1:
        p.error(f"--time-limit must be positive and --jobs at least 1 (got {args.time_limit:g} and {args.jobs})")
    data = args.out / "data" / ANCHORS_JSONL
    sarsop, paynt = _references(args.data_dir)
    every = models(args.data_dir, args.pomdpx_dir, sarsop)
    if args.files:
        wanted = {f.lower() for f in args.files}
        every = [
            (path, key)
            for path, key in every
            if {path.name.lower(), stem(path.name).lower(), path.stem.lower()} & wanted
        ]
        if not every:
            p.error(f"no model named {', '.join(args.files)}")
    if not args.report_only:
        done = {(r["model"], r["time_limit"], r["seed"]) for r in read_records(data)}
        todo = [str(path) for path, _ in every if (path.name, args.time_limit, args.seed) not in done]
        stamp = {"commit": source_commit(), "date": _dt.date.today().isoformat(), "machine": machine_text()}
        print(f"{len(todo)} model(s), {args.time_limit:g} s each, {args.jobs} at a time; data {data}", flush=True)
        for found in _run_all(todo, args.time_limit, args.seed, args.jobs):
            key = next(k for path, k in every if path.name == found["model"])
            note = SAME_MODEL.get(found["model"], ("", ""))[1]
            references = {"reference": key, "note": note, "sarsop": sarsop.get(key), "paynt": paynt.get(key)}
            found = {**found, **references, **stamp}
            shown = found.get("refused") or f"{found['value']:.4f} with {found['nodes']} nodes"
            print(f"{found['model']:24} {shown}", flush=True)
            append_record(data, found)
    write_page(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
