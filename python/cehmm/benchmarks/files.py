"""The benchmark files: which ones, what each declares (discount, values, start), SARSOP's bounds from
``SOURCES.md`` and whether a file's numbers can be compared with them."""

from __future__ import annotations

import fnmatch
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cehmm

from .._files import MAX_TEXT_BYTES, read_bytes
from .config import HORIZON_WEIGHT, horizon

#: Files SOURCES.md calls parser and regression inputs only.
REGRESSION_INPUTS = {"ejs4", "ejs5", "ejs6", "ejs7"}
#: Files that reset to the start after the goal (SOURCES.md: "Continuing versus episodic").
CONTINUING = {"hallway", "hallway2", "tiger-grid", "mini-hall2"}
#: Files whose SARSOP upper bound is loose after 300 s (SOURCES.md).
LOOSE_UB = {"tag", "tagavoid", "hallway2"}


def stem(name: str) -> str:
    """``"tiger.95"`` for ``"tiger.95.POMDP"`` (the extension in any case)."""
    return name[: -len(".pomdp")] if name.lower().endswith(".pomdp") else name


def find_files(data_dir: Path, patterns: Sequence[str] | None = None) -> list[Path]:
    """Every ``.pomdp`` file of ``data_dir`` (any case of the extension), sorted by name; with ``patterns``,
    those whose name or stem matches one of these globs (case-insensitive)."""
    files = sorted((p for p in data_dir.iterdir() if p.suffix.lower() == ".pomdp"), key=lambda p: p.name.lower())
    if not patterns:
        return files
    pats = [g.lower() for g in patterns]
    names = {p: (p.name.lower(), stem(p.name).lower()) for p in files}
    return [p for p in files if any(fnmatch.fnmatchcase(n, g) for g in pats for n in names[p])]


def scan_preamble(text: str) -> dict[str, Any]:
    """What the file itself declares: ``discount`` (None when absent), ``values`` (None when absent) and
    ``start`` (``"given"``, ``"given (include)"``, ``"given (exclude)"``, ``"uniform"`` or ``"none (uniform)"``)."""
    body = re.sub(r"#[^\n]*", "", text)
    discount = re.search(r"(?m)^\s*discount\s*:\s*([-+0-9.eE]+)", body)
    values = re.search(r"(?m)^\s*values\s*:\s*([A-Za-z]+)", body)
    start = re.search(r"(?m)^\s*start\b\s*(include|exclude)?\s*:\s*(\S+)?", body)
    if start is None:
        start_text = "none (uniform)"
    elif start.group(1):
        start_text = f"given ({start.group(1)})"
    elif start.group(2) == "uniform":
        start_text = "uniform"
    else:
        start_text = "given"
    return {
        "discount": float(discount.group(1)) if discount else None,
        "values": values.group(1) if values else None,
        "start": start_text,
    }


def parse_sarsop(sources: str) -> dict[str, dict[str, Any]]:
    """SARSOP's bounds from the table of SOURCES.md's "Computed reference values": lower-cased file stem ->
    ``{"lb", "ub", "run", "renormalised", "label"}``. Rows of variants not among the files ("ep.") are left out."""
    section = re.search(r"(?ms)^## Computed reference values.*?(?=^## |\Z)", sources)
    table: dict[str, dict[str, Any]] = {}
    if section is None:
        return table
    for line in section.group(0).splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if not line.lstrip().startswith("|") or len(cells) < 4 or "ep." in cells[0]:
            continue
        label = cells[0]
        try:
            lb, ub = (float(c.replace("\u2212", "-")) for c in cells[1:3])
        except ValueError:  # the header and the separator
            continue
        name = re.sub(r"\s*\(.*\)\s*$", "", label).rstrip("*").strip()
        table[stem(name).lower()] = {
            "lb": lb,
            "ub": ub,
            "run": cells[3],
            "renormalised": "*" in label,
            "label": label,
        }
    return table


def parse_paynt(sources: str) -> dict[str, dict[str, Any]]:
    """PAYNT/SAYNT's controller values from the table of SOURCES.md's "Controller values from PAYNT/SAYNT
    logs": lower-cased file stem -> ``{"value", "size", "run", "source"}``."""
    section = re.search(r"(?ms)^## Controller values from PAYNT.*?(?=^## |\Z)", sources)
    table: dict[str, dict[str, Any]] = {}
    for line in section.group(0).splitlines() if section else []:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if not line.lstrip().startswith("|") or len(cells) < 5:
            continue
        try:
            value, size = float(cells[1].replace("\u2212", "-")), int(cells[2])
        except ValueError:  # the header and the separator
            continue
        table[cells[0].lower()] = {"value": value, "size": size, "run": cells[3], "source": cells[4]}
    return table


def refusal_text(error: Exception, path: Path) -> str:
    """The reader's message with the file's path shortened to its name (``ejs7.POMDP:22:1: ...``)."""
    message = str(error)
    for prefix in (f"invalid model file {path}", str(path)):
        if prefix in message:
            return message.replace(prefix, path.name, 1)
    return message


def file_facts(path: Path, sarsop: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """One file's facts: sizes, discount, horizon, values, start, whether it parses, SARSOP's bounds, notes."""
    facts: dict[str, Any] = {"file": path.name, "sarsop": sarsop.get(stem(path.name).lower())}
    try:
        facts.update(scan_preamble(read_bytes(path, MAX_TEXT_BYTES, "pomdp file").decode("utf-8", errors="replace")))
        world = cehmm.PomdpWorld.from_file(path, horizon=1)
    except (cehmm.CehmmError, OSError) as e:
        facts.update(parse="refused", error=refusal_text(e, path))
        facts["comparable"], facts["notes"] = comparability(facts)
        return facts
    gamma = float(world.discount)
    facts.update(
        parse="ok",
        states=len(world.states),
        actions=len(world.actions),
        observations=len(world.observations),
        gamma=gamma,
        horizon=horizon(gamma),
        sha256=world.sha256,
    )
    facts["comparable"], facts["notes"] = comparability(facts)
    return facts


def comparability(facts: dict[str, Any]) -> tuple[str, list[str]]:
    """Whether the file's CE value can be set against SARSOP's (``"yes"``, ``"with care"``, ``"no"``) and why
    (SOURCES.md's quirks and this run's conventions)."""
    key = stem(facts["file"]).lower()
    sarsop = facts.get("sarsop")
    notes: list[str] = []
    if facts.get("parse") == "refused":
        notes.append(f"refused: {facts['error']}")
    if key in REGRESSION_INPUTS:
        notes.append("parser/regression input (SOURCES.md), not a benchmark")
    if facts.get("discount", 0) is None:
        notes.append("no discount line: γ = 1 used")
    if facts.get("gamma", 0) >= 1.0:
        notes.append("undiscounted: value at horizon H; no SARSOP value")
    if key in CONTINUING:
        notes.append("continuing: resets after the goal (the file as written, not the literature's episodic version)")
    if key in LOOSE_UB:
        notes.append("SARSOP UB loose: compare with LB")
    if sarsop and sarsop["renormalised"]:
        notes.append("SARSOP solved a renormalised copy")
    if sarsop and sarsop["run"] != "converged":
        notes.append(f"SARSOP not converged ({sarsop['run']})")
    gamma, h = facts.get("gamma"), facts.get("horizon")
    if gamma is not None and gamma < 1.0 and h is not None and gamma**h > HORIZON_WEIGHT:
        notes.append(f"trained on H = {h} steps only (γ^H = {gamma**h:.2f})")
    if facts.get("start") == "none (uniform)":
        notes.append("no start line: uniform start by convention")
    if facts.get("parse") == "refused" or sarsop is None or key in REGRESSION_INPUTS:
        verdict = "no"
    elif any(not n.startswith("no start line") for n in notes):
        verdict = "with care"
    else:
        verdict = "yes"
    return verdict, notes
