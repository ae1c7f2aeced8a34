"""The one place the figures meet matplotlib: a figure without pyplot (no GUI backend needed;
``fig.savefig`` renders with Agg), or an error that says how to install matplotlib."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

INSTALL = "cehmm's figures need matplotlib: pip install 'cehmm[plot]'"


def figure(**kwargs: Any) -> Figure:
    """A :class:`matplotlib.figure.Figure` (keywords passed on)."""
    try:
        from matplotlib.figure import Figure
    except ImportError as e:
        raise ImportError(INSTALL) from e
    return Figure(**kwargs)


def names(world: Any, attribute: str, count: int) -> list[str]:
    """The world's names of its decisions (``"actions"``) or observations (``"observations"``),
    indices where it has none; ``count`` of them (a tabular policy's extra observation is the
    start symbol)."""
    given = list(getattr(world, attribute, None) or []) if world is not None else []
    return [given[k] if k < len(given) else ("start" if given and k == len(given) else str(k)) for k in range(count)]


def stored_world(policy: Any) -> Any:
    """The world stored in a policy's file, as a world object (``None`` where it has none)."""
    from ..world import World

    return World.from_dict(policy.world) if policy.world else None
