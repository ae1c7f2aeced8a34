"""Argument checks of the Python layer: types only.

Domains (``rho`` in (0, 1), ``samples >= 1``, level sizes, ...) are checked by the engine, whose
messages name the argument and what it expects; here we only make sure each value can cross into
Rust, raising :class:`~cehmm.InvalidArgumentError` in the same ``invalid NAME: VALUE (expected ...)``
form otherwise.
"""

from __future__ import annotations

import numbers
from typing import Any

from ._core import InvalidArgumentError

_U64 = 2**64


def invalid(name: str, value: Any, expected: str) -> InvalidArgumentError:
    """The error for ``name = value``, in the engine's wording."""
    return InvalidArgumentError(f"invalid {name}: {value!r} (expected {expected})")


def _is_int(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def count(name: str, value: Any) -> int:
    """A non-negative int (the engine checks the lower bound that matters, e.g. ``>= 1``)."""
    if not _is_int(value) or not 0 <= int(value) < _U64:
        raise invalid(name, value, "a non-negative int")
    return int(value)


def optional_count(name: str, value: Any) -> int | None:
    """:func:`count`, or ``None``."""
    return None if value is None else count(name, value)


def seed(value: Any, name: str = "seed") -> int:
    """A seed: an int in ``0 .. 2**64``."""
    if not _is_int(value) or not 0 <= int(value) < _U64:
        raise invalid(name, value, "an int in 0..2**64")
    return int(value)


def real(name: str, value: Any) -> float:
    """A real number (an int or a float, not a bool)."""
    if not isinstance(value, numbers.Real) or isinstance(value, bool):
        raise invalid(name, value, "a number")
    return float(value)


def optional_real(name: str, value: Any) -> float | None:
    """:func:`real`, or ``None``."""
    return None if value is None else real(name, value)


def flag(name: str, value: Any) -> bool:
    """A bool."""
    if not isinstance(value, (bool, numbers.Integral)):
        raise invalid(name, value, "True or False")
    return bool(value)


def levels(value: Any) -> list[int]:
    """Memory sizes per level, bottom first: a list of positive ints (the engine checks the range)."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise invalid("levels", value, "a list of positive ints, e.g. [16, 16]")
    sizes = list(value)
    for position, size in enumerate(sizes, start=1):
        if not _is_int(size) or not 0 <= int(size) < 2**63:
            raise InvalidArgumentError(
                f"invalid levels: {sizes!r}: level {position} is {size!r} (expected a positive int)"
            )
    return [int(size) for size in sizes]


def choice(name: str, value: Any, options: tuple[str, ...]) -> str:
    """``value`` if it is one of ``options``."""
    if not isinstance(value, str) or value not in options:
        raise invalid(name, value, " or ".join(repr(o) for o in options))
    return value
