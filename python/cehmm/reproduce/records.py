"""The JSON-lines data: one record per finished job, read back whole and appended one line at a time."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from .._files import MAX_TEXT_BYTES, read_bytes

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


def compact_history(history: dict[str, np.ndarray]) -> dict[str, list[float]]:
    """The per-iteration statistics a record keeps (4 decimals: a mean over N >= 100 episodes of a
    whole-number reward needs no more for a figure)."""
    return {k: [round(float(x), 4) for x in history[k]] for k in HISTORY_KEYS}


def read_records(path: Path) -> list[dict[str, Any]]:
    """Every complete line of the JSONL file (a torn last line, from a killed run, is skipped)."""
    records = []
    if not path.exists():
        return records
    for line in read_bytes(path, MAX_TEXT_BYTES, "records file").decode("utf-8", errors="replace").splitlines():
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
