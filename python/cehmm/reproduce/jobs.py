"""Job identity: the rows and settings presets chosen, the keyword arguments each job runs with, its name."""

from __future__ import annotations

import fnmatch
import json
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .._files import MAX_TEXT_BYTES, read_bytes
from ..paper_table import ROWS, SETTINGS


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
        preset = json.loads(read_bytes(path, MAX_TEXT_BYTES, "settings file").decode("utf-8", errors="replace"))
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
