"""One job, run here or in a worker process: the engine's optimisation, its Ctrl-C, its record."""

from __future__ import annotations

import datetime as _dt
import os
import signal
from pathlib import Path
from typing import Any

from .jobs import job_stem
from .machine import load
from .records import compact_history

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
        out_dir = Path(job["out_dir"])
        stem = job_stem(job["row"], job["settings"], job["seed"])
        # A job cut mid-run (Ctrl-C, SIGTERM, a crash) continues from its checkpoint next time.
        checkpoint = out_dir / "checkpoints" / f"{stem}.ckpt"
        checkpoint.parent.mkdir(parents=True, exist_ok=True)
        result = cehmm.optimize(
            world,
            seed=job["seed"],
            threads=job["threads"],
            progress=job["progress"],
            checkpoint=checkpoint,
            resume=True,
            **kwargs,
        )
        seconds = result.seconds  # every session of the job together
        if result.interrupted:
            return {"interrupted": True}
        policy_path = Path("policies") / f"{stem}.json"
        (out_dir / "policies").mkdir(parents=True, exist_ok=True)
        result.policy.save(out_dir / policy_path, overwrite=True)
        checkpoint.unlink(missing_ok=True)  # the record written by the caller is the job's result now
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
    ev = result.evaluation
    return {
        "row": job["row"],
        "seed": job["seed"],
        "settings": job["settings"],
        "case": job["case"],
        "levels": list(result.policy.levels),
        "kwargs": kwargs,
        "mean": ev.mean,
        "std_error": ev.std_error,
        "std": ev.std,
        "min": ev.min,
        "max": ev.max,
        "eval_episodes": ev.episodes,
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
        "load": load(),
    }
