"""Reproduces the paper's results table (model §5, Q-learning rows excepted) and writes a report.

Every row of the table is run over several seeds; each (row, seed, settings) job optimises a
policy, evaluates it on fresh episodes and appends one line to a JSON-lines file (the data, by
default ``docs/data/reproduce.jsonl``, committed), so that a run can be stopped (Ctrl-C) and
resumed. A job is identified by its row, seed, settings label *and* the exact keyword arguments
it ran with: a preset whose settings change runs again. From the data come ``results.json``,
``results.csv``, a markdown report (``docs/results.md`` by default) and its figures
(``docs/img/``); ``--report-only`` rebuilds them from the data alone (a figure that needs a
policy no longer on disk replays its job, which is deterministic).

Usage::

    python -m cehmm.reproduce                      # every row, 5 seeds, the paper's settings
    cehmm reproduce --seeds 3 --jobs 2             # 2 worker processes of 1 thread each
    cehmm reproduce --rows 'c3-*-strong'           # a subset of rows (ids or glob patterns)
    cehmm reproduce --set smoothing=0.7            # any optimize() keyword, for every row
    cehmm reproduce --report-only                  # rebuild the outputs from the JSONL only
    cehmm reproduce --report-only --check          # exit 1 if docs/results.md is not what the data gives
    cehmm reproduce --quick --out-dir /tmp/q       # a seconds-long smoke run

Rows (:data:`ROWS`) and settings presets (:data:`SETTINGS`) are plain data: a new preset is a new
entry of :data:`SETTINGS` (or a JSON file given to ``--settings``), mapping ``"*"`` (every row)
and row ids to keyword arguments of :func:`cehmm.optimize`, passed through unchanged.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import csv
import datetime as _dt
import fnmatch
import json
import multiprocessing
import os
import platform
import re
import shlex
import signal
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .paper_table import PAPER_BEST, QUICK_ROWS, QUICK_SEEDS, ROWS, SETTINGS

#: Keys of every JSONL line (one finished job).
RECORD_KEYS = (
    "row",
    "seed",
    "settings",
    "case",
    "levels",
    "kwargs",
    "mean",
    "std_error",
    "std",
    "min",
    "max",
    "eval_episodes",
    "best_mean",
    "iterations",
    "best_iteration",
    "stop_reason",
    "seconds",
    "threads",
    "policy",
    "history",
    "commit",
    "finished",
    "run",
    "command",
    "machine",
    "version",
)

JSONL_NAME = "reproduce.jsonl"
#: Where the data the committed reports are built from lives (relative to the working directory).
DEFAULT_DATA = Path("docs") / "data" / JSONL_NAME
#: Per-iteration statistics kept in each record (rounded: they are for the learning-curve figure).
HISTORY_KEYS = ("mean", "elite_threshold", "best")


# -- rows and settings -----------------------------------------------------------------------------


def rows_by_id() -> dict[str, dict[str, Any]]:
    return {row["id"]: row for row in ROWS}


def select_rows(patterns: Sequence[str] | None) -> list[dict[str, Any]]:
    """The rows whose id matches one of ``patterns`` (ids or glob patterns), in table order."""
    if not patterns:
        return list(ROWS)
    chosen = [row for row in ROWS if any(fnmatch.fnmatchcase(row["id"], p) for p in patterns)]
    unknown = [p for p in patterns if not any(fnmatch.fnmatchcase(row["id"], p) for row in ROWS)]
    if unknown:
        raise SystemExit(f"unknown row(s) {', '.join(unknown)}; rows are: {', '.join(r['id'] for r in ROWS)}")
    return chosen


def load_preset(name: str) -> tuple[str, dict[str, dict[str, Any]]]:
    """A preset by name, or from a JSON file ``{"*": {...}, "row-id": {...}}`` (named after the file)."""
    if name in SETTINGS:
        return name, SETTINGS[name]
    path = Path(name)
    if path.suffix == ".json" and path.is_file():
        preset = json.loads(path.read_text())
        if not isinstance(preset, dict) or not all(isinstance(v, dict) for v in preset.values()):
            raise SystemExit(f'{path}: expected {{"*": {{...}}, "row-id": {{...}}}} of optimize() keywords')
        return path.stem, preset
    raise SystemExit(f"unknown settings {name!r}: presets are {', '.join(SETTINGS)} (or a .json file)")


def job_kwargs(row: dict[str, Any], preset: dict[str, dict[str, Any]], extra: dict[str, Any]) -> dict[str, Any]:
    """The keyword arguments of :func:`cehmm.optimize` for ``row``: row < preset["*"] < preset[row] < extra."""
    kwargs: dict[str, Any] = {"levels": list(row["levels"]), **row["optimize"]}
    kwargs.update(preset.get("*", {}))
    kwargs.update(preset.get(row["id"], {}))
    kwargs.update(extra)
    return kwargs


def parse_set(items: Sequence[str]) -> dict[str, Any]:
    """``["smoothing=0.7", "levels=[8,8]"]`` -> ``{"smoothing": 0.7, "levels": [8, 8]}`` (values as JSON)."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise SystemExit(f"--set {item!r}: expected KEY=VALUE")
        try:
            out[key.strip()] = json.loads(value)
        except json.JSONDecodeError:
            out[key.strip()] = value
    return out


def settings_label(name: str, extra: dict[str, Any]) -> str:
    """The settings part of a job's identity: the preset name, then each ``--set`` override."""
    parts = [name] + [f"{k}={json.dumps(v, separators=(',', ':'))}" for k, v in sorted(extra.items())]
    return "+".join(parts)


def kwargs_key(kwargs: dict[str, Any]) -> str:
    """The keyword arguments of a job as canonical JSON: part of the job's identity."""
    return json.dumps(kwargs, sort_keys=True, separators=(",", ":"))


def expected_kwargs(
    rows: list[dict[str, Any]], preset: dict[str, dict[str, Any]], extra: dict[str, Any]
) -> dict[str, str]:
    """Row id -> the canonical keyword arguments its jobs must have run with."""
    return {row["id"]: kwargs_key(job_kwargs(row, preset, extra)) for row in rows}


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_")


def job_stem(row_id: str, settings: str, seed: int) -> str:
    return f"{row_id}__{_slug(settings)}__s{seed}"


# -- the machine -----------------------------------------------------------------------------------


def machine_info() -> dict[str, Any]:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.lower().startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {
        "cpu": cpu,
        "cores": os.cpu_count() or 1,
        "os": f"{platform.system()} {platform.release()}",
        "python": platform.python_version(),
    }


# -- one job ---------------------------------------------------------------------------------------


def source_commit() -> str:
    """The git commit of the code that runs (``-dirty`` when tracked files differ from it), or
    ``"unknown"`` outside a git checkout."""
    root = Path(__file__).resolve().parents[2]
    try:
        head = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "--short=12", "HEAD"], capture_output=True, text=True, timeout=10
        )
        if head.returncode != 0:
            return "unknown"
        dirty = subprocess.run(
            ["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=10,
        )
        return head.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def compact_history(history: dict[str, np.ndarray]) -> dict[str, list[float]]:
    """The per-iteration statistics a record keeps (4 decimals: a mean over N >= 100 episodes of a
    whole-number reward needs no more for a figure)."""
    return {k: [round(float(x), 4) for x in history[k]] for k in HISTORY_KEYS}


_IN_JOB = False
_STOPPING = False


def _prime_engine() -> None:
    """Makes the engine create a numpy array once, before any job.

    The compiled module looks numpy's C API up (a Python import) the first time it returns an
    array; a KeyboardInterrupt pending at that moment makes it panic instead of returning the
    interrupted result. Doing it here, outside any job, removes that window.
    """
    import cehmm

    cehmm.Policy.uniform(cehmm.TargetTracking(case=1), [1]).tables  # noqa: B018


def _worker_init() -> None:
    """Worker processes: the first Ctrl-C of a job stops its optimisation (the engine returns it,
    marked interrupted); later ones, and any between jobs, are ignored so the pool is not broken."""

    def handler(signum: int, frame: Any) -> None:
        global _STOPPING
        if _IN_JOB and not _STOPPING:
            _STOPPING = True
            raise KeyboardInterrupt

    signal.signal(signal.SIGINT, handler)
    _prime_engine()


def run_job(job: dict[str, Any]) -> dict[str, Any]:
    """Runs one (row, seed, settings) job and returns its JSONL record, or ``{"interrupted": True}``.

    Writes the policy (model §6 JSON) under ``job["out_dir"]``; the record holds the history.
    """
    global _IN_JOB, _STOPPING
    import cehmm

    _IN_JOB, _STOPPING = True, False
    try:
        world = cehmm.TargetTracking(case=job["case"])
        kwargs = dict(job["kwargs"])
        start = time.perf_counter()
        result = cehmm.optimize(world, seed=job["seed"], threads=job["threads"], progress=job["progress"], **kwargs)
        seconds = time.perf_counter() - start
        if result.interrupted:
            return {"interrupted": True}
        out_dir = Path(job["out_dir"])
        stem = job_stem(job["row"], job["settings"], job["seed"])
        policy_path = Path("policies") / f"{stem}.json"
        (out_dir / "policies").mkdir(parents=True, exist_ok=True)
        result.policy.save(out_dir / policy_path)
    except KeyboardInterrupt:
        return {"interrupted": True}
    except BaseException as e:  # a pyo3 panic is a BaseException; reported by the parent, which goes on
        if isinstance(e, (SystemExit, GeneratorExit)):
            raise
        if _STOPPING:
            return {"interrupted": True}
        return {"error": f"{type(e).__name__}: {e}", "row": job["row"], "seed": job["seed"]}
    finally:
        _IN_JOB = False
    e = result.evaluation
    return {
        "row": job["row"],
        "seed": job["seed"],
        "settings": job["settings"],
        "case": job["case"],
        "levels": list(result.policy.levels),
        "kwargs": kwargs,
        "mean": e.mean,
        "std_error": e.std_error,
        "std": e.std,
        "min": e.min,
        "max": e.max,
        "eval_episodes": e.episodes,
        "best_mean": result.best_mean,
        "iterations": result.iterations,
        "best_iteration": result.best_iteration,
        "stop_reason": result.stop_reason,
        "seconds": round(seconds, 3),
        "threads": job["threads"] or (os.cpu_count() or 1),
        "policy": policy_path.as_posix(),
        "history": compact_history(result.history),
        "commit": job["commit"],
        "finished": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "run": job["run"],
        "command": job["command"],
        "machine": job["machine"],
        "version": cehmm.__version__,
        "load": _load(),
    }


def _load() -> float | None:
    """The 1-minute load average (other work on the machine slows the jobs down)."""
    try:
        return round(os.getloadavg()[0], 2)
    except (OSError, AttributeError):
        return None


# -- the JSONL file --------------------------------------------------------------------------------


def read_records(path: Path) -> list[dict[str, Any]]:
    """Every complete line of the JSONL file (a torn last line, from a killed run, is skipped)."""
    records = []
    if not path.exists():
        return records
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line:
                continue
            try:
                records.append(json.loads(line))
            except json.JSONDecodeError:
                continue
    return records


def append_record(path: Path, record: dict[str, Any]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a") as f:
        f.write(json.dumps(record, separators=(",", ":")) + "\n")
        f.flush()
        os.fsync(f.fileno())


# -- running ---------------------------------------------------------------------------------------


def _fmt_duration(seconds: float) -> str:
    seconds = max(0.0, seconds)
    if seconds < 60:
        return f"{seconds:.0f}s"
    minutes, s = divmod(int(round(seconds)), 60)
    if minutes < 60:
        return f"{minutes}m{s:02d}s"
    hours, m = divmod(minutes, 60)
    return f"{hours}h{m:02d}m"


class _Progress:
    """One line per finished job, with the count and an ETA from the finished jobs' times."""

    def __init__(self, jobs: list[dict[str, Any]], parallel: int, stream: Any = None) -> None:
        self.pending = {(j["row"], j["seed"]) for j in jobs}
        self.rows = {j["row"]: j for j in jobs}
        self.total = len(jobs)
        self.done = 0
        self.parallel = max(1, parallel)
        self.times: dict[str, list[float]] = {}
        self.start = time.perf_counter()
        self.stream = stream or sys.stdout

    def finished(self, record: dict[str, Any]) -> None:
        self.done += 1
        self.pending.discard((record["row"], record["seed"]))
        self.times.setdefault(record["row"], []).append(record["seconds"])
        every = [t for ts in self.times.values() for t in ts]
        overall = sum(every) / len(every)
        left = sum(np.mean(self.times[row]) if row in self.times else overall for row, _ in self.pending)
        eta = left / self.parallel
        width = len(str(self.total))
        print(
            f"[{self.done:>{width}}/{self.total}] {record['row']:<20} seed {record['seed']}: "
            f"{record['mean']:6.2f} ± {record['std_error']:.2f}  {record['iterations']:5d} it "
            f"(best {record['best_iteration']}, {record['stop_reason']})  {record['seconds']:6.1f} s"
            f"  | elapsed {_fmt_duration(time.perf_counter() - self.start)}, ETA {_fmt_duration(eta)}",
            file=self.stream,
            flush=True,
        )


class _Outcome:
    """What a run of jobs came to."""

    def __init__(self) -> None:
        self.finished = 0
        self.failed: list[str] = []
        self.interrupted = False


def run_jobs(jobs: list[dict[str, Any]], jsonl: Path, n_jobs: int) -> _Outcome:
    """Runs ``jobs``, appending each finished one to ``jsonl`` as soon as it ends."""
    progress = _Progress(jobs, n_jobs)
    outcome = _Outcome()

    def handle(record: dict[str, Any]) -> None:
        if record.get("interrupted"):
            outcome.interrupted = True
        elif "error" in record:
            message = f"{record.get('row')} seed {record.get('seed')}: {record['error']}"
            outcome.failed.append(message)
            print(f"FAILED {message}", file=sys.stderr, flush=True)
        else:
            append_record(jsonl, record)
            outcome.finished += 1
            progress.finished(record)

    if n_jobs <= 1:
        try:
            _prime_engine()
            for job in jobs:
                handle(run_job(job))
                if outcome.interrupted:
                    break
        except KeyboardInterrupt:
            outcome.interrupted = True
        return outcome

    # At most one job per worker is handed out at a time, so that Ctrl-C leaves nothing queued:
    # the running jobs see the same Ctrl-C (or the one forwarded to them) and return at once.
    context = multiprocessing.get_context("spawn")
    executor = cf.ProcessPoolExecutor(max_workers=n_jobs, mp_context=context, initializer=_worker_init)
    queue = list(reversed(jobs))
    running: set[cf.Future] = set()

    def collect(done: set[cf.Future]) -> None:
        for future in done:
            try:
                record = future.result()
            except Exception as e:  # a worker died (BrokenProcessPool) or its error could not be sent back
                record = {"error": f"{type(e).__name__}: {e}"}
            handle(record)

    try:
        while queue or running:
            while queue and len(running) < n_jobs and not outcome.interrupted:
                running.add(executor.submit(run_job, queue.pop()))
            if not running:
                break
            done, running = cf.wait(running, return_when=cf.FIRST_COMPLETED)
            collect(done)
    except KeyboardInterrupt:
        outcome.interrupted = True
        # Pass the Ctrl-C on, in case it reached this process only (a second one is ignored there).
        for process in list(getattr(executor, "_processes", {}).values()):
            try:
                os.kill(process.pid, signal.SIGINT)
            except (OSError, AttributeError):
                pass
        try:
            done, _ = cf.wait(running)
            collect(done)
        except KeyboardInterrupt:
            pass
    finally:
        executor.shutdown(wait=True, cancel_futures=True)
    return outcome


# -- aggregation -----------------------------------------------------------------------------------


def status_text(ours: float, paper: float) -> str:
    if ours >= paper:
        return "≥ paper"
    gap = paper - ours
    return f"below paper by {gap:.1f} ({100.0 * gap / PAPER_BEST:.1f} pp)"


def aggregate(
    records: list[dict[str, Any]], rows: list[dict[str, Any]], settings: str, kwargs: dict[str, str]
) -> list[dict[str, Any]]:
    """One summary per row (rows without any finished job are left out), runs sorted by seed.

    Only the records of ``settings`` whose keyword arguments are ``kwargs[row]`` (see
    :func:`expected_kwargs`) count: a record made with other settings under the same label is stale.
    """
    out = []
    for row in rows:
        runs = sorted(
            (
                r
                for r in records
                if r.get("row") == row["id"]
                and r.get("settings") == settings
                and kwargs_key(r.get("kwargs", {})) == kwargs[row["id"]]
            ),
            key=lambda r: r["seed"],
        )
        # The last line of a (row, seed) wins, should a job have been recorded twice.
        runs = list({r["seed"]: r for r in runs}.values())
        if not runs:
            continue
        means = np.array([r["mean"] for r in runs], dtype=float)
        std = float(means.std(ddof=1)) if len(means) > 1 else 0.0
        mean = float(means.mean())
        out.append(
            {
                "row": row["id"],
                "title": row["title"],
                "group": row["group"],
                "case": row["case"],
                "levels": runs[0]["levels"],
                "criterion": row["criterion"],
                "settings": settings,
                "kwargs": runs[0]["kwargs"],
                "seeds": len(runs),
                "paper_reward": row["paper_reward"],
                "paper_percent": row["paper_percent"],
                "paper_text": row["paper_text"],
                "mean": mean,
                "std": std,
                "percent": 100.0 * mean / PAPER_BEST,
                "percent_std": 100.0 * std / PAPER_BEST,
                "min": float(means.min()),
                "max": float(means.max()),
                "iterations_mean": float(np.mean([r["iterations"] for r in runs])),
                "seconds_mean": float(np.mean([r["seconds"] for r in runs])),
                "status": status_text(mean, row["paper_reward"]),
                "commits": sorted({r.get("commit", "unknown") for r in runs}),
                "note": row["note"],
                "runs": runs,
            }
        )
    return out


CSV_FIELDS = [
    "row",
    "title",
    "case",
    "levels",
    "criterion",
    "settings",
    "seeds",
    "paper_reward",
    "paper_percent",
    "mean",
    "std",
    "percent",
    "percent_std",
    "min",
    "max",
    "iterations_mean",
    "seconds_mean",
    "status",
]


def write_tables(summary: list[dict[str, Any]], meta: dict[str, Any], out_dir: Path) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    doc = {**meta, "paper_best": PAPER_BEST, "rows": summary}
    _write_text(out_dir / "results.json", json.dumps(doc, indent=1, default=_json_default) + "\n")
    tmp = out_dir / ".results.csv.tmp"
    with open(tmp, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=CSV_FIELDS)
        writer.writeheader()
        for s in summary:
            line = {k: s[k] for k in CSV_FIELDS}
            line["levels"] = "x".join(map(str, s["levels"]))
            for k in ("mean", "std", "percent", "percent_std", "min", "max", "iterations_mean", "seconds_mean"):
                line[k] = f"{s[k]:.3f}"
            writer.writerow(line)
    os.replace(tmp, out_dir / "results.csv")


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def _write_text(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


# -- the report ------------------------------------------------------------------------------------


def _repo_root() -> Path | None:
    here = Path(__file__).resolve().parents[2]
    for root in (here, Path.cwd()):
        if (root / "docs" / "engine-results.md").exists():
            return root
    return None


def _rel(target: Path, start: Path) -> str:
    return Path(os.path.relpath(target.resolve(), start.resolve())).as_posix()


def _link(target: Path, report_dir: Path) -> str:
    """A link from the report to ``target``: relative when both are in one tree, else absolute."""
    target, report_dir = target.resolve(), report_dir.resolve()
    rel = os.path.relpath(target, report_dir)
    return Path(rel).as_posix() if not rel.startswith(os.pardir + os.sep + os.pardir) else target.as_posix()


def run_stats(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Total job time and elapsed wall time of the runs that produced ``records``."""
    runs: dict[str, list[dict[str, Any]]] = {}
    for r in records:
        runs.setdefault(r.get("run", "?"), []).append(r)
    elapsed = 0.0
    for run, rs in runs.items():
        try:
            start = _dt.datetime.fromisoformat(run)
            end = max(_dt.datetime.fromisoformat(r["finished"]) for r in rs)
            elapsed += (end - start).total_seconds()
        except (ValueError, KeyError, TypeError):
            elapsed += sum(r.get("seconds", 0.0) for r in rs)
    return {
        "job_seconds": float(sum(r.get("seconds", 0.0) for r in records)),
        "elapsed_seconds": elapsed,
        "runs": len(runs),
        "jobs": len(records),
    }


def model_text(row: dict[str, Any]) -> str:
    """``"case 3, Λ = 2, [16,16]"``: a row's title with its levels."""
    return f"{row['title']}, [{','.join(map(str, row['levels']))}]"


def _pm(mean: float, std: float, digits: int = 2) -> str:
    return f"{mean:.{digits}f} ± {std:.{digits}f}"


def render_report(
    summary: list[dict[str, Any]],
    records: list[dict[str, Any]],
    settings: str,
    report_path: Path,
    figures: dict[str, Path],
    findings_path: Path | None,
    regenerate: str,
    rollouts: int = 1000,
) -> str:
    report_dir = report_path.parent
    stats = run_stats(records)
    machines = {json.dumps(r.get("machine", {}), sort_keys=True) for r in records}
    commands = sorted({r.get("command", "") for r in records if r.get("command")})
    threads = sorted({r.get("threads") for r in records if r.get("threads")})
    root = _repo_root()
    lines: list[str] = []
    add = lines.append
    add("# Results: the paper's table reproduced")
    add("")
    add(
        "Generated by `cehmm reproduce` (python/cehmm/reproduce.py) from its JSON-lines file; do not edit by "
        "hand, regenerate it. Every figure of ours is the mean reward of the returned policy (the best "
        "iteration's) **evaluated on fresh episodes**, then the mean ± standard deviation over seeds. The "
        "paper's percentages are of 69, its best case-3 reward (model §5); ours are given the same way."
    )
    add("")
    eval_eps = sorted({r.get("eval_episodes") for r in records if r.get("eval_episodes")})

    def _text(kw: dict[str, Any]) -> str:
        return ", ".join(f"{k} = {v}" for k, v in kw.items() if k not in ("levels", "patience"))

    # The settings shared by most rows, then each row that differs from them.
    texts = [_text(r["kwargs"]) for r in summary]
    common = max(set(texts), key=texts.count) if texts else ""
    add(f"- **Settings**: `{settings}` ({common}; patience 100 for the weak criterion, 500 for the strong).")
    for r, text in zip(summary, texts):
        if text != common:
            add(f"  - `{r['row']}`: {text}, levels {r['levels']}.")
    add(f"- **Evaluation**: {', '.join(f'{e:,}' for e in eval_eps)} fresh episodes per policy.")
    add(
        f"- **Jobs**: {stats['jobs']} (row × seed), {stats['runs']} invocation(s); total job time "
        f"{_fmt_duration(stats['job_seconds'])}, elapsed {_fmt_duration(stats['elapsed_seconds'])}."
    )
    for m in sorted(machines):
        info = json.loads(m)
        if info:
            add(
                f"- **Machine**: {info.get('cpu', '?')}, {info.get('cores', '?')} cores, {info.get('os', '?')}, "
                f"Python {info.get('python', '?')}; engine threads per job: {', '.join(map(str, threads))}."
            )
    loads = [r["load"] for r in records if r.get("load") is not None]
    if loads:
        add(
            f"- **Load**: 1-minute load average at the end of the jobs {min(loads):.1f}–{max(loads):.1f} (mean "
            f"{np.mean(loads):.1f}); above the number of cores, other work was running beside the jobs."
        )
    for c in commands:
        add(f"- **Command**: `{c}`")
    add(f"- **Regenerate this report** from the JSONL without running anything: `{regenerate}`")
    add("")
    add("## The table")
    add("")
    add(
        "| row | model | criterion | paper | paper % | ours (mean ± std over seeds) | ours % | seeds | iterations "
        "| wall (s) | status | commit |"
    )
    add("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for s in summary:
        add(
            f"| `{s['row']}` | {model_text(s)} | {s['criterion']} | {s['paper_text']} | {s['paper_percent']:.0f} % | "
            f"{_pm(s['mean'], s['std'])} | {_pm(s['percent'], s['percent_std'], 1)} % | {s['seeds']} | "
            f"{s['iterations_mean']:.0f} | {s['seconds_mean']:.1f} | {s['status']} | {', '.join(s['commits'])} |"
        )
    add("")
    add(
        "*paper*: the paper's reward (case 1, case 2) or 69 × its percentage (case 3); *iterations* and "
        "*wall* are means over seeds, wall time per job including the evaluation. *status* compares the "
        "mean over seeds with the paper's figure (pp: percentage points of 69). *commit*: the code that "
        "ran the row's jobs (`-dirty`: with uncommitted changes)."
    )
    notes = [s for s in summary if s["note"]]
    if notes:
        add("")
        for s in notes:
            add(f"- `{s['row']}`: {s['note']}.")
    add("")
    add("## Per seed")
    add("")
    add(
        "| row | seed | evaluated mean ± s.e. | best iteration's mean | iterations | best iteration | stop | wall (s) |"
    )
    add("|---|---|---|---|---|---|---|---|")
    for s in summary:
        for r in s["runs"]:
            add(
                f"| `{s['row']}` | {r['seed']} | {r['mean']:.2f} ± {r['std_error']:.2f} | {r['best_mean']:.2f} | "
                f"{r['iterations']} | {r['best_iteration']} | {r['stop_reason']} | {r['seconds']:.1f} |"
            )
    if figures:
        add("")
        add("## Figures")
        captions = {
            "summary": "Ours (mean ± std over seeds, dots: each seed) against the paper, in % of 69.",
            "learning_curves": "Learning curves of the case-3 rows (seed 0): mean reward, elite threshold and "
            "best reward of each iteration; dotted: the paper's figure; vertical line: the best iteration.",
            "trajectory": "A stretch of one episode of the best case-3 policy, in the spirit of the paper's "
            "*Near-optimal control sequence*: × target, • observer 1 (B), ○ observer 2 (C); relative "
            "times next to the points.",
            "memory": f"How the learned memory is used: frequency of (m₁, y) and of (m₁, m₂) over {rollouts} "
            "episodes of the best two-level case-3 policy ([16,16] when run); blank: never visited.",
        }
        for name, path in figures.items():
            add("")
            add(f"![{name}]({_rel(path, report_dir)})")
            add("")
            add(captions.get(name, name))
    add("")
    add("## Findings")
    add("")
    if root is not None:
        link = _link(root / "docs" / "engine-results.md", report_dir)
        add(
            f"The engine's first measurements and findings (case 1's memoryless limit of 83, case 2's stall with "
            f"basic CE, the determinism check) are in [docs/engine-results.md]({link})."
        )
    else:
        add("The engine's first measurements and findings are in docs/engine-results.md.")
    add("")
    add("## Optimiser findings")
    add("")
    if findings_path is not None and findings_path.is_file():
        add(findings_path.read_text().rstrip())
    else:
        where = "docs/findings.md" if findings_path is None else findings_path.as_posix()
        add(f"*None yet: this section reproduces `{where}` verbatim once that hand-written file exists.*")
    add("")
    return "\n".join(lines)


# -- figures ---------------------------------------------------------------------------------------


def planned_figures(summary: list[dict[str, Any]]) -> list[str]:
    """The figures a report of ``summary`` shows: decided by the data alone, so that the report's
    text does not depend on whether they were (re)drawn this time."""
    case3 = [s for s in summary if s["case"] == 3]
    names = ["summary"] if summary else []
    if case3:
        names += ["learning_curves", "trajectory"]
    if any(len(s["levels"]) >= 2 for s in case3):
        names.append("memory")
    return names


def job_policy(run: dict[str, Any], out_dir: Path) -> Any:
    """The policy of a finished job: its file under ``out_dir``, or else the job replayed (it is
    deterministic: same seed and settings, same policy whatever the thread count)."""
    import cehmm

    path = out_dir / run["policy"]
    if path.exists():
        return cehmm.Policy.load(path)
    print(f"replaying {run['row']} seed {run['seed']} for its policy ({path} is not here)", file=sys.stderr, flush=True)
    result = cehmm.optimize(cehmm.TargetTracking(case=run["case"]), seed=run["seed"], progress=False, **run["kwargs"])
    if result.evaluation.mean != run["mean"]:
        print(
            f"warning: the replay of {run['row']} seed {run['seed']} evaluates to {result.evaluation.mean}, the record "
            f"says {run['mean']} (recorded at commit {run.get('commit', 'unknown')})",
            file=sys.stderr,
            flush=True,
        )
    path.parent.mkdir(parents=True, exist_ok=True)
    result.policy.save(path)
    return result.policy


def make_figures(summary: list[dict[str, Any]], out_dir: Path, img_dir: Path, rollouts: int = 1000) -> dict[str, Path]:
    """Draws the figures of :func:`planned_figures` as PNG files; returns {name: path}. Needs
    matplotlib (warns and draws nothing without it)."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        print("matplotlib is not installed: no figures (pip install 'cehmm[plot]')", file=sys.stderr)
        return {}
    import cehmm

    from . import plots

    planned = planned_figures(summary)
    img_dir.mkdir(parents=True, exist_ok=True)
    written: dict[str, Path] = {}

    def save(name: str, fig: Any) -> None:
        path = img_dir / f"{name}.png"
        tmp = img_dir / f".{name}.tmp.png"
        fig.savefig(tmp, dpi=110)
        os.replace(tmp, path)
        written[name] = path

    if "summary" in planned:
        save("summary", plots.summary_bars(summary, paper_best=PAPER_BEST))

    case3 = [s for s in summary if s["case"] == 3]
    if "learning_curves" in planned:
        curves = []
        for s in case3:
            run = min(s["runs"], key=lambda r: r["seed"])
            history = {k: np.asarray(v) for k, v in run["history"].items()}
            history["iteration"] = np.arange(len(history["mean"]))
            curves.append(
                {
                    "title": f"{model_text(s)}, {s['criterion']} (seed {run['seed']})",
                    "history": history,
                    "paper": s["paper_reward"],
                    "best_iteration": run["best_iteration"],
                }
            )
        save("learning_curves", plots.learning_curves(curves))

    def best_policy(candidates: list[dict[str, Any]]) -> tuple[Any, dict[str, Any]]:
        r, s = max(((r, s) for s in candidates for r in s["runs"]), key=lambda rs: rs[0]["mean"])
        return job_policy(r, out_dir), {**r, "title": f"{model_text(s)}, {s['criterion']}"}

    world = cehmm.TargetTracking(case=3)
    if "trajectory" in planned:
        policy, run = best_policy(case3)
        title = f"{run['title']}, seed {run['seed']} (evaluated mean {run['mean']:.1f})"
        save("trajectory", plots.trajectory(policy, world, title=title))
    if "memory" in planned:
        two_level = [s for s in case3 if list(s["levels"]) == [16, 16]] or [s for s in case3 if len(s["levels"]) >= 2]
        policy, run = best_policy(two_level)
        title = f"{run['title']}, seed {run['seed']} (evaluated mean {run['mean']:.1f})"
        save("memory", plots.memory_heatmap(policy, world, episodes=rollouts, title=title))
    return written


# -- the command -----------------------------------------------------------------------------------


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
    _write_text(report_path, text)
    print(
        f"wrote {out_dir / 'results.json'}, {out_dir / 'results.csv'}, {report_path}"
        + (f" and {len(drawn)} figure(s) in {img_dir}" if drawn else "")
        + f" ({_fmt_duration(time.perf_counter() - total_start)})",
        flush=True,
    )
    return 130 if interrupted else (1 if failed else 0)


if __name__ == "__main__":
    sys.exit(main())
