"""Episodes drawn: target tracking on its grid (a stretch after the paper's *Near-optimal
control sequence* figure, or an animation of a whole episode), any other world as a timeline
of its observations, decisions and memory."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import _core
from ..world import world_title
from ._figure import figure, names

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from ..policy import Policy
    from ..tracking import TargetTracking

#: The columns of a target-tracking rollout's hidden state (model §4).
TRACKING_STATE = ["b_i", "b_j", "b_heading", "c_i", "c_j", "c_heading", "target_i", "target_j"]
#: The grid of target tracking's defaults, used when no world is given.
DEFAULT_GRID = {"width": 20, "height": 20, "reward_radius": 3}


def is_tracking(rollout: Any) -> bool:
    """Whether a rollout is of the target-tracking world (by its state's columns)."""
    return list(rollout.x_labels) == TRACKING_STATE


def _grid(rollout: Any, world: Any) -> dict[str, int]:
    """Width, height and reward radius: the world's, else the defaults (grown to the rollout)."""
    params = dict(DEFAULT_GRID)
    if world is not None:
        params.update({k: int(v) for k, v in world.params.items() if k in DEFAULT_GRID})
    else:
        x = rollout.x
        params["width"] = max(params["width"], int(x[:, [0, 3, 6]].max()) + 1)
        params["height"] = max(params["height"], int(x[:, [1, 4, 7]].max()) + 1)
    return params


def _rewarded(x: np.ndarray, radius: int) -> np.ndarray:
    """Per step of a target-tracking state ``x``, whether a mobile is within ``radius`` of the
    target (Chebyshev distance: the reward of model §4)."""
    near_b = np.abs(x[:, 0:2] - x[:, 6:8]).max(axis=1)
    near_c = np.abs(x[:, 3:5] - x[:, 6:8]).max(axis=1)
    return np.minimum(near_b, near_c) <= radius


def pick_episode(policy: Policy, world: TargetTracking, seed: int = 0, candidates: int = 50) -> int:
    """The first of ``candidates`` episodes whose reward is nearest the policy's mean over them.

    Example:
        >>> world = cehmm.TargetTracking(case=3)
        >>> policy = cehmm.Policy.uniform(world, [2])
        >>> [policy.rollout(world, episode=k).reward for k in range(10)]
        [0.0, 8.0, 0.0, 7.0, 0.0, 0.0, 0.0, 0.0, 0.0, 24.0]
        >>> cehmm.plots.pick_episode(policy, world, candidates=10)  # the mean is 3.9
        3
    """
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

    Example:
        >>> world = cehmm.TargetTracking(case=3)
        >>> fig = cehmm.plots.trajectory(cehmm.Policy.uniform(world, [2]), world, episode=1, start=20, length=5)
        >>> fig.axes[0].get_title()
        'episode 1 of target tracking, case 3 (reward 8): steps 21–25 shown as times 0–4 (... rewarded)'
        >>> fig.axes[0].get_xlabel(), fig.axes[0].get_ylabel()
        ('i (column)', 'j (row)')
        >>> fig.savefig("trajectory.png")
    """
    if episode is None:
        episode = pick_episode(policy, world, seed)
    ro = policy.rollout(world, seed=seed, episode=episode)
    if start is None:
        start = _stretch(ro, length)
    what = f"episode {episode} of {world_title(world) or 'target tracking'}"
    return _grid_figure(ro, _grid(ro, world), start, length, title, zoom, min_view, what)


def rollout(
    record: Any, world: Any = None, start: int = 0, length: int | None = None, title: str = "", zoom: bool = True
) -> Figure:
    """One recorded episode (:meth:`cehmm.Policy.rollout`; also ``rollout.plot()``): for target
    tracking, steps ``start .. start + length`` (default: all) on the grid, as
    :func:`trajectory` draws them (``world`` gives the grid's size; default 20 × 20); for any
    other world, its observations, decisions and memory states against time (``world`` gives
    their names).

    Example:
        >>> tiger = cehmm.PomdpWorld.from_file("data/pomdp/tiger.95.POMDP", horizon=10)
        >>> fig = cehmm.plots.rollout(cehmm.Policy.uniform(tiger, [2]).rollout(tiger), tiger)
        >>> [ax.get_ylabel() for ax in fig.axes], fig.axes[-1].get_xlabel()
        (['observation y', 'decision d', 'memory m_1'], 'step t')
        >>> world = cehmm.TargetTracking(case=1)
        >>> episode = cehmm.Policy.uniform(world, [2]).rollout(world)
        >>> episode.plot(world=world, length=10).axes[0].get_title()
        'episode of target tracking, case 1 (reward 0): steps 1–10 shown as times 0–9 (0 rewarded)'
    """
    if not is_tracking(record):
        return _timeline(record, world, title)
    length = len(record) - start if length is None else length
    what = f"episode of {world_title(world) or 'target tracking'}"
    return _grid_figure(record, _grid(record, world), start, length, title, zoom, 9, what)


def _grid_figure(
    ro: Any, params: dict[str, int], start: int, length: int, title: str, zoom: bool, min_view: int, what: str
) -> Figure:
    """Steps ``start .. start + length`` of a target-tracking rollout on its grid, titled
    ``what`` (which episode, of which world) with its reward; the times' labels that would
    cover one of an earlier time are left out."""
    if not 0 <= start < len(ro) or length < 1:
        raise _core.InvalidArgumentError(
            f"invalid stretch: start {start}, length {length} (expected 0 <= start < {len(ro)} and length >= 1)"
        )
    stop = min(len(ro), start + length)
    x = ro.x[start:stop]
    width, height = params["width"], params["height"]

    # The view: the cells the stretch visits, with a margin (at least `min_view` cells a side).
    if zoom:
        cols = np.concatenate([x[:, 0], x[:, 3], x[:, 6]])
        rows = np.concatenate([x[:, 1], x[:, 4], x[:, 7]])
        (i0, i1), (j0, j1) = (_span(cols, width, min_view), _span(rows, height, min_view))
    else:
        i0, i1, j0, j1 = 0, width - 1, 0, height - 1

    fig = figure(figsize=(6.6, 7.0), layout="constrained")
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

    radius = params["reward_radius"]
    rewarded = _rewarded(x, radius)

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
    times: list[tuple[int, int, Any]] = []  # (first time, mobile, label)
    most = None if len(x) <= 20 else 2  # a long stretch: a cell's first visits, then "…"
    for mobile, (label, ci, cj, style, offset) in enumerate(specs):
        ii, jj = x[:, ci], x[:, cj]
        ax.plot(ii, jj, "-", color=style["color"], alpha=0.45, linewidth=1.2)
        ax.plot(ii, jj, linestyle="none", label=label, **style)
        # Times grouped by cell ("5,6" when it stayed put; revisits share the cell's label).
        cells: dict[tuple[int, int], list[int]] = {}
        for t in range(len(x)):
            cells.setdefault((int(ii[t]), int(jj[t])), []).append(t)
        for (gi, gj), visits in cells.items():
            text = ax.annotate(
                _ranges(visits, most),
                (gi, gj),
                textcoords="offset points",
                xytext=offset,
                ha="right" if offset[0] < 0 else "left",
                fontsize=8,
                color=style["color"],
            )
            times.append((visits[0], mobile, text))
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
        + f"{what} (reward {ro.reward:g}): steps {start + 1}–{stop} shown as times 0–{len(x) - 1}"
        f" ({reward_stretch} rewarded)",
        fontsize=9,
    )
    _thin(fig, [text for _, _, text in sorted(times, key=lambda t: t[:2])])
    return fig


def _thin(fig: Figure, labels: Sequence[Any]) -> None:
    """Hides each of ``labels`` that would cover one before it (as the figure is laid out: the
    same at any dpi)."""
    fig.draw_without_rendering()
    kept: list[Any] = []
    for label in labels:
        box = label.get_window_extent().padded(-0.5)
        if any(box.overlaps(other) for other in kept):
            label.set_visible(False)
        else:
            kept.append(box)


def _ranges(times: Sequence[int], most: int | None = None) -> str:
    """``[2, 3, 4, 8]`` -> ``"2–4,8"`` (pairs stay as ``"5,6"``); ``most``: the first ``most``
    parts, then ``…``."""
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
    if most is not None and len(parts) > most:
        parts = [*parts[:most], "…"]
    return ",".join(parts)


def _timeline(ro: Any, world: Any, title: str) -> Figure:
    """Observation, decision and each level's memory state against time, one panel each."""
    levels = ro.memory.shape[1]
    # As many names as the world has (the start symbol of a tabular world after them), else as
    # many as the episode shows.
    count = lambda values, n: n if n is not None else (int(values.max()) + 1 if len(values) else 0)  # noqa: E731
    n_obs = getattr(world, "n_observations", None)
    n_obs = n_obs + 1 if n_obs is not None and getattr(world, "observations", None) else n_obs
    rows = [("observation y", ro.y, names(world, "observations", count(ro.y, n_obs)))]
    rows.append(("decision d", ro.d, names(world, "actions", count(ro.d, getattr(world, "n_decisions", None)))))
    rows += [(f"memory m_{level + 1}", ro.memory[:, level], None) for level in range(levels)]
    fig = figure(figsize=(7.5, 0.8 + 1.3 * len(rows)), layout="constrained")
    axes = fig.subplots(len(rows), 1, sharex=True, squeeze=False)[:, 0]
    t = np.arange(len(ro))
    for ax, (label, values, ticks) in zip(axes, rows):
        ax.step(t, values, where="mid", color="tab:blue", linewidth=1.0)
        ax.plot(t, values, ".", color="tab:blue", markersize=3)
        ax.set_ylabel(label, fontsize=8)
        if ticks is not None:
            # Every value by name where they fit, else those the episode shows (at most 12).
            shown = list(range(len(ticks))) if len(ticks) <= 12 else sorted(set(values.tolist()))
            shown = shown[:: max(1, math.ceil(len(shown) / 12))]
            ax.set_yticks(shown)
            ax.set_yticklabels([ticks[v] for v in shown], fontsize=7)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("step t")
    of = world_title(world)
    what = f"episode{' of ' + of if of else ''} (reward {ro.reward:g}): {len(ro)} steps"
    fig.suptitle((title + "\n" if title else "") + what, fontsize=9)
    return fig


def animation(
    record: Any,
    path: str | os.PathLike[str],
    world: Any = None,
    fps: float = 4.0,
    steps: int | None = None,
    trail: int = 5,
    dpi: int = 80,
) -> str:
    """A target-tracking episode as an animation saved to ``path`` (also
    ``rollout.animate(path)``): the whole grid, the target (×), observer 1 = mobile B (•) and
    observer 2 = mobile C (○) with their last ``trail`` positions, the reward square around the
    target (green while a mobile is inside), and the reward so far. A ``.gif`` is written with
    matplotlib's Pillow writer; other extensions with the writer matplotlib picks for them
    (``.mp4`` needs ffmpeg).

    Args:
        record: a rollout of the target-tracking world (:meth:`cehmm.Policy.rollout`).
        path: the file to write.
        world: its world (the grid's size; default 20 × 20).
        fps: frames (steps) per second.
        steps: the first ``steps`` steps only (default: all).

    Returns:
        the path written.

    Raises:
        InvalidArgumentError: the rollout is not of target tracking, or ``steps`` < 1.

    Example:
        >>> world = cehmm.TargetTracking(case=1)
        >>> episode = cehmm.Policy.uniform(world, [2]).rollout(world)
        >>> cehmm.plots.animation(episode, "episode.gif", world, steps=2)  # or episode.animate(...)
        'episode.gif'
    """
    if not is_tracking(record):
        raise _core.InvalidArgumentError(
            f"invalid rollout: a state of {list(record.x_labels)} (expected a target-tracking rollout: "
            "other worlds are drawn by rollout.plot())"
        )
    frames = len(record) if steps is None else min(steps, len(record))
    if frames < 1:
        raise _core.InvalidArgumentError(f"invalid steps: {steps} (expected at least 1)")
    from matplotlib.animation import FuncAnimation, PillowWriter
    from matplotlib.patches import Rectangle

    params = _grid(record, world)
    width, height, radius = params["width"], params["height"], params["reward_radius"]
    x = record.x[:frames]
    fig = figure(figsize=(4.8, 5.2), layout="constrained")
    ax = fig.add_subplot()
    ax.set_xlim(-0.5, width - 0.5)
    ax.set_ylim(height - 0.5, -0.5)  # j grows downwards (model §4)
    ax.set_aspect("equal")
    ax.set_xticks(np.arange(-0.5, width, 1), minor=True)
    ax.set_yticks(np.arange(-0.5, height, 1), minor=True)
    ax.grid(which="minor", color="0.9", linewidth=0.5)
    ax.set_xticks(range(0, width, 5))
    ax.set_yticks(range(0, height, 5))
    ax.tick_params(which="both", length=0, labelsize=7)
    square = Rectangle((0, 0), 2 * radius + 1, 2 * radius + 1, facecolor="tab:green", alpha=0.0, edgecolor="0.6")
    ax.add_patch(square)
    styles = [
        ((6, 7), dict(marker="x", color="tab:red", markersize=9, markeredgewidth=2), "target"),
        ((0, 1), dict(marker="o", color="black", markersize=6), "observer 1 (B)"),
        (
            (3, 4),
            dict(marker="o", markerfacecolor="white", color="tab:blue", markersize=8, markeredgewidth=1.5),
            "observer 2 (C)",
        ),
    ]
    marks = [ax.plot([], [], linestyle="none", label=label, **style)[0] for _, style, label in styles]
    trails = [ax.plot([], [], "-", color=style["color"], alpha=0.4, linewidth=1.2)[0] for _, style, _ in styles]
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.02), ncol=3, fontsize=7, frameon=False)
    near = _rewarded(x, radius)
    so_far = np.cumsum(near)

    def draw(t: int) -> list[Any]:
        for (ci, cj), mark, line in zip([c for c, _, _ in styles], marks, trails):
            mark.set_data([x[t, ci]], [x[t, cj]])
            lo = max(0, t - trail)
            line.set_data(x[lo : t + 1, ci], x[lo : t + 1, cj])
        square.set_xy((x[t, 6] - radius - 0.5, x[t, 7] - radius - 0.5))
        square.set_alpha(0.25 if near[t] else 0.08)
        ax.set_title(f"step {t + 1} of {len(record)}: rewarded steps so far {int(so_far[t])}", fontsize=9)
        return [*marks, *trails, square]

    movie = FuncAnimation(fig, draw, frames=frames, interval=1000.0 / fps, blit=False)
    path = os.fspath(path)
    writer = PillowWriter(fps=fps) if path.lower().endswith(".gif") else None
    movie.save(path, writer=writer, dpi=dpi)
    return path
