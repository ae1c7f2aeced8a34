"""The one place the figures meet matplotlib: a figure without pyplot (no GUI backend needed;
``fig.savefig`` renders with Agg), or an error that says how to install matplotlib."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import _core

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
    """The names of a world's decisions (``"actions"``) or observations (``"observations"``),
    ``count`` of them: a world's own (a ``.pomdp`` file's), else the values of the spaces a
    Gymnasium environment's description records (:mod:`cehmm.encoded`: a ``Discrete`` space's
    values, a ``MultiDiscrete``'s tuples, a ``Grid``'s actions; cells of bins and hashes have no
    value, and keep their index); indices where there are none. ``world``: a world object or a
    policy file's ``"world"`` dict. A tabular policy's extra observation is the start symbol."""
    given = _given(world, attribute)
    return [given[k] if k < len(given) else ("start" if given and k == len(given) else str(k)) for k in range(count)]


def _given(world: Any, attribute: str) -> list[str]:
    """The names a world gives, or ``[]``."""
    if world is None:
        return []
    own = None if isinstance(world, Mapping) else getattr(world, attribute, None)
    if isinstance(own, (list, tuple)):
        return [str(name) for name in own]
    from ..encoded import recorded

    described = world if isinstance(world, Mapping) else getattr(world, "description", None)
    encodings = recorded(described) if isinstance(described, Mapping) else None
    if encodings is None:
        return []
    encoded = encodings[0] if attribute == "observations" else encodings[1]
    try:
        return [_label(encoded.value(k)) for k in range(encoded.size)]
    except _core.InvalidArgumentError:  # bins and hashed cells: indices only
        return []


def _label(value: Any) -> str:
    """A value of a space as a tick label: ``3``, ``-0.5``, ``(1, 0, 2)``."""
    if isinstance(value, tuple):
        return "(" + ", ".join(_label(v) for v in value) + ")"
    items = np.asarray(value).ravel().tolist()
    shown = [f"{x:g}" if isinstance(x, float) else str(x) for x in items]
    return shown[0] if len(shown) == 1 else "(" + ", ".join(shown) + ")"


def stored_world(policy: Any) -> Any:
    """The world stored in a policy's file: a world object where it is one of the engine's
    registry, else (a world written in Python, a Gymnasium environment: only Python runs them) its
    description, which names it and records its spaces; ``None`` where the policy has none."""
    from ..world import World

    described = policy.world
    if not described:
        return None
    return World.from_dict(described) if described.get("name") in World.names() else dict(described)
