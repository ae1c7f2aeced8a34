"""How a policy uses its memory, for any world: the states visited at each level against time,
the visits of (m₁, y) and (m₁, m₂), and the decision law per observation and memory state."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import _core
from ..world import world_title
from ._figure import figure, names, stored_world

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from ..policy import Policy


def _rollouts(policy: Policy, world: Any, episodes: int, seed: int) -> list[Any]:
    """Episodes ``0..episodes`` of ``policy.evaluate(world, seed=seed)``, recorded (``world``:
    default, the policy's stored world, made once)."""
    if episodes < 1:
        raise _core.InvalidArgumentError(f"invalid episodes: {episodes} (expected at least 1)")
    if world is None:
        world = stored_world(policy)
        if isinstance(world, Mapping):
            raise _core.InvalidArgumentError(
                f"invalid world: none given for a policy of {world_title(world)}, a world written in Python, whose "
                "episodes run only in Python (expected the world, as in cehmm.plots.memory_use(policy, world))"
            )
    return [policy.rollout(world, seed=seed, episode=k) for k in range(episodes)]


def memory_by_step(policy: Policy, world: Any = None, episodes: int = 200, seed: int = 0) -> list[np.ndarray]:
    """For each level ``l``, the share of the episodes still running at step ``t`` whose memory
    ``m_l[t]`` is ``m``: an array ``(|M_l|, T)`` whose columns sum to 1 (episodes that end early
    stop counting).

    Example:
        >>> world = cehmm.TargetTracking(case=1)
        >>> shares = cehmm.plots.memory_by_step(cehmm.Policy.uniform(world, [2, 3]), world, episodes=5)
        >>> [share.shape for share in shares], bool(np.allclose(shares[1].sum(axis=0), 1.0))
        ([(2, 100), (3, 100)], True)
    """
    rollouts = _rollouts(policy, world, episodes, seed)
    steps = max(len(r) for r in rollouts)
    counts = [np.zeros((size, steps)) for size in policy.levels]
    for r in rollouts:
        t = np.arange(len(r))
        for level, c in enumerate(counts):
            np.add.at(c, (r.memory[:, level], t), 1.0)
    alive = np.array([sum(len(r) > t for r in rollouts) for t in range(steps)], dtype=float)
    return [c / alive for c in counts]


def memory_use(policy: Policy, world: Any = None, episodes: int = 200, seed: int = 0, title: str = "") -> Figure:
    """Heat maps of the memory states visited at each level against time over ``episodes``
    rollouts (one panel per level, bottom level first; colour: the share of the episodes in
    that state at that step).

    Example:
        >>> world = cehmm.TargetTracking(case=1)
        >>> fig = cehmm.plots.memory_use(cehmm.Policy.uniform(world, [2, 3]), world, episodes=5)
        >>> [ax.get_title() for ax in fig.axes[:2]], fig.axes[1].get_xlabel()
        (['level 1: 2 of 2 states visited', 'level 2: 3 of 3 states visited'], 'step t (5 episodes)')
        >>> fig.savefig("memory.png")
    """
    shares = memory_by_step(policy, world, episodes, seed)
    fig = figure(figsize=(7.0, 1.0 + 2.2 * len(shares)), layout="constrained")
    axes = fig.subplots(len(shares), 1, squeeze=False, sharex=True)[:, 0]
    image = None
    for level, (ax, share) in enumerate(zip(axes, shares), start=1):
        image = ax.imshow(share, cmap="magma_r", vmin=0.0, vmax=1.0, aspect="auto", interpolation="nearest")
        used = int((share.sum(axis=1) > 0).sum())
        ax.set_ylabel(f"m_{level}")
        ax.set_title(f"level {level}: {used} of {share.shape[0]} states visited", fontsize=9)
        step = max(1, math.ceil(share.shape[0] / 8))
        ax.set_yticks(range(0, share.shape[0], step))
    axes[-1].set_xlabel(f"step t ({episodes} episodes)")
    if image is not None:
        fig.colorbar(image, ax=list(axes), shrink=0.85, label="share of episodes")
    if title:
        fig.suptitle(title, fontsize=9)
    return fig


def decision_law(policy: Policy, world: Any = None, title: str = "") -> Figure:
    """The decision law as heat maps: ``h0``, the decision given the bottom memory ``m₁``, and
    the decision given the observation ``y`` and the memory above ``m₂`` (``Σ_m₁ h1[y, m₂, m₁]
    h0[m₁, d]``: with one level, a map ``y × d``; with more, the likeliest decision per
    ``(y, m₂)``, shaded by its probability). Decisions and observations are named by the world
    where it names them (default: the policy's stored world; for a world written in Python or a
    Gymnasium environment, the spaces its file records), by index elsewhere.

    Example:
        >>> tiger = cehmm.PomdpWorld.from_file("data/pomdp/tiger.95.POMDP", horizon=10)
        >>> fig = cehmm.plots.decision_law(cehmm.Policy.uniform(tiger, [2]), tiger)
        >>> law = fig.axes[1]
        >>> law.get_title(), [label.get_text() for label in law.get_yticklabels()]
        ('decision given the observation y', ['tiger-left', 'tiger-right', 'start'])
        >>> [label.get_text() for label in law.get_xticklabels()]
        ['listen', 'open-left', 'open-right']
        >>> pendulum = cehmm.PythonWorld("Pendulum-v1", actions=cehmm.spaces.Grid(3))  # torques -2, 0, 2
        >>> fig = cehmm.plots.decision_law(cehmm.Policy.uniform(pendulum, [2]))  # the policy alone
        >>> [label.get_text() for label in fig.axes[0].get_xticklabels()]
        ['-2', '0', '2']
    """
    from matplotlib import colormaps as cm
    from matplotlib.colors import ListedColormap

    world = world if world is not None else stored_world(policy)
    tables = policy.tables
    h0, h1 = tables["h0"], tables["h1"]
    decisions = names(world, "actions", h0.shape[1])
    observations = names(world, "observations", h1.shape[0])
    law = np.einsum("yum,md->yud", h1, h0)  # P(d | y, m2)
    fig = figure(figsize=(11.0, 0.8 + 0.22 * max(h0.shape[0], h1.shape[0], 12)), layout="constrained")
    left, right = fig.subplots(1, 2, width_ratios=[1.0, 1.3])
    image = left.imshow(h0, cmap="Blues", vmin=0.0, vmax=1.0, aspect="auto", interpolation="nearest")
    left.set_title("decision given m₁ (h0)", fontsize=9)
    left.set_xlabel("decision d")
    left.set_ylabel("m₁")
    _ticks(left.xaxis, decisions, rotate=True)
    _ticks(left.yaxis, [str(k) for k in range(h0.shape[0])])
    fig.colorbar(image, ax=left, shrink=0.85, label="probability")
    if law.shape[1] == 1:
        image = right.imshow(law[:, 0, :], cmap="Blues", vmin=0.0, vmax=1.0, aspect="auto", interpolation="nearest")
        right.set_title("decision given the observation y", fontsize=9)
        right.set_xlabel("decision d")
        _ticks(right.xaxis, decisions, rotate=True)
        fig.colorbar(image, ax=right, shrink=0.85, label="probability")
    else:
        likeliest, p = law.argmax(axis=2), law.max(axis=2)
        palette = [f"C{k}" for k in range(10)] if len(decisions) <= 10 else [cm["tab20"](k) for k in range(20)]
        color = lambda d: palette[d % len(palette)]  # noqa: E731
        colors = ListedColormap([color(d) for d in range(len(decisions))])
        right.imshow(
            likeliest, cmap=colors, vmin=-0.5, vmax=len(decisions) - 0.5, aspect="auto", interpolation="nearest"
        )
        # Shade each cell towards white by how far its likeliest decision is from certain.
        right.imshow(
            np.ones_like(p), cmap="gray", vmin=0, vmax=1, alpha=1.0 - p, aspect="auto", interpolation="nearest"
        )
        right.set_title("likeliest decision given y and m₂ (paler: less likely)", fontsize=9)
        right.set_xlabel("m₂")
        _ticks(right.xaxis, [str(k) for k in range(law.shape[1])])
        from matplotlib.patches import Patch

        shown = sorted(set(likeliest.ravel().tolist()))
        right.legend(
            handles=[Patch(color=color(d), label=decisions[d]) for d in shown[:20]],
            fontsize=7,
            loc="upper left",
            bbox_to_anchor=(1.01, 1.0),
            frameon=False,
        )
    right.set_ylabel("observation y")
    _ticks(right.yaxis, observations)
    if title:
        fig.suptitle(title, fontsize=9)
    return fig


def _ticks(axis: Any, labels: list[str], rotate: bool = False) -> None:
    """At most 24 labelled ticks."""
    step = max(1, math.ceil(len(labels) / 24))
    axis.set_ticks(range(0, len(labels), step))
    axis.set_ticklabels(labels[::step], fontsize=7, rotation=60 if rotate else 0)


def memory_usage(policy: Policy, world: Any = None, episodes: int = 1000, seed: int = 0) -> dict[str, np.ndarray]:
    """Visit counts over ``episodes`` rollouts: ``"m1_y"`` (|M_1| × Y) and, with two levels or
    more, ``"m1_m2"`` (|M_1| × |M_2|).

    Example:
        >>> world = cehmm.TargetTracking(case=1)
        >>> counts = cehmm.plots.memory_usage(cehmm.Policy.uniform(world, [2, 3]), world, episodes=5)
        >>> {key: value.shape for key, value in counts.items()}, int(counts["m1_y"].sum())
        ({'m1_y': (2, 16), 'm1_m2': (2, 3)}, 500)
    """
    levels = policy.levels
    m1_y = np.zeros((levels[0], policy.n_obs), dtype=np.int64)
    m1_m2 = np.zeros((levels[0], levels[1]), dtype=np.int64) if len(levels) > 1 else None
    for ro in _rollouts(policy, world, episodes, seed):
        np.add.at(m1_y, (ro.memory[:, 0], ro.y), 1)
        if m1_m2 is not None:
            np.add.at(m1_m2, (ro.memory[:, 0], ro.memory[:, 1]), 1)
    out = {"m1_y": m1_y}
    if m1_m2 is not None:
        out["m1_m2"] = m1_m2
    return out


def memory_heatmap(policy: Policy, world: Any = None, episodes: int = 1000, seed: int = 0, title: str = "") -> Figure:
    """Heat maps of how the learned memory is used: frequency of (m₁, y), and of (m₁, m₂) when the
    policy has two levels or more, over ``episodes`` rollouts (log colour scale).

    Example:
        >>> world = cehmm.TargetTracking(case=1)
        >>> fig = cehmm.plots.memory_heatmap(cehmm.Policy.uniform(world, [2, 3]), world, episodes=5)
        >>> for ax in fig.axes[:2]:
        ...     print(f"{ax.get_title()}: x {ax.get_xlabel()}, y {ax.get_ylabel()}")
        m₁ against the observation (5 episodes): x observation y (= obs_B + 4·obs_C), y m₁
        m₁ against m₂ (5 episodes): x m₂, y m₁
    """
    from matplotlib.colors import LogNorm

    counts = memory_usage(policy, world, episodes, seed)
    tracking = getattr(world, "name", "") == "target-tracking"
    panels = [("m1_y", "observation y" + (" (= obs_B + 4·obs_C)" if tracking else ""), "m₁ against the observation")]
    if "m1_m2" in counts:
        panels.append(("m1_m2", "m₂", "m₁ against m₂"))
    fig = figure(figsize=(5.2 * len(panels) + 0.6, 5.0), layout="constrained")
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
        if key == "m1_y":
            observations = names(world if world is not None else stored_world(policy), "observations", freq.shape[1])
            ax.set_xticklabels(observations[:: max(1, math.ceil(freq.shape[1] / 16))], fontsize=7, rotation=60)
        ax.set_title(f"{name} ({episodes} episodes)", fontsize=9)
        ax.set_facecolor("0.95")
        fig.colorbar(image, ax=ax, shrink=0.85, label="frequency")
    if title:
        fig.suptitle(title, fontsize=9)
    return fig
