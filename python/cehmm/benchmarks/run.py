"""Running the jobs, one at a time here or in worker processes: each finished job is appended to the data at
once and gets a progress line; the first Ctrl-C lets the running jobs finish and starts no other, a second one
abandons them."""

from __future__ import annotations

import multiprocessing
import signal
import sys
import time
from pathlib import Path
from typing import Any

from ..reproduce.records import append_record
from ..reproduce.text import _fmt_duration
from .job import ignore_sigint, run_job


class Outcome:
    """What a run of jobs came to."""

    def __init__(self, total: int) -> None:
        self.total = total
        self.finished = 0
        self.failed: list[str] = []
        self.stopping = False
        self.start = time.perf_counter()


def _value_text(record: dict[str, Any]) -> str:
    kind = "∞" if record["value_kind"] == "infinite" else f"H={record['horizon']}"
    return f"{record['value']:.4f} ({kind})"


def _handle(record: dict[str, Any], jsonl: Path, outcome: Outcome, stream: Any) -> None:
    if record.get("interrupted"):
        outcome.stopping = True
    elif "error" in record:
        message = f"{record.get('file')} · {record.get('controller')}: {record['error']}"
        outcome.failed.append(message)
        print(f"FAILED {message}", file=sys.stderr, flush=True)
    else:
        append_record(jsonl, record)
        outcome.finished += 1
        width = len(str(outcome.total))
        elapsed = _fmt_duration(time.perf_counter() - outcome.start)
        print(
            f"[{outcome.finished + len(outcome.failed):>{width}}/{outcome.total}] {record['file']} · "
            f"{record['controller']}: {_value_text(record)}  {record['iterations']} it ({record['stop_reason']})  "
            f"{record['ce_seconds']:.1f} s CE + {record['exact_seconds']:.1f} s exact  | elapsed {elapsed}",
            file=stream,
            flush=True,
        )


def run_jobs(jobs: list[dict[str, Any]], jsonl: Path, n_jobs: int, stream: Any = None) -> Outcome:
    """Runs ``jobs`` (``n_jobs`` at a time), appending each finished one to ``jsonl`` as soon as it ends."""
    stream = stream or sys.stdout
    outcome = Outcome(len(jobs))

    def on_sigint(signum: int, frame: Any) -> None:
        if outcome.stopping:
            raise KeyboardInterrupt
        outcome.stopping = True
        print("\nCtrl-C: stopping after the running job(s); Ctrl-C again to abandon them", file=sys.stderr, flush=True)

    previous = signal.signal(signal.SIGINT, on_sigint)
    try:
        if n_jobs <= 1:
            for job in jobs:
                if outcome.stopping:
                    break
                _handle(run_job(job), jsonl, outcome, stream)
        else:
            _run_pool(jobs, jsonl, n_jobs, outcome, stream)
    except KeyboardInterrupt:
        outcome.stopping = True
    finally:
        signal.signal(signal.SIGINT, previous)
    return outcome


def _run_pool(jobs: list[dict[str, Any]], jsonl: Path, n_jobs: int, outcome: Outcome, stream: Any) -> None:
    """At most ``n_jobs`` jobs handed out at a time, so that a stop leaves nothing queued; the workers ignore
    Ctrl-C, and a second Ctrl-C here terminates them (leaving the ``with``)."""
    context = multiprocessing.get_context("spawn")
    queue = list(jobs)
    running: list[Any] = []
    with context.Pool(n_jobs, initializer=ignore_sigint) as pool:
        while queue or running:
            while queue and len(running) < n_jobs and not outcome.stopping:
                running.append(pool.apply_async(run_job, (queue.pop(0),)))
            if not running:
                break
            done = [r for r in running if r.ready()]
            if not done:
                time.sleep(0.05)
                continue
            for r in done:
                running.remove(r)
                try:
                    record = r.get()
                except Exception as e:  # the record could not be sent back
                    record = {"error": f"{type(e).__name__}: {e}"}
                _handle(record, jsonl, outcome, stream)
