"""Learning curves: of a run, of several on one axes, of the reproduction's panels, and the
reproduction's summary bars; histories read back from their files (:mod:`.history`)."""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import _core
from ._figure import figure
from .history import read_history

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure


#: The largest magnitude a curve draws: matplotlib's axis arithmetic overflows near the top of
#: the float range (a value of 1e308 fails to draw).
MOST_DRAWN = 1e300


#: Per run, the colours of its mean (and elite threshold) and of its best so far: a colour
#: each, none shared between runs (a sixth run takes the first pair again).
CURVE_COLORS = [
    ("tab:blue", "tab:orange"),
    ("tab:green", "tab:red"),
    ("tab:purple", "tab:olive"),
    ("tab:cyan", "tab:brown"),
    ("tab:gray", "tab:pink"),
]


def _history_of(run: Any) -> tuple[dict[str, Any], str]:
    """A run's history columns and label: a result, a history dict, or a history file."""
    if isinstance(run, (str, os.PathLike)):
        return read_history(run), Path(os.fsdecode(run)).stem
    history = getattr(run, "history", run)
    if not isinstance(history, Mapping) or "mean" not in history:
        raise TypeError(
            f"invalid run: {type(run).__name__} (expected a result of optimize or optimize_controller, a history "
            "dict with 'mean', or a .jsonl/.csv history file)"
        )
    return dict(history), type(run).__name__.removesuffix("Result").lower() or "run"


def _drawn(history: Mapping[str, Any], field: str, run: Any, default: Any = None) -> np.ndarray:
    """A history's ``field`` (``default`` where it has none) as floats that can be drawn, or an
    error naming the run and the field."""
    name = f"history file: {os.fsdecode(run)}" if isinstance(run, (str, os.PathLike)) else f"run ({type(run).__name__})"
    try:
        values = np.asarray(history[field] if field in history else default, dtype=float)
    except (TypeError, ValueError) as e:
        raise _core.InvalidArgumentError(f"invalid {name}: field {field!r} does not hold numbers ({e})") from None
    if values.ndim != 1:
        raise _core.InvalidArgumentError(
            f"invalid {name}: field {field!r} has the shape {values.shape} (expected one value per iteration)"
        )
    big = np.abs(values) > MOST_DRAWN
    if big.any():
        raise _core.InvalidArgumentError(
            f"invalid {name}: field {field!r} has {values[big][0]:g} (expected values within ±{MOST_DRAWN:g} to draw)"
        )
    return values


def learning_curve(*runs: Any, x: str = "iteration", labels: Sequence[str] | None = None) -> Figure:
    """The mean (solid), elite threshold (dotted, in the mean's colour) and best so far
    (dashed, in a colour of its own: :data:`CURVE_COLORS`) of each iteration, of one run or
    several on one axes (restarts and rivals beside each other), each line in the legend.

    Args:
        runs: results of :func:`cehmm.optimize` or :func:`cehmm.optimize_controller`, history
            dicts (``{"mean": [...], ...}``: a rival's run as plain arrays; ``elite_threshold``,
            ``best_so_far``, ``seconds`` and ``env_steps`` are drawn where given), or history files.
        x: ``"iteration"``, ``"seconds"`` or ``"env_steps"`` (the world's steps learning had
            taken: runs compared at equal steps of the world).
        labels: one per run (default: the file's name, or the kind of result).

    Example:
        >>> result = cehmm.optimize(cehmm.TargetTracking(case=1), levels=[4], samples=200,
        ...                         max_iterations=2, progress=False)
        >>> fig = cehmm.plots.learning_curve(result, {"mean": [1.0, 3.0, 2.0]}, labels=["ce", "rival"])
        >>> [line.get_label() for line in fig.axes[0].get_lines()]
        ['ce: mean', 'ce: elite threshold', 'ce: best so far', 'rival: mean', 'rival: best so far']
        >>> fig.axes[0].get_xlabel(), fig.axes[0].get_ylabel()
        ('iteration', 'value')
        >>> fig.savefig("curve.png")
    """
    if x not in ("iteration", "seconds", "env_steps"):
        raise _core.InvalidArgumentError(f"invalid x: {x!r} (expected 'iteration', 'seconds' or 'env_steps')")
    if not runs:
        raise TypeError("learning_curve() needs at least one run")
    fig = figure(figsize=(7.0, 4.2), layout="constrained")
    ax = fig.add_subplot()
    for k, run in enumerate(runs):
        history, label = _history_of(run)
        label = labels[k] if labels is not None else label
        mean = _drawn(history, "mean", run)
        xs = _drawn(history, x, run, np.arange(len(mean)))
        color, best_color = CURVE_COLORS[k % len(CURVE_COLORS)]
        # Best so far: the searches record it; for episode CE, the best mean so far.
        best = _drawn(history, "best_so_far", run, np.fmax.accumulate(mean))
        ax.plot(xs, mean, color=color, linewidth=1.0, label=f"{label}: mean")
        if "elite_threshold" in history:
            ax.plot(
                xs,
                _drawn(history, "elite_threshold", run),
                color=color,
                linewidth=0.8,
                linestyle=":",
                label=f"{label}: elite threshold",
            )
        ax.plot(xs, best, color=best_color, linewidth=1.6, linestyle="--", label=f"{label}: best so far")
    ax.set_xlabel({"iteration": "iteration", "seconds": "seconds", "env_steps": "steps of the world"}[x])
    ax.set_ylabel("value")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    return fig


def summary_bars(summary: Sequence[Mapping[str, Any]], paper_best: float = 69.0) -> Figure:
    """Ours against the paper per row, in % of ``paper_best``.

    Args:
        summary: rows as aggregated by :func:`cehmm.reproduce.aggregate` (``row``, ``mean``,
            ``std``, ``paper_reward``, ``runs`` with each seed's ``mean``).

    Example:
        >>> rows = [{"row": "case 1", "mean": 60.0, "std": 2.0, "paper_reward": 65.0,
        ...          "runs": [{"mean": 58.0}, {"mean": 62.0}]},
        ...         {"row": "case 2", "mean": 70.0, "std": 0.0, "paper_reward": 69.0}]
        >>> ax = cehmm.plots.summary_bars(rows).axes[0]
        >>> ax.get_ylabel(), [label.get_text() for label in ax.get_xticklabels()]
        ('reward, % of 69', ['case 1', 'case 2'])
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

    Example:
        >>> result = cehmm.optimize(cehmm.TargetTracking(case=1), levels=[4], samples=200,
        ...                         max_iterations=2, progress=False)
        >>> curves = [{"history": result.history, "title": f"seed {k}", "paper": 1.0} for k in range(3)]
        >>> fig = cehmm.plots.learning_curves(curves, columns=2)
        >>> [(ax.get_title(), ax.get_visible()) for ax in fig.axes]
        [('seed 0', True), ('seed 1', True), ('seed 2', True), ('', False)]
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
