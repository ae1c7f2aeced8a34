"""Figures of the reproduction report (matplotlib; ``pip install 'cehmm[plot]'``).

Every function returns a :class:`matplotlib.figure.Figure` built without pyplot (no GUI backend
is needed: ``fig.savefig("x.png")`` renders with Agg). matplotlib is imported when a function is
called, so this module imports without it.

Example:
    >>> import cehmm, cehmm.plots
    >>> world = cehmm.TargetTracking(case=3)
    >>> policy = cehmm.Policy.uniform(world, [4, 4])
    >>> cehmm.plots.trajectory(policy, world).savefig("trajectory.png")  # doctest: +SKIP
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from . import _core

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from .policy import Policy
    from .tracking import TargetTracking


def _figure(**kwargs: Any) -> Figure:
    try:
        from matplotlib.figure import Figure
    except ImportError as e:
        raise ImportError("cehmm's figures need matplotlib: pip install 'cehmm[plot]'") from e
    return Figure(**kwargs)


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
    fig = _figure(figsize=(7.0, 4.2), layout="constrained")
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
    fig = _figure(figsize=(max(6.0, 0.62 * n + 2.0), 4.6), layout="constrained")
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
    fig = _figure(figsize=(3.6 * columns, 2.7 * lines + 0.4), layout="constrained")
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


def pick_episode(policy: Policy, world: TargetTracking, seed: int = 0, candidates: int = 50) -> int:
    """The first of ``candidates`` episodes whose reward is nearest the policy's mean over them."""
    rewards = np.array([policy.rollout(world, seed=seed, episode=k).reward for k in range(candidates)])
    return int(np.argmin(np.abs(rewards - rewards.mean())))


def _stretch(rollout: Any, length: int) -> int:
    """The start of the ``length``-step window where the mobiles and the target move the most."""
    x = rollout.x
    steps = len(x)
    if steps <= length:
        return 0
    moves = np.zeros(steps)
    moves[1:] = np.abs(np.diff(x[:, [0, 1, 3, 4, 6, 7]], axis=0)).sum(axis=1)
    # Skip the approach from the start corners: prefer windows once a mobile is near the target.
    near = np.maximum(np.abs(x[:, 0] - x[:, 6]), np.abs(x[:, 1] - x[:, 7])) <= 3
    near |= np.maximum(np.abs(x[:, 3] - x[:, 6]), np.abs(x[:, 4] - x[:, 7])) <= 3
    first = int(np.argmax(near)) if near.any() else 0
    sums = np.convolve(moves, np.ones(length), mode="valid")
    starts = np.arange(len(sums))
    sums = np.where(starts >= first, sums, -1.0)
    return int(np.argmax(sums))


def _span(values: np.ndarray, size: int, least: int) -> tuple[int, int]:
    """``[lo, hi]`` covering ``values`` with a one-cell margin, ``least`` cells wide, inside ``0..size-1``."""
    lo, hi = int(values.min()) - 1, int(values.max()) + 1
    while hi - lo + 1 < min(least, size):
        lo, hi = lo - 1, hi + 1
    if lo < 0:
        lo, hi = 0, min(size - 1, hi - lo)
    if hi > size - 1:
        lo, hi = max(0, lo - (hi - size + 1)), size - 1
    return lo, hi


def trajectory(
    policy: Policy,
    world: TargetTracking,
    seed: int = 0,
    episode: int | None = None,
    start: int | None = None,
    length: int = 15,
    title: str = "",
    zoom: bool = True,
    min_view: int = 9,
) -> Figure:
    """A stretch of one episode on the grid, after the paper's *Near-optimal control sequence*.

    The target (×), observer 1 = mobile B (•) and observer 2 = mobile C (○) are drawn at each
    step of the stretch with the relative time next to them (``5,6`` when it stayed put).

    Args:
        policy: the policy.
        world: its world (target tracking).
        seed, episode: the episode (:meth:`cehmm.Policy.rollout`); default: one with a typical reward.
        start, length: the stretch (default ``start``: the most active window once tracking began).
        title: the figure's title.
        zoom: show only the cells around the stretch (at least ``min_view`` a side; the grid's
            border is drawn thick), else the whole grid.
    """
    if episode is None:
        episode = pick_episode(policy, world, seed)
    ro = policy.rollout(world, seed=seed, episode=episode)
    if start is None:
        start = _stretch(ro, length)
    stop = min(len(ro), start + length)
    x = ro.x[start:stop]
    params = world.params
    width, height = int(params.get("width", 20)), int(params.get("height", 20))

    # The view: the cells the stretch visits, with a margin (at least `min_view` cells a side).
    if zoom:
        cols = np.concatenate([x[:, 0], x[:, 3], x[:, 6]])
        rows = np.concatenate([x[:, 1], x[:, 4], x[:, 7]])
        (i0, i1), (j0, j1) = (_span(cols, width, min_view), _span(rows, height, min_view))
    else:
        i0, i1, j0, j1 = 0, width - 1, 0, height - 1

    fig = _figure(figsize=(6.6, 7.0), layout="constrained")
    ax = fig.add_subplot()
    ax.set_xticks(np.arange(-0.5, width, 1), minor=True)
    ax.set_yticks(np.arange(-0.5, height, 1), minor=True)
    ax.grid(which="minor", color="0.88", linewidth=0.6)
    ax.tick_params(which="minor", length=0)
    step = 1 if max(i1 - i0, j1 - j0) < 16 else 5
    ax.set_xticks(range(i0 - i0 % step, i1 + 1, step))
    ax.set_yticks(range(j0 - j0 % step, j1 + 1, step))
    ax.set_aspect("equal")
    from matplotlib.patches import Rectangle

    ax.add_patch(Rectangle((-0.5, -0.5), width, height, fill=False, edgecolor="0.3", linewidth=2, clip_on=True))
    ax.set_xlabel("i (column)")
    ax.set_ylabel("j (row)")

    radius = int(params.get("reward_radius", 3))
    near_b = np.abs(x[:, 0:2] - x[:, 6:8]).max(axis=1)
    near_c = np.abs(x[:, 3:5] - x[:, 6:8]).max(axis=1)
    rewarded = np.minimum(near_b, near_c) <= radius

    specs = [
        ("target", 6, 7, dict(marker="x", color="tab:red", markersize=9, markeredgewidth=2), (7, -11)),
        ("observer 1 (B)", 0, 1, dict(marker="o", color="black", markersize=6), (-7, 6)),
        (
            "observer 2 (C)",
            3,
            4,
            dict(marker="o", markerfacecolor="white", color="tab:blue", markersize=8, markeredgewidth=1.5),
            (7, 6),
        ),
    ]
    for label, ci, cj, style, offset in specs:
        ii, jj = x[:, ci], x[:, cj]
        ax.plot(ii, jj, "-", color=style["color"], alpha=0.45, linewidth=1.2)
        ax.plot(ii, jj, linestyle="none", label=label, **style)
        # Times grouped by cell ("5,6" when it stayed put; revisits share the cell's label).
        cells: dict[tuple[int, int], list[int]] = {}
        for t in range(len(x)):
            cells.setdefault((int(ii[t]), int(jj[t])), []).append(t)
        for (gi, gj), times in cells.items():
            ax.annotate(
                _ranges(times),
                (gi, gj),
                textcoords="offset points",
                xytext=offset,
                ha="right" if offset[0] < 0 else "left",
                fontsize=8,
                color=style["color"],
            )
    # Headings of the mobiles at the stretch's start, as arrows (0 up, 1 right, 2 down, 3 left).
    arrow = {0: (0, -0.8), 1: (0.8, 0), 2: (0, 0.8), 3: (-0.8, 0)}
    for ci, cj, ch, color in ((0, 1, 2, "black"), (3, 4, 5, "tab:blue")):
        dx, dy = arrow.get(int(x[0, ch]), (0, 0))
        ax.annotate(
            "",
            xy=(x[0, ci] + dx, x[0, cj] + dy),
            xytext=(x[0, ci], x[0, cj]),
            arrowprops=dict(arrowstyle="->", color=color, linewidth=1),
        )
    # Room beyond the grid's border for the labels of its edge cells.
    pad = lambda at_edge: 0.5 + (0.9 if at_edge else 0.0)  # noqa: E731
    ax.set_xlim(i0 - pad(i0 == 0), i1 + pad(i1 == width - 1))
    ax.set_ylim(j1 + pad(j1 == height - 1), j0 - pad(j0 == 0))  # j grows downwards (model §4)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.09), ncol=3, fontsize=8, frameon=False)
    reward_stretch = int(sum(rewarded))
    ax.set_title(
        (title + "\n" if title else "")
        + f"episode {episode} (reward {ro.reward:g}), steps {start + 1}–{stop} shown as times 0–{len(x) - 1}"
        f" ({reward_stretch} rewarded)",
        fontsize=9,
    )
    return fig


def _ranges(times: Sequence[int]) -> str:
    """``[2, 3, 4, 8]`` -> ``"2–4,8"`` (pairs stay as ``"5,6"``)."""
    parts: list[str] = []
    k = 0
    while k < len(times):
        j = k
        while j + 1 < len(times) and times[j + 1] == times[j] + 1:
            j += 1
        if j - k >= 2:
            parts.append(f"{times[k]}–{times[j]}")
        else:
            parts.extend(str(t) for t in times[k : j + 1])
        k = j + 1
    return ",".join(parts)


def memory_usage(policy: Policy, world: TargetTracking, episodes: int = 1000, seed: int = 0) -> dict[str, np.ndarray]:
    """Visit counts over ``episodes`` rollouts: ``"m1_y"`` (|M_1| × Y) and, with two levels or
    more, ``"m1_m2"`` (|M_1| × |M_2|)."""
    levels = policy.levels
    m1_y = np.zeros((levels[0], policy.n_obs), dtype=np.int64)
    m1_m2 = np.zeros((levels[0], levels[1]), dtype=np.int64) if len(levels) > 1 else None
    for k in range(episodes):
        ro = policy.rollout(world, seed=seed, episode=k)
        np.add.at(m1_y, (ro.memory[:, 0], ro.y), 1)
        if m1_m2 is not None:
            np.add.at(m1_m2, (ro.memory[:, 0], ro.memory[:, 1]), 1)
    out = {"m1_y": m1_y}
    if m1_m2 is not None:
        out["m1_m2"] = m1_m2
    return out


def memory_heatmap(
    policy: Policy, world: TargetTracking, episodes: int = 1000, seed: int = 0, title: str = ""
) -> Figure:
    """Heat maps of how the learned memory is used: frequency of (m₁, y), and of (m₁, m₂) when the
    policy has two levels or more, over ``episodes`` rollouts (log colour scale)."""
    from matplotlib.colors import LogNorm

    counts = memory_usage(policy, world, episodes, seed)
    panels = [("m1_y", "observation y (= obs_B + 4·obs_C)", "m₁ against the observation")]
    if "m1_m2" in counts:
        panels.append(("m1_m2", "m₂", "m₁ against m₂"))
    fig = _figure(figsize=(5.2 * len(panels) + 0.6, 5.0), layout="constrained")
    axes = fig.subplots(1, len(panels), squeeze=False)[0]
    total = counts["m1_y"].sum()
    for ax, (key, xlabel, name) in zip(axes, panels):
        freq = counts[key] / total
        positive = freq[freq > 0]
        vmin = positive.min() if positive.size else 1e-6
        image = ax.imshow(
            np.where(freq > 0, freq, np.nan),
            norm=LogNorm(vmin=vmin, vmax=max(vmin * 1.01, freq.max())),
            cmap="viridis",
            aspect="auto",
            interpolation="nearest",
        )
        ax.set_xlabel(xlabel)
        ax.set_ylabel("m₁")
        for axis, n in ((ax.xaxis, freq.shape[1]), (ax.yaxis, freq.shape[0])):
            step = max(1, math.ceil(n / 16))
            axis.set_ticks(range(0, n, step))
        ax.set_title(f"{name} ({episodes} episodes)", fontsize=9)
        ax.set_facecolor("0.95")
        fig.colorbar(image, ax=ax, shrink=0.85, label="frequency")
    if title:
        fig.suptitle(title, fontsize=9)
    return fig
