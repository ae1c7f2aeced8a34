"""A policy of a tabular world drawn as its policy graph (model §8): nodes are memory states
labelled with their decisions, arrows are observations; no Graphviz needed (for Graphviz,
``Policy.graph(form="dot")`` or ``ceworld show --dot``)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .. import _core
from ._figure import figure

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from ..policy import Policy

#: The most nodes a drawing takes (a larger graph is unreadable: prune it, or draw
#: ``policy.most_likely()``).
MOST_NODES = 40


def _probability(p: float) -> str:
    return "" if p >= 1.0 else f" ({p:.2f})"


def edges(graph: dict[str, Any]) -> list[tuple[int, int, str]]:
    """``(from, to, label)`` per pair of nodes of a graph of ``Policy.graph(form="json")``, the
    label listing the observations that take it (with their probability where below 1)."""
    out: dict[tuple[int, int], list[str]] = {}
    for k, node in enumerate(graph["nodes"]):
        for observation, law in node["next"].items():
            for n, p in law:
                out.setdefault((k, int(n)), []).append(observation + _probability(p))
    return [(a, b, "\n".join(labels)) for (a, b), labels in out.items()]


def policy_graph(policy: Policy, world: Any = None, prune: float = _core.GRAPH_PRUNE, title: str = "") -> Figure:
    """The policy graph of ``policy`` on a tabular world (default: its stored world): nodes on a
    circle, node 0 first, each labelled with its decision law; an arrow per pair of nodes with
    the observations that take it; a short arrow into the initial nodes.

    Raises:
        InvalidArgumentError: the world is not tabular, or the graph has more than
            :data:`MOST_NODES` nodes (prune more, or draw ``policy.most_likely()``).
    """
    from matplotlib.patches import FancyArrowPatch

    graph = policy.graph(world, form="json", prune=prune)
    nodes = graph["nodes"]
    n = len(nodes)
    if n > MOST_NODES:
        raise _core.InvalidArgumentError(
            f"invalid policy: its graph has {n} nodes at prune={prune:g} (expected at most {MOST_NODES} to draw: "
            "a larger prune, or policy.most_likely())"
        )
    angle = np.pi / 2 - 2 * np.pi * np.arange(n) / max(n, 1)
    radius = 1.0 if n > 1 else 0.0
    at = np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)
    size = 6.0 + 0.12 * n
    fig = figure(figsize=(size, size), layout="constrained")
    ax = fig.add_subplot()
    ax.set_aspect("equal")
    ax.axis("off")
    box = dict(boxstyle="round,pad=0.35", facecolor="#e8f0fa", edgecolor="tab:blue")
    for k, node in enumerate(nodes):
        law = "\n".join(f"{d}{_probability(p)}" for d, p in node["decision"].items())
        ax.text(*at[k], f"{k}: {law}", ha="center", va="center", fontsize=8, bbox=box, zorder=3)
    arrows = edges(graph)
    # Many arrows: their labels would cover one another; the laws are in form="text".
    labelled = len(arrows) <= 3 * max(n, 1)
    for a, b, label in arrows:
        label = label if labelled else ""
        if a == b:
            # A loop: a small circle outside the node, away from the centre.
            out = _outward(at[a], n)
            centre = at[a] + 0.2 * out
            ax.add_patch(_loop(centre, 0.09))
            ax.text(*(at[a] + 0.36 * out), label, ha="center", va="center", fontsize=6.5, color="0.25")
            continue
        ax.add_patch(
            FancyArrowPatch(
                at[a],
                at[b],
                connectionstyle="arc3,rad=0.18",
                arrowstyle="-|>",
                mutation_scale=11,
                shrinkA=18,
                shrinkB=18,
                color="0.35",
                linewidth=0.9,
            )
        )
        # A third of the way from its node, on the side the arc bends to: labels of arrows that
        # cross in the middle stay apart.
        along = at[a] + 0.33 * (at[b] - at[a])
        normal = np.array([at[b][1] - at[a][1], at[a][0] - at[b][0]])
        along = along + 0.07 * normal / (np.linalg.norm(normal) or 1.0)
        ax.text(*along, label, ha="center", va="center", fontsize=6.5, color="0.25", zorder=2)
    for k, p in graph["initial"]:
        k = int(k)
        # From the side (a node's loop is drawn outwards).
        out = _outward(at[k], n)
        start = at[k] + 0.45 * np.array([-out[1], out[0]]) + 0.25 * out
        ax.add_patch(FancyArrowPatch(start, at[k], arrowstyle="-|>", mutation_scale=11, shrinkB=18, color="tab:green"))
        ax.text(*start, "start" + _probability(p), ha="center", va="center", fontsize=7, color="tab:green")
    ax.set_xlim(-1.5, 1.5)
    ax.set_ylim(-1.5, 1.5)
    unlabelled = "" if labelled else "; too many arrows to label them"
    ax.set_title(title or f"policy graph: {n} nodes (laws ≤ {prune:g} left out{unlabelled})", fontsize=9)
    return fig


def _outward(point: np.ndarray, n: int) -> np.ndarray:
    """The unit vector from the circle's centre out through a node (up for a lone node)."""
    return point / (np.linalg.norm(point) or 1.0) if n > 1 else np.array([0.0, 1.0])


def _loop(centre: np.ndarray, r: float) -> Any:
    from matplotlib.patches import Arc

    return Arc(tuple(centre), 2 * r, 2 * r, theta1=0, theta2=330, color="0.35", linewidth=0.9)
