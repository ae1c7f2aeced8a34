"""The arithmetic of the encodings' sizes and indices, and the reading of their arguments
(:mod:`cehmm.spaces`): products compared with their bounds without being built, row-major indices
of any number of digits, lists of real numbers, a dtype's range."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from . import _core

#: The most indices the engine takes (its observations are 16-bit).
MAX_INDICES = 65535
#: The most values an index can name (an int64).
INDEX_LIMIT = 2**63 - 1
#: The largest size an error writes out (past it: "more than ...").
SHOWN_LIMIT = 10**100


def product(factors: Iterable[int], cap: int) -> int:
    """The product of positive ints, or ``cap + 1`` as soon as it passes ``cap``: sizes are
    compared with their bounds from their arithmetic, never built in full (the 2**21168 cells of
    an image) nor written out (Python refuses ints of more than 4300 digits).

    Example:
        >>> product([3, 4], 100), product([2] * 10**6, 100)
        (12, 101)
    """
    total = 1
    for factor in factors:
        total *= int(factor)
        if total > cap:
            return cap + 1
    return total


def at_most(factors: Iterable[int], what: str, role: str, subject: str, hint: str) -> int:
    """The product of ``factors``, refused past :data:`MAX_INDICES`, naming ``subject``.

    Example:
        >>> at_most([300, 300], "actions", "action", "300 values in each of 2 dimensions", "fewer values")
        Traceback (most recent call last):
        ...
        cehmm.InvalidArgumentError: invalid action encoding: 300 values in each of 2 dimensions: 90000 actions (at most 65535: fewer values)
    """  # noqa: E501
    size = product(factors, SHOWN_LIMIT)
    if size > MAX_INDICES:
        count = counted(size, str(MAX_INDICES))
        raise _core.InvalidArgumentError(
            f"invalid {role} encoding: {subject}: {count} {what} (at most {MAX_INDICES}: {hint})"
        )
    return size


def counted(size: int, bound: str) -> str:
    """A size past a bound as an error writes it: exact up to :data:`SHOWN_LIMIT`, else "more
    than" the bound (given as text).

    Example:
        >>> counted(2**80, "2**63 - 1"), counted(product([10] * 5000, SHOWN_LIMIT), "2**63 - 1")
        ('1208925819614629174706176', 'more than 2**63 - 1')
    """
    return str(size) if size <= SHOWN_LIMIT else f"more than {bound}"


def ravel(digits: Iterable[int], radices: Sequence[int]) -> int:
    """The row-major index of digits (exact, of any number of them: numpy's stops at 64).

    Example:
        >>> ravel([2, 1], [3, 4]), unravel(9, [3, 4])
        (9, [2, 1])
    """
    index = 0
    for digit, radix in zip(digits, radices):
        index = index * radix + digit
    return index


def unravel(index: int, radices: Sequence[int]) -> list[int]:
    """The row-major digits of an index (:func:`ravel`'s inverse)."""
    digits = [0] * len(radices)
    for k in range(len(radices) - 1, -1, -1):
        index, digits[k] = divmod(index, radices[k])
    return digits


def is_int(value: Any) -> bool:
    """Whether ``value`` is an int (a numpy integer included, a bool not)."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def counts(value: Any) -> bool:
    """Whether ``value`` is a count of :data:`MAX_INDICES` at most (a positive int), or a list of them."""
    if is_int(value):
        return 1 <= value <= MAX_INDICES
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        return False
    return all(is_int(b) and 1 <= b <= MAX_INDICES for b in value)


def lists(value: Any, name: str, expected: str) -> list[Any]:
    """A list of lists (one per dimension), each sized, refused naming the first that is not.

    Example:
        >>> lists([[1.0], "ab"], "Grid values", "a list of lists")
        Traceback (most recent call last):
        ...
        cehmm.InvalidArgumentError: invalid Grid values[1]: 'ab' (expected a list of numbers)
    """
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        raise _core.InvalidArgumentError(f"invalid {name}: {shown(value)} (expected {expected})")
    items = list(value)
    for i, item in enumerate(items):
        try:
            sized = not isinstance(item, (str, bytes)) and len(item) >= 0
        except TypeError:
            sized = False
        if not sized:
            raise _core.InvalidArgumentError(f"invalid {name}[{i}]: {shown(item)} (expected a list of numbers)")
    return items


def numbers(value: Any, name: str, expected: str, least: int = 0) -> np.ndarray:
    """A list of ``least`` finite real numbers or more, as floats, refused otherwise (text is not
    read as numbers)."""
    x = reals(value)
    if x is None or x.ndim != 1 or x.size < least or not np.all(np.isfinite(x)):
        raise _core.InvalidArgumentError(f"invalid {name}: {shown(value)} (expected {expected})")
    return x


def reals(value: Any) -> np.ndarray | None:
    """A value as an array of floats, or None where it is not real numbers (text, objects, ragged).

    Example:
        >>> reals([1, 2.5]), reals("12"), reals([[1], [2, 3]])
        (array([1. , 2.5]), None, None)
    """
    try:
        x = np.asarray(value)
    except (TypeError, ValueError, OverflowError):
        return None
    return x.astype(float) if x.dtype.kind in "biuf" else None


def dtype_limits(dtype: np.dtype) -> tuple[Any, Any]:
    """The least and the greatest value of a numeric dtype, as Python numbers.

    Example:
        >>> dtype_limits(np.dtype(np.uint8)), dtype_limits(np.dtype(bool))
        ((0, 255), (0, 1))
    """
    if dtype.kind == "b":
        return 0, 1
    if dtype.kind in "iu":
        return int(np.iinfo(dtype).min), int(np.iinfo(dtype).max)
    return -float(np.finfo(dtype).max), float(np.finfo(dtype).max)


def shown(value: Any) -> str:
    """A value as an error shows it: its repr, cut at 80 characters."""
    text = repr(value)
    return text if len(text) <= 80 else text[:79] + "…"
