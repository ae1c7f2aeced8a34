"""The tables: results.json and results.csv written from the summary, each file replaced whole."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import IO, Any

import numpy as np

from .._files import write_atomic, write_text
from ..paper_table import PAPER_BEST

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
    write_text(out_dir / "results.json", json.dumps(doc, indent=1, default=_json_default) + "\n")

    def write_csv(f: IO[Any]) -> None:
        writer = csv.DictWriter(f, fieldnames=CSV_FIELDS)
        writer.writeheader()
        for s in summary:
            line = {k: s[k] for k in CSV_FIELDS}
            line["levels"] = "x".join(map(str, s["levels"]))
            for k in ("mean", "std", "percent", "percent_std", "min", "max", "iterations_mean", "seconds_mean"):
                line[k] = f"{s[k]:.3f}"
            writer.writerow(line)

    write_atomic(out_dir / "results.csv", write_csv, newline="")


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
