"""One job, in this process or in a worker: a controller learned on one file (by CE on episodes, or by the
CE search over deterministic controllers), then its exact value and its shape as a finite-state controller."""

from __future__ import annotations

import datetime as _dt
import os
import signal
import time
from typing import Any

import cehmm

from .config import TOLERANCE


def ignore_sigint() -> None:
    """Worker processes: Ctrl-C reaches the parent alone, which lets the running jobs finish."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def run_job(job: dict[str, Any]) -> dict[str, Any]:
    """Runs one (file, controller) job and returns its JSONL record, ``{"interrupted": True}`` when a Ctrl-C
    stopped it, or ``{"error": ...}`` when it failed."""
    try:
        return _run(job)
    except KeyboardInterrupt:
        return {"interrupted": True}
    except BaseException as e:  # a pyo3 panic is a BaseException; reported by the caller, which goes on
        if isinstance(e, (SystemExit, GeneratorExit)):
            raise
        return {"error": f"{type(e).__name__}: {e}", "file": job["file"], "controller": job["controller"]}


def _run(job: dict[str, Any]) -> dict[str, Any]:
    settings = dict(job["settings"])
    reward = settings.pop("reward")
    world = cehmm.PomdpWorld.from_file(job["path"], horizon=job["horizon"], reward=reward)
    if settings.pop("method", None) == "controller":
        searched = cehmm.optimize_controller(
            world,
            nodes=job["levels"][0],
            seed=settings["seed"],
            time_limit=settings["time_limit"],
            threads=job["threads"],
            progress=False,
        )
        if searched.interrupted:
            return {"interrupted": True}
        policy, seconds, stop_reason = searched.policy, searched.seconds, searched.stop_reason
        iterations = len(searched.history["iteration"])
        sampled = policy.evaluate(world, episodes=settings["eval_episodes"], seed=settings["seed"] + 1)
    else:
        result = cehmm.optimize(world, levels=job["levels"], threads=job["threads"], progress=False, **settings)
        if result.interrupted:
            return {"interrupted": True}
        policy, seconds, stop_reason = result.policy, result.seconds, result.stop_reason
        iterations, sampled = result.iterations, result.evaluation
    start = time.perf_counter()
    infinite = world.discount < 1.0
    exact = policy.evaluate_exact(infinite=True, tolerance=TOLERANCE) if infinite else policy.evaluate_exact()
    exact_seconds = time.perf_counter() - start
    graph = policy.graph(form="json")
    # Deterministic (exportable as .pg): one initial node, one decision and one next node each.
    deterministic = len(graph["initial"]) == 1 and all(
        len(node["decision"]) == 1 and all(len(law) == 1 for law in node["next"].values()) for node in graph["nodes"]
    )
    nodes = len(graph["nodes"])
    return {
        "record": "job",
        "file": job["file"],
        "controller": job["controller"],
        "levels": list(job["levels"]),
        "horizon": job["horizon"],
        "gamma": world.discount,
        "value": exact.value,
        "value_kind": "infinite" if infinite else "horizon",
        "tail_bound": exact.tail_bound,
        "exact_steps": exact.steps,
        "exact_seconds": round(exact_seconds, 3),
        "ce_seconds": round(seconds, 3),
        "iterations": iterations,
        "stop_reason": stop_reason,
        "sampled_mean": sampled.mean,
        "sampled_std_error": sampled.std_error,
        "deterministic": deterministic,
        "nodes": nodes,
        "threads": job["threads"] or (os.cpu_count() or 1),
        "sha256": world.sha256,
        "finished": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        **job["meta"],
        "settings": job["settings"],  # this job's own (the meta's are the common ones)
        "version": cehmm.__version__,
    }
