"""A policy of a tabular world drawn as its policy graph (model §8): nodes are memory states
labelled with their decisions, arrows are observations; no Graphviz needed (for Graphviz,
``Policy.graph(form="dot")`` or ``ceworld show --dot``)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import _core
from ..world import world_title
from ._figure import figure, stored_world

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from ..policy import Policy

#: The most nodes a drawing takes (a larger graph is unreadable: prune it, or draw
#: ``policy.most_likely()``).
MOST_NODES = 40


def _probability(p: float) -> str:
    return "" if p >= 1.0 else f" ({p:.2f})"


def edges(graph: dict[str, Any], short: dict[str, str] | None = None) -> list[tuple[int, int, str]]:
    """``(from, to, label)`` per pair of nodes of a graph of ``Policy.graph(form="json")``, the
    label listing the observations that take it (with their probability where below 1), by
    name, or by ``short[name]`` where given (one line then, comma-separated)."""
    out: dict[tuple[int, int], list[str]] = {}
    for k, node in enumerate(graph["nodes"]):
        for observation, law in node["next"].items():
            for n, p in law:
                shown = observation if short is None else short.get(observation, observation)
                out.setdefault((k, int(n)), []).append(shown + _probability(p))
    return [(a, b, ("\n" if short is None else ",").join(labels)) for (a, b), labels in out.items()]


def policy_graph(policy: Policy, world: Any = None, prune: float = _core.GRAPH_PRUNE, title: str = "") -> Figure:
    """The policy graph of ``policy`` on a tabular world (default: its stored world): nodes on a
    circle, node 0 first, each labelled with its decision law; an arrow per pair of nodes (a
    loop for a node to itself) labelled with the observations that take it, by name, or by
    index where the arrows are many (the key in the title); a short arrow into the initial
    nodes. ``title``: a first line above the graph's own (what it is, of which world).

    Raises:
        InvalidArgumentError: the world is not tabular, or the graph has more than
            :data:`MOST_NODES` nodes (prune more, or draw ``policy.most_likely()``).

    Example:
        >>> tiger = cehmm.PomdpWorld.from_file("data/pomdp/tiger.95.POMDP", horizon=10)
        >>> fig = cehmm.plots.policy_graph(cehmm.Policy.uniform(tiger, [2]), tiger, title="Uniform")
        >>> print(fig.axes[0].get_title())
        Uniform
        policy graph of tiger.95.POMDP: 2 nodes (laws ≤ 0.001 left out)
        >>> fig.savefig("graph.png")
    """
    from matplotlib.patches import FancyArrowPatch

    described = world if world is not None else stored_world(policy)
    if isinstance(described, Mapping):  # a world written in Python: never tabular
        raise _core.InvalidArgumentError(
            f"invalid world: {world_title(described)}, written in Python (a policy graph needs a tabular world, "
            "e.g. cehmm.PomdpWorld; its decision law draws any policy: cehmm.plots.decision_law)"
        )
    graph = policy.graph(described, form="json", prune=prune)
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
    # Many arrows: names would cover one another; the observations' indices are shorter.
    short = None if len(arrows) <= 3 * max(n, 1) else _indices(graph, described)
    if short is not None:
        arrows = edges(graph, short)
    style = dict(arrowstyle="-|>", mutation_scale=11, color="0.35", linewidth=0.9)
    for a, b, label in arrows:
        if a == b:
            # A loop: a circle outside the node, away from the centre, back into the node.
            out = _outward(at[a], n)
            ax.add_patch(FancyArrowPatch(path=_loop(at[a] + 0.2 * out, 0.09, out), gid=f"edge {a}->{b}", **style))
            where = at[a] + 0.36 * out
        else:
            arc = "arc3,rad=0.18"
            ax.add_patch(
                FancyArrowPatch(
                    at[a], at[b], connectionstyle=arc, shrinkA=18, shrinkB=18, gid=f"edge {a}->{b}", **style
                )
            )
            # A third of the way from its node, on the side the arc bends to: labels of arrows
            # that cross in the middle stay apart.
            normal = np.array([at[b][1] - at[a][1], at[a][0] - at[b][0]])
            where = at[a] + 0.33 * (at[b] - at[a]) + 0.07 * normal / (np.linalg.norm(normal) or 1.0)
        ax.text(*where, label, ha="center", va="center", fontsize=6.5, color="0.25", zorder=2, gid=f"label {a}->{b}")
    for k, p in graph["initial"]:
        k = int(k)
        # From the side (a node's loop is drawn outwards).
        out = _outward(at[k], n)
        start = at[k] + 0.45 * np.array([-out[1], out[0]]) + 0.25 * out
        ax.add_patch(FancyArrowPatch(start, at[k], arrowstyle="-|>", mutation_scale=11, shrinkB=18, color="tab:green"))
        ax.text(*start, "start" + _probability(p), ha="center", va="center", fontsize=7, color="tab:green")
    ax.set_xlim(-1.5, 1.5)
    ax.set_ylim(-1.5, 1.5)
    of = world_title(described)
    of = f" of {of}" if of and of not in title else ""  # named once
    what = f"policy graph{of}: {n} node{'s' * (n != 1)} (laws ≤ {prune:g} left out)"
    key = "" if short is None else "\narrows: observations by index, " + ", ".join(f"{i} {o}" for o, i in short.items())
    ax.set_title((title + "\n" if title else "") + what + key, fontsize=9)
    return fig


def _indices(graph: dict[str, Any], world: Any) -> dict[str, str]:
    """The observations of a graph's arrows by their index in the world (in the order the
    graph names them where the world has no names)."""
    seen = sorted({o for node in graph["nodes"] for o in node["next"]})
    given = getattr(world, "observations", None)
    order = list(given) if given else seen
    return {o: str(order.index(o) if o in order else k) for k, o in enumerate(seen)}


def _outward(point: np.ndarray, n: int) -> np.ndarray:
    """The unit vector from the circle's centre out through a node (up for a lone node)."""
    return point / (np.linalg.norm(point) or 1.0) if n > 1 else np.array([0.0, 1.0])


def _loop(centre: np.ndarray, r: float, out: np.ndarray) -> Any:
    """A loop of radius ``r`` around ``centre``: from its node (towards ``-out``) round and back,
    a gap facing the node, drawn anticlockwise so that its arrowhead comes back into it."""
    from matplotlib.path import Path

    facing = np.degrees(np.arctan2(-out[1], -out[0]))
    arc = Path.arc(facing + 25.0, facing + 335.0)
    return Path(centre + r * arc.vertices, arc.codes)
