"""The summary: each row's records aggregated over seeds and set against the paper, and the runs' times."""

from __future__ import annotations

import datetime as _dt
from typing import Any

import numpy as np

from ..paper_table import PAPER_BEST
from .jobs import kwargs_key


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
