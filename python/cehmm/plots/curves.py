"""Learning curves: of a run, of several on one axes, of the reproduction's panels, and the
reproduction's summary bars; histories read back from their files."""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import _core
from ._figure import figure

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure


def read_history(path: str | Path) -> dict[str, np.ndarray]:
    """The history a run saved (``--history FILE.jsonl`` or ``FILE.csv``) as columns, one numpy
    array per field, as :attr:`cehmm.OptimizeResult.history` has them."""
    path = Path(path)
    if path.suffix == ".jsonl":
        rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    elif path.suffix == ".csv":
        rows = list(csv.DictReader(path.read_text().splitlines()))
    else:
        raise _core.InvalidArgumentError(f"invalid history: {path} (expected a .jsonl or .csv file)")
    if not rows:
        raise _core.InvalidArgumentError(f"invalid history: {path} has no record")
    return {key: np.array([_cell(r.get(key)) for r in rows]) for key in rows[0]}


def _cell(value: Any) -> Any:
    """A CSV cell as its number or flag (JSON values are already)."""
    if not isinstance(value, str):
        return value
    if value in ("true", "false"):
        return value == "true"
    try:
        return float(value)
    except ValueError:
        return value


def _history_of(run: Any) -> tuple[dict[str, Any], str]:
    """A run's history columns and label: a result, a history dict, or a history file."""
    if isinstance(run, (str, Path)):
        return read_history(run), Path(run).stem
    history = getattr(run, "history", run)
    if not isinstance(history, Mapping) or "mean" not in history:
        raise TypeError(
            f"invalid run: {type(run).__name__} (expected a result of optimize or optimize_controller, a history "
            "dict with 'mean', or a .jsonl/.csv history file)"
        )
    return dict(history), type(run).__name__.removesuffix("Result").lower() or "run"


def learning_curve(*runs: Any, x: str = "iteration", labels: Sequence[str] | None = None) -> Figure:
    """The mean, elite threshold and best so far of each iteration, of one run or several on
    one axes (restarts and rivals beside each other).

    Args:
        runs: results of :func:`cehmm.optimize` or :func:`cehmm.optimize_controller`, history
            dicts (``{"mean": [...], ...}``: a rival's run as plain arrays; ``elite_threshold``,
            ``best_so_far`` and ``seconds`` are drawn where given), or history files.
        x: ``"iteration"`` or ``"seconds"``.
        labels: one per run (default: the file's name, or the kind of result).
    """
    if x not in ("iteration", "seconds"):
        raise _core.InvalidArgumentError(f"invalid x: {x!r} (expected 'iteration' or 'seconds')")
    if not runs:
        raise TypeError("learning_curve() needs at least one run")
    fig = figure(figsize=(7.0, 4.2), layout="constrained")
    ax = fig.add_subplot()
    colors = ["tab:blue", "tab:red", "tab:green", "tab:purple", "tab:brown", "tab:olive"]
    for k, run in enumerate(runs):
        history, label = _history_of(run)
        label = labels[k] if labels is not None else label
        mean = np.asarray(history["mean"], dtype=float)
        xs = np.asarray(history.get(x, np.arange(len(mean))), dtype=float)
        color = colors[k % len(colors)]
        # Best so far: the searches record it; for episode CE, the best mean so far.
        best = np.asarray(history.get("best_so_far", np.maximum.accumulate(mean)), dtype=float)
        ax.plot(xs, mean, color=color, linewidth=1.0, label=f"{label}: mean")
        if "elite_threshold" in history:
            ax.plot(
                xs,
                history["elite_threshold"],
                color=color,
                linewidth=0.7,
                linestyle="--",
                label=f"{label}: elite threshold",
            )
        ax.plot(xs, best, color=color, linewidth=1.4, linestyle=":", label=f"{label}: best so far")
    ax.set_xlabel("iteration" if x == "iteration" else "seconds")
    ax.set_ylabel("value")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    return fig


def summary_bars(summary: Sequence[Mapping[str, Any]], paper_best: float = 69.0) -> Figure:
    """Ours against the paper per row, in % of ``paper_best``.

    Args:
        summary: rows as aggregated by :func:`cehmm.reproduce.aggregate` (``row``, ``mean``,
            ``std``, ``paper_reward``, ``runs`` with each seed's ``mean``).
    """
    n = len(summary)
    fig = figure(figsize=(max(6.0, 0.62 * n + 2.0), 4.6), layout="constrained")
    ax = fig.add_subplot()
    x = np.arange(n)
    ours = np.array([100.0 * s["mean"] / paper_best for s in summary])
    err = np.array([100.0 * s["std"] / paper_best for s in summary])
    paper = np.array([100.0 * s["paper_reward"] / paper_best for s in summary])
    ax.bar(x - 0.2, paper, width=0.4, color="0.75", label="paper")
    ax.bar(x + 0.2, ours, width=0.4, yerr=err, capsize=3, color="tab:blue", label="ours (mean ± std)")
    for i, s in enumerate(summary):
        seeds = [100.0 * r["mean"] / paper_best for r in s.get("runs", [])]
        ax.plot([i + 0.2] * len(seeds), seeds, ".", color="black", markersize=3)
    ax.axhline(100.0, color="0.4", linestyle=":", linewidth=1)
    ax.set_xticks(x)
    ax.set_xticklabels([s["row"] for s in summary], rotation=45, ha="right", fontsize=8)
    ax.set_ylabel(f"reward, % of {paper_best:g}")
    ax.set_title("Evaluated reward per row: ours against the paper")
    ax.legend(loc="lower right", fontsize=8)
    return fig


def learning_curves(curves: Sequence[Mapping[str, Any]], columns: int = 4) -> Figure:
    """One panel per run: the mean, elite threshold and best reward of each iteration.

    Args:
        curves: dicts with ``history`` (as :attr:`cehmm.OptimizeResult.history`), and optionally
            ``title``, ``paper`` (a reward drawn as a dotted line) and ``best_iteration``.
        columns: panels per line.
    """
    n = max(1, len(curves))
    columns = min(columns, n)
    lines = math.ceil(n / columns)
    fig = figure(figsize=(3.6 * columns, 2.7 * lines + 0.4), layout="constrained")
    axes = fig.subplots(lines, columns, squeeze=False, sharey=True)
    for k, ax in enumerate(axes.flat):
        if k >= len(curves):
            ax.set_visible(False)
            continue
        c = curves[k]
        h = c["history"]
        it = np.asarray(h["iteration"])
        ax.plot(it, h["best"], color="tab:green", linewidth=0.7, label="best")
        ax.plot(it, h["elite_threshold"], color="tab:orange", linewidth=0.8, label="elite threshold")
        ax.plot(it, h["mean"], color="tab:blue", linewidth=1.0, label="mean")
        if c.get("paper") is not None:
            ax.axhline(c["paper"], color="0.3", linestyle=":", linewidth=1, label="paper")
        if c.get("best_iteration") is not None:
            ax.axvline(c["best_iteration"], color="0.6", linewidth=0.6)
        ax.set_title(c.get("title", ""), fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
        if k % columns == 0:
            ax.set_ylabel("reward", fontsize=8)
        if k >= len(curves) - columns:
            ax.set_xlabel("iteration", fontsize=8)
    axes.flat[0].legend(fontsize=7, loc="lower right")
    fig.suptitle("Learning curves", fontsize=10)
    return fig
