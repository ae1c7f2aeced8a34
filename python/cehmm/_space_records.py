"""Gymnasium spaces as the JSON a policy file records of them (:mod:`cehmm.spaces`' encodings,
read back by :mod:`cehmm.encoded`), and the ``gymnasium`` module itself, an optional dependency."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import _core
from ._sizes import dtype_limits, shown


def gymnasium() -> Any:
    """The ``gymnasium`` module, or an ``ImportError`` that says how to install it."""
    try:
        import gymnasium
    except ImportError as e:  # pragma: no cover - the test extra installs it
        raise ImportError("Gymnasium environments need gymnasium: pip install 'cehmm[gym]'") from e
    return gymnasium


def gymnasium_spaces() -> Any:
    """``gymnasium.spaces``."""
    return gymnasium().spaces


def space_record(space: Any) -> dict[str, Any]:
    """A Gymnasium space as JSON (infinite bounds as the strings ``"inf"``, ``"-inf"``)."""
    spaces = gymnasium_spaces()
    if isinstance(space, spaces.Discrete):
        return {"type": "Discrete", "n": int(space.n), "start": int(space.start)}
    if isinstance(space, spaces.MultiDiscrete):
        return {
            "type": "MultiDiscrete",
            "nvec": space.nvec.tolist(),
            "start": space.start.tolist(),
            "dtype": str(space.dtype),
        }
    if isinstance(space, spaces.MultiBinary):
        return {"type": "MultiBinary", "n": space.n if isinstance(space.n, int) else [int(k) for k in space.n]}
    if isinstance(space, spaces.Tuple):
        return {"type": "Tuple", "spaces": [space_record(s) for s in space.spaces]}
    if isinstance(space, spaces.Box):
        return {
            "type": "Box",
            "low": _finite_or_text(space.low),
            "high": _finite_or_text(space.high),
            "shape": list(space.shape),
            "dtype": str(space.dtype),
        }
    raise _core.InvalidArgumentError(
        f"invalid space: {space} (expected Discrete, MultiDiscrete, MultiBinary, Tuple or Box)"
    )


def _finite_or_text(bounds: np.ndarray) -> list[Any]:
    """Bounds as JSON: an integer Box's as ints (exact past 2**53), infinite ones as text."""
    return [
        b if isinstance(b, int) or math.isfinite(b) else ("inf" if b > 0 else "-inf") for b in np.ravel(bounds).tolist()
    ]


def _bounds(record: dict[str, Any], key: str, dtype: np.dtype, shape: tuple[int, ...]) -> np.ndarray:
    """A Box record's bounds, each a value of its dtype (never cast: 1e308 is no float32)."""
    lo, hi = dtype_limits(dtype)
    integer = dtype.kind in "biu"
    read = []
    for b in record[key]:
        x = float(b) if isinstance(b, str) else b
        if not isinstance(x, (int, float)):
            raise TypeError(f"{key} {shown(b)} is not a number")
        finite = math.isfinite(x) and lo <= x <= hi and (not integer or x == int(x))
        if not (finite or (math.isinf(x) and not integer)):
            raise ValueError(f"{key} {shown(b)} is not a bound of {dtype} (expected a number in [{lo}, {hi}])")
        read.append(int(x) if integer else x)
    return np.array(read, dtype=dtype).reshape(shape)


def space_of(record: dict[str, Any]) -> Any:
    """The Gymnasium space of a :func:`space_record`."""
    spaces = gymnasium_spaces()
    kind = record.get("type")
    if kind == "Discrete":
        return spaces.Discrete(int(record["n"]), start=int(record["start"]))
    if kind == "MultiDiscrete":
        return spaces.MultiDiscrete(record["nvec"], dtype=record["dtype"], start=record["start"])
    if kind == "MultiBinary":
        return spaces.MultiBinary(record["n"])
    if kind == "Tuple":
        return spaces.Tuple([space_of(s) for s in record["spaces"]])
    if kind == "Box":
        shape, dtype = tuple(record["shape"]), np.dtype(record["dtype"])
        low, high = _bounds(record, "low", dtype, shape), _bounds(record, "high", dtype, shape)
        return spaces.Box(low, high, shape=shape, dtype=dtype)
    raise _core.PolicyFormatError(f"invalid space record: {shown(record)} (expected a type Discrete, ..., Box)")
