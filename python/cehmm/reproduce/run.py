"""Running jobs: one at a time here or in a pool of worker processes, each finished one appended to the data at
once, Ctrl-C leaving nothing half done."""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
import signal
import sys
from pathlib import Path
from typing import Any

from .progress import _Progress
from .records import append_record
from .worker import _prime_engine, _worker_init, run_job


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
