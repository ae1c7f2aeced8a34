"""Gymnasium spaces as the finite indices a policy reads and writes, and back: the encodings
that policy files record (docs/python-worlds.md, "Spaces").

A policy's observation ``y`` and decision ``d`` are indices ``0..size``. An environment's values
map to them through an encoding of its space, chosen by :class:`~cehmm.PythonWorld`
(``observations=``, ``actions=``) or by default:

* :class:`Flat` (finite spaces, the default where they have at most :data:`MAX_FLAT` values):
  ``Discrete(n, start)`` gives ``x - start``; a ``MultiDiscrete`` or ``MultiBinary`` its
  components in row-major order (the last one varying fastest, as ``numpy.ravel_multi_index``);
  a ``Tuple`` its components' indices in the same order. Exact both ways.
* :class:`Hashed` (finite observations with more values, the default there: ``Hashed(128)``):
  the values' components hashed (BLAKE2b) into ``size`` cells. Values that share a cell look
  the same to the policy.
* :class:`Bins` (``Box`` observations, the default there): each dimension cut at edges, the cell
  the row-major index of the dimensions' bins. The edges come from quantiles of the
  observations met in a warm-up of random actions (the default: even in what is met, whatever
  the bounds), from the space's bounds, or are given.
* :class:`Grid` (``Box`` actions, the default there: 5 values a dimension): each dimension takes
  one of evenly spaced values between its bounds, a decision the row-major index of the choices.

The encoding of each space is recorded in the policy file (the world's ``"spaces"``, read back
by :mod:`cehmm.encoded`), so that :meth:`cehmm.Policy.agent`, :func:`cehmm.gym.play` and
:meth:`cehmm.Policy.evaluate` on the environment replay the policy exactly: the agent takes what
the environment returns and answers what its action space holds.
"""

from __future__ import annotations

import hashlib
import itertools
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from . import _core, _sizes
from ._sizes import INDEX_LIMIT, MAX_INDICES, SHOWN_LIMIT, at_most, counted, counts, dtype_limits, is_int
from ._sizes import shown as _shown
from ._space_records import gymnasium as gymnasium
from ._space_records import gymnasium_spaces, space_record
from ._space_records import space_of as space_of

#: The most values a finite observation space is flattened over by default (more: hashed).
MAX_FLAT = 4096
#: The cells of the default :class:`Hashed` encoding: a 64-node Mealy controller over 128 cells
#: and 104 decisions (POPGym's Concentration) saves as at most 55 million entries, a policy file
#: of at most about 220 MB, which the engine reads back (model §8).
HASHED_CELLS = 128
#: The most cells of a default :class:`Bins` encoding (bins per dimension: the most ``b <= 16``
#: with ``b ** dims <= 256``, at least 2: 16 for two dimensions, 6 for three, 4 for four). A
#: learner that looks at one dimension at a time (model §10's views) sees 16 values of it, not 8.
BINS_CELLS = 256
#: Steps of random actions the default :class:`Bins` fits its quantiles on.
WARMUP_STEPS = 2000
#: Values per dimension of the default :class:`Grid`.
GRID_VALUES = 5


class Encoding:
    """A space's values as indices ``0..size`` (subclasses below). ``role`` names it in errors."""

    space: Any
    role: str
    size: int
    radices: list[int]

    def index(self, value: Any) -> int:
        """The index of a value the environment gave (checked to be of the space)."""
        raise NotImplementedError

    def value(self, index: int) -> Any:
        """The value of the space at an index (an action to give the environment)."""
        raise _core.InvalidArgumentError(
            f"invalid {self.role} encoding: {type(self).__name__} maps values to indices only (expected Flat or Grid "
            "for actions)"
        )

    def record(self) -> dict[str, Any]:
        """What a policy file records of it (:func:`cehmm.encoded.from_record` reads it back)."""
        raise NotImplementedError

    def check(self, value: Any) -> None:
        """Refuses a value that is not in the space (``space.contains``: type, shape, range).

        Raises:
            WorldError: naming the value and the space.
        """
        try:
            inside = bool(self.space.contains(value))
        except Exception:  # noqa: BLE001 - a value contains() cannot even read is not in the space
            inside = False
        if not inside:
            self._refuse(value)

    def _refuse(self, value: Any) -> None:
        raise _core.WorldError(f"{self.role} {_shown(value)} is not in the space {self.space}")

    def _digits(self, index: int) -> list[int]:
        """The row-major digits of an index of ``0..size``."""
        if (
            isinstance(index, (bool, np.bool_))
            or not isinstance(index, (int, np.integer))
            or not 0 <= index < self.size
        ):
            raise _core.InvalidArgumentError(
                f"invalid {self.role} index: {index!r} (expected an int in 0..{self.size - 1})"
            )
        return _sizes.unravel(int(index), self.radices)


class Flat(Encoding):
    """A finite space flattened to the indices ``0..size`` (module docstring).

    Raises:
        InvalidArgumentError: a space that is not finite (``Box``: :class:`Bins`) or not one of
            the kinds above, or with more than ``2**63 - 1`` values.

    Example:
        >>> from gymnasium.spaces import Discrete, MultiDiscrete
        >>> Flat(Discrete(3, start=-1)).index(1), Flat(MultiDiscrete([3, 4])).value(9)
        (2, array([2, 1]))
    """

    def __init__(self, space: Any, role: str = "observation") -> None:
        spaces = gymnasium_spaces()
        self.space = space
        self.role = role
        self.start: int | None = None
        self.parts: list[Flat] = []
        if not isinstance(space, (spaces.Discrete, spaces.MultiDiscrete, spaces.MultiBinary, spaces.Tuple)):
            hint = (
                " is continuous (expected a finite space: a Box is encoded by cehmm.spaces.Bins for observations "
                "and cehmm.spaces.Grid for actions)"
                if isinstance(space, spaces.Box)
                else " (expected Discrete, MultiDiscrete, MultiBinary, a Tuple of them, or a Box)"
            )
            raise _core.InvalidArgumentError(f"invalid {role} space: {space}{hint}")
        # From the arithmetic of the sizes, before any list of components is built: a MultiBinary
        # of 10**10 bits is refused at once, and no size past 2**63 is ever written out.
        size = _finite_size(space, SHOWN_LIMIT)
        if size > INDEX_LIMIT:
            raise _core.InvalidArgumentError(
                f"invalid {role} space: {space} has {counted(size, '2**63 - 1')} values (at most 2**63 - 1 can be "
                "indexed; observations that many are hashed: cehmm.spaces.Hashed)"
            )
        if isinstance(space, spaces.Discrete):
            self.kind = "discrete"
            self.radices = [int(space.n)]
            self.start = int(space.start)
        elif isinstance(space, spaces.Tuple):
            self.kind = "tuple"
            self.parts = [Flat(s, f"{role}[{k}]") for k, s in enumerate(space.spaces)]
            self.radices = [p.size for p in self.parts]
        else:
            self.kind = "multi"
            binary = isinstance(space, spaces.MultiBinary)
            self.radices = [2] * math.prod(space.shape) if binary else [int(n) for n in np.ravel(space.nvec)]
            # Python ints: exact whatever the dtype (an int8 value minus its start may not fit int8).
            self._offset = [0] * len(self.radices) if binary else [int(s) for s in np.ravel(space.start)]
        # A Tuple of nothing has one value, ().
        self.size = math.prod(self.radices)

    def index(self, value: Any) -> int:
        self.check(value)
        return self._index(value)

    def _index(self, value: Any) -> int:
        if self.kind == "discrete":
            return int(value) - int(self.start or 0)
        if self.kind == "tuple":
            return _sizes.ravel([p._index(v) for p, v in zip(self.parts, value)], self.radices)
        # A MultiBinary's value may be floats (0.0 and 1.0 are in it): read as the ints they are.
        return _sizes.ravel([int(x) - s for x, s in zip(np.ravel(value).tolist(), self._offset)], self.radices)

    def value(self, index: int) -> Any:
        digits = self._digits(index)
        if self.kind == "discrete":
            return int(self.start or 0) + digits[0]
        if self.kind == "tuple":
            return tuple(p.value(d) for p, d in zip(self.parts, digits))
        values = [d + s for d, s in zip(digits, self._offset)]
        return np.array(values, dtype=self.space.dtype).reshape(self.space.shape)

    def record(self) -> dict[str, Any]:
        return {"encoding": "flat", "space": space_record(self.space)}


class Hashed(Encoding):
    """A finite space's values hashed into ``size`` cells (for observations with too many values
    to flatten, such as a board of 52 cards): each value's components, in row-major order, go
    through BLAKE2b, the cell is the digest modulo ``size``. Pass it unfitted
    (``Hashed(128)``) as :class:`~cehmm.PythonWorld`'s ``observations=``.

    Example:
        >>> from gymnasium.spaces import MultiDiscrete
        >>> Hashed(16).fit(MultiDiscrete([3] * 10), "observation").index(np.full(10, 2))
        0
    """

    def __init__(self, size: int = HASHED_CELLS, space: Any = None, role: str = "observation") -> None:
        if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or not 1 <= size <= MAX_INDICES:
            raise _core.InvalidArgumentError(f"invalid Hashed size: {size!r} (expected an int in 1..={MAX_INDICES})")
        self.size = int(size)
        self.radices = [self.size]
        self.space = space
        self.role = role
        # A value's components, read the same way at every step: made once.
        self._components = None if space is None else _digits_of(space, role)

    def fit(self, space: Any, role: str) -> Hashed:
        """This encoding for ``space``: it must be finite (``Discrete``, ``MultiDiscrete``,
        ``MultiBinary`` or a ``Tuple`` of them)."""
        return Hashed(self.size, space, role)

    def index(self, value: Any) -> int:
        assert self._components is not None, "an unfitted Hashed has no space"
        self.check(value)
        digits = np.asarray(self._components(value), dtype="<i8")
        digest = hashlib.blake2b(digits.tobytes(), digest_size=8).digest()
        return int.from_bytes(digest, "little") % self.size

    def record(self) -> dict[str, Any]:
        return {"encoding": "hashed", "size": self.size, "space": space_record(self.space)}


def _digits_of(space: Any, role: str) -> Callable[[Any], list[int]]:
    """The components of a finite space's values, in row-major order."""
    spaces = gymnasium_spaces()
    if isinstance(space, spaces.Discrete):
        return lambda v: [int(v)]
    if isinstance(space, (spaces.MultiDiscrete, spaces.MultiBinary)):
        return lambda v: [int(x) for x in np.ravel(v)]
    if isinstance(space, spaces.Tuple):
        parts = [_digits_of(s, f"{role}[{k}]") for k, s in enumerate(space.spaces)]
        return lambda v: [x for p, w in zip(parts, v) for x in p(w)]
    raise _core.InvalidArgumentError(
        f"invalid {role} space: {space} cannot be hashed (expected Discrete, MultiDiscrete, MultiBinary or a Tuple of "
        "them)"
    )


class Bins(Encoding):
    """A ``Box`` observation cut into cells: dimension ``i`` at its sorted ``edges[i]`` (a value
    ``x`` falls in bin ``searchsorted(edges[i], x, side="right")``), the cell the row-major index
    of the bins. Unfitted (as :class:`~cehmm.PythonWorld`'s ``observations=``):

    * ``Bins()``: the default, ``bins`` from :data:`BINS_CELLS`, edges at quantiles of the
      observations met in ``warmup`` steps of uniformly random actions (episodes reset with seeds
      ``seed``, ``seed + 1``, ...; their infinite values, which an unbounded ``Box`` holds, fall
      in the end bins);
    * ``Bins(8, fit="bounds")``: edges evenly between the space's (finite) bounds;
    * ``Bins(edges=[[...], [...]])``: one sorted list per dimension.

    Its observations are checked against the space (its shape, its bounds, no NaN), their
    numbers whatever their dtype (float64 values for a float32 ``Box`` are read).

    Example:
        >>> from gymnasium.spaces import Box
        >>> Bins(4, fit="bounds").fit(Box(-1.0, 1.0, shape=(2,)), "observation").index([0.1, -0.9])  # bins 2, 0
        8
    """

    def __init__(
        self,
        bins: int | Sequence[int] | None = None,
        *,
        fit: str = "quantiles",
        edges: Sequence[Any] | None = None,
        warmup: int = WARMUP_STEPS,
        seed: int = 0,
        space: Any = None,
        role: str = "observation",
    ) -> None:
        if not isinstance(fit, str) or fit not in ("quantiles", "bounds"):
            raise _core.InvalidArgumentError(f"invalid Bins fit: {_shown(fit)} (expected 'quantiles' or 'bounds')")
        if not is_int(warmup) or warmup < 1:
            raise _core.InvalidArgumentError(
                f"invalid Bins warmup: {_shown(warmup)} (expected a positive int of steps)"
            )
        if not is_int(seed):
            raise _core.InvalidArgumentError(f"invalid Bins seed: {_shown(seed)} (expected an int)")
        if not (bins is None or counts(bins)):
            raise _core.InvalidArgumentError(
                f"invalid Bins bins: {_shown(bins)} (expected a positive int, at most {MAX_INDICES}, or a list of one "
                "per dimension)"
            )
        self.bins, self.fit_from, self.warmup, self.seed = bins, fit, int(warmup), int(seed)
        self.space, self.role = _box(space, role, "Bins"), role
        self.edges: list[np.ndarray] | None = None
        if edges is not None:
            given = _sizes.lists(edges, "Bins edges", "a list of lists of numbers, one per dimension")
            # The size from the lists' lengths, before any is read as numbers.
            self.size = at_most((len(e) + 1 for e in given), "cells", role, f"Bins of {space or 'edges'}", _FEWER_BINS)
            self.edges = [
                _sizes.numbers(e, f"Bins edges[{i}]", "finite numbers in increasing order") for i, e in enumerate(given)
            ]
            for i, e in enumerate(self.edges):
                if np.any(np.diff(e) <= 0):
                    raise _core.InvalidArgumentError(
                        f"invalid Bins edges[{i}]: {_shown(e.tolist())} (expected finite numbers in increasing order)"
                    )
            self.radices = [len(e) + 1 for e in self.edges]
            if space is not None:
                _per_dimension(len(self.edges), space, "Bins edges")

    def needs_warmup(self) -> bool:
        """Whether fitting reads observations of a warm-up."""
        return self.edges is None and self.fit_from == "quantiles"

    def fit(self, space: Any, role: str, sample: Callable[[int, int], Sequence[Any]] | None = None) -> Bins:
        """This encoding for the ``Box`` ``space``; ``sample(steps, seed)`` gives the observations
        of a warm-up (as the environment gave them) where the edges are quantiles.

        Raises:
            InvalidArgumentError: not a ``Box``, or too many cells (from the arithmetic of the
                bins, before any warm-up).
            WorldError: an observation of the warm-up that is not in the space.
        """
        _box(space, role, "Bins")
        if self.edges is not None:
            return Bins(edges=self.edges, space=space, role=role)
        dims = _dims(space)
        bins = self._bins(dims, space, role)
        if self.fit_from == "bounds":
            low, high = np.ravel(space.low).astype(float), np.ravel(space.high).astype(float)
            if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high))):
                raise _core.InvalidArgumentError(
                    f'invalid {role} encoding: Bins(fit="bounds") of {space}, whose bounds are not all finite '
                    '(expected fit="quantiles" or edges=...)'
                )
            edges = [np.linspace(lo, hi, b + 1)[1:-1] for lo, hi, b in zip(low, high, bins)]
        elif dims == 0:
            edges = []
        else:
            assert sample is not None, "a quantile fit needs a warm-up"
            warm = Bins(space=space, role=f"warm-up {role}")
            seen = []
            for observation in sample(self.warmup, self.seed):
                warm.check(observation)
                seen.append(np.ravel(np.asarray(observation, dtype=float)))
            columns = np.reshape(seen, (-1, dims)).T
            edges = [_quantiles(c[np.isfinite(c)], b) for c, b in zip(columns, bins)]
        return Bins(edges=edges, space=space, role=role)

    def _bins(self, dims: int, space: Any, role: str) -> list[int]:
        """The bins of each dimension, their product checked before any edge is made."""
        if self.bins is None:
            # The most b <= 16 with b**dims <= BINS_CELLS, from products that stop at the bound.
            fitting = (b for b in range(2, 17) if _sizes.product(itertools.repeat(b, dims), BINS_CELLS) <= BINS_CELLS)
            each = max(fitting, default=2)
        elif is_int(self.bins):
            each = int(self.bins)  # type: ignore[arg-type]
        else:
            bins = [int(b) for b in self.bins]  # type: ignore[union-attr]
            if len(bins) != dims:
                raise _core.InvalidArgumentError(
                    f"invalid Bins bins: {_shown(self.bins)} (expected a positive int, or one per dimension: {dims})"
                )
            at_most(bins, "cells", role, f"Bins({bins}) of {space}", _FEWER_BINS)
            return bins
        subject = f"{each} bins in each of the {dims} dimensions of {space}"
        at_most(itertools.repeat(each, dims), "cells", role, subject, _FEWER_BINS)
        return [each] * dims

    def check(self, value: Any) -> None:
        if isinstance(value, (np.ndarray, np.generic)) and np.asarray(value).dtype.kind not in "biuf":
            super().check(np.asarray(value))
            return
        # Its numbers, against the shape and the bounds, whatever their dtype: an environment
        # that returns float64 values for a float32 Box (a common slip, which Gymnasium's own
        # checker only warns of) is read, as long as the values are in the space (whole numbers
        # for an integer Box).
        read = _sizes.reals(value)
        if (
            read is None
            or read.shape != self.space.shape
            or not np.all((read >= self.space.low) & (read <= self.space.high))
            or (np.issubdtype(self.space.dtype, np.integer) and not np.all(read == np.round(read)))
        ):
            self._refuse(value)

    def index(self, value: Any) -> int:
        assert self.edges is not None, "an unfitted Bins has no cells"
        self.check(value)
        x = np.ravel(np.asarray(value, dtype=float))
        return _sizes.ravel([int(np.searchsorted(e, v, side="right")) for e, v in zip(self.edges, x)], self.radices)

    def record(self) -> dict[str, Any]:
        assert self.edges is not None
        return {"encoding": "bins", "edges": [e.tolist() for e in self.edges], "space": space_record(self.space)}


class Grid(Encoding):
    """A ``Box`` action as a finite set: dimension ``i`` takes one of ``values[i]`` (by default
    ``values`` evenly spaced values between its finite bounds, both included; of an integer
    ``Box``, those rounded to integers), a decision the row-major index of the choices. Unfitted:
    ``Grid()``, ``Grid(9)``, ``Grid(values=[[-2, 0, 2]])``; given values must be of the space
    (within its bounds, integers for an integer ``Box``): none is cast.

    Example:
        >>> from gymnasium.spaces import Box
        >>> Grid(3).fit(Box(-2.0, 2.0, shape=(1,)), "action").value(2)  # of -2, 0, 2
        array([2.], dtype=float32)
    """

    def __init__(
        self,
        values: int | Sequence[Any] = GRID_VALUES,
        *,
        space: Any = None,
        role: str = "action",
    ) -> None:
        self.space, self.role = _box(space, role, "Grid"), role
        self.count: int | None = None
        self.values: list[np.ndarray] | None = None
        if is_int(values):
            if not 1 <= values <= MAX_INDICES:  # type: ignore[operator]
                raise _core.InvalidArgumentError(
                    f"invalid Grid values: {values!r} (expected a positive int of values a dimension, at most "
                    f"{MAX_INDICES}, or a list of values a dimension)"
                )
            self.count = int(values)  # type: ignore[arg-type]
            return
        given = _sizes.lists(values, "Grid values", "a positive int, or a list of values a dimension")
        self.size = at_most((len(v) for v in given), "actions", role, f"Grid of {space or 'values'}", "fewer values")
        expected = "a non-empty list of finite numbers"
        self.values = [_sizes.numbers(v, f"Grid values[{i}]", expected, least=1) for i, v in enumerate(given)]
        self.radices = [len(v) for v in self.values]
        if space is not None:
            self._check_in(space, role)

    def _check_in(self, space: Any, role: str) -> None:
        """Refuses values that are not of ``space``: one list per dimension, each value within the
        dimension's bounds and of the space's dtype (an integer for an integer ``Box``)."""
        assert self.values is not None
        _per_dimension(len(self.values), space, "Grid values")
        integer = space.dtype.kind in "biu"
        kind = "an integer" if integer else f"a {space.dtype} number"
        limits = dtype_limits(space.dtype)
        for i, (v, lo, hi) in enumerate(zip(self.values, np.ravel(space.low).tolist(), np.ravel(space.high).tolist())):
            lo, hi = max(lo, limits[0]), min(hi, limits[1])
            for x in v.tolist():
                outside = (x != round(x) or not lo <= round(x) <= hi) if integer else not lo <= x <= hi
                if outside:
                    raise _core.InvalidArgumentError(
                        f"invalid Grid values[{i}]: {x!r} (expected {kind} in [{lo}, {hi}]: dimension {i} of the "
                        f"{role} space {space})"
                    )

    def fit(self, space: Any, role: str) -> Grid:
        """This encoding for the ``Box`` ``space``.

        Raises:
            InvalidArgumentError: not a ``Box``, too many actions (from the arithmetic of the
                values, before any is made), or values that are not of the space.
        """
        _box(space, role, "Grid")
        if self.values is not None:
            return Grid(self.values, space=space, role=role)
        count, dims = self.count or GRID_VALUES, _dims(space)
        subject = f"{count} values in each of the {dims} dimensions of {space}"
        at_most(itertools.repeat(count, dims), "actions", role, subject, "fewer values")
        low, high = np.ravel(space.low).astype(float), np.ravel(space.high).astype(float)
        if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high))):
            raise _core.InvalidArgumentError(
                f"invalid {role} space: {space} has bounds that are not finite (expected Grid(values=[[...], ...]))"
            )
        values = [np.linspace(lo, hi, count) for lo, hi in zip(low, high)]
        if space.dtype.kind in "biu":
            # Integers only: the rounded values that are of the space (a bound past 2**53 is not a float).
            exact = zip(values, np.ravel(space.low).tolist(), np.ravel(space.high).tolist())
            values = [np.array([x for x in np.unique(np.round(v)) if lo <= int(x) <= hi]) for v, lo, hi in exact]
        return Grid(values, space=space, role=role)

    def index(self, value: Any) -> int:
        """The index of the grid's nearest action (each dimension's nearest value)."""
        assert self.values is not None
        x = _sizes.reals(value)
        if x is None or x.size != len(self.values) or not np.all(np.isfinite(x)):
            self._refuse(value)
        assert x is not None
        digits = [int(np.argmin(np.abs(v - c))) for v, c in zip(self.values, np.ravel(x))]
        return _sizes.ravel(digits, self.radices)

    def value(self, index: int) -> Any:
        assert self.values is not None
        chosen = np.array([v[d] for v, d in zip(self.values, self._digits(index))])
        return chosen.astype(self.space.dtype).reshape(self.space.shape)

    def record(self) -> dict[str, Any]:
        assert self.values is not None
        return {"encoding": "grid", "values": [v.tolist() for v in self.values], "space": space_record(self.space)}


def encoding(
    space: Any,
    role: str,
    choice: Any = None,
    sample: Callable[[int, int], Sequence[Any]] | None = None,
) -> Encoding:
    """The fitted encoding of ``space`` (``role``: ``"observation"`` or ``"action"``) from the
    user's ``choice`` (``None``: the default of the module docstring; an encoding, fitted or
    not); ``sample(steps, seed)`` gives a warm-up's observations where a fit needs them.

    Example:
        >>> from gymnasium.spaces import Box, Discrete
        >>> type(encoding(Discrete(5), "observation")).__name__, type(encoding(Box(-1.0, 1.0), "action")).__name__
        ('Flat', 'Grid')
        >>> bins = encoding(Box(-1.0, 1.0, shape=(2,)), "observation", Bins(4, fit="bounds"))
        >>> bins.index(np.array([0.1, -0.9], dtype=np.float32))
        8
    """
    spaces = gymnasium_spaces()
    if choice is None:
        if isinstance(space, spaces.Box):
            choice = Bins() if role == "observation" else Grid()
        elif role == "observation" and _finite_size(space, MAX_FLAT) > MAX_FLAT:
            choice = Hashed()
        else:
            return Flat(space, role)
    if isinstance(choice, Flat):
        return Flat(space, role)
    if isinstance(choice, Hashed):
        if role != "observation":
            raise _core.InvalidArgumentError(f"invalid {role} encoding: Hashed (expected Flat or Grid for actions)")
        return choice.fit(space, role)
    if isinstance(choice, Bins):
        if role != "observation":
            raise _core.InvalidArgumentError(f"invalid {role} encoding: Bins (expected Flat or Grid for actions)")
        return choice.fit(space, role, sample if choice.needs_warmup() else None)
    if isinstance(choice, Grid):
        if role != "action":
            raise _core.InvalidArgumentError(f"invalid {role} encoding: Grid (expected Flat, Hashed or Bins)")
        return choice.fit(space, role)
    if isinstance(choice, str) and choice == "flat":
        return Flat(space, role)
    raise TypeError(
        f"invalid {role}s: {_shown(choice)} (expected None, 'flat' or a cehmm.spaces encoding: Flat, Hashed, Bins, "
        "Grid)"
    )


# -- the checks of spaces and their sizes (the arithmetic: cehmm._sizes) -----------------------------

_FEWER_BINS = "fewer bins, or a wrapper that keeps the dimensions that matter"


def _finite_size(space: Any, cap: int) -> int:
    """The values of a finite space, or ``cap + 1`` past ``cap`` (0 where it is not one of the
    finite kinds: Flat names it)."""
    spaces = gymnasium_spaces()
    if isinstance(space, spaces.Discrete):
        return min(int(space.n), cap + 1)
    if isinstance(space, spaces.MultiDiscrete):
        return _sizes.product(np.ravel(space.nvec).tolist(), cap)
    if isinstance(space, spaces.MultiBinary):
        return _sizes.product(itertools.repeat(2, math.prod(space.shape)), cap)
    if isinstance(space, spaces.Tuple):
        return _sizes.product((_finite_size(s, cap) for s in space.spaces), cap)
    return 0


def _dims(space: Any) -> int:
    """The dimensions of a ``Box`` (its shape's product, 0 for an empty one)."""
    return math.prod(space.shape)


def _per_dimension(lists: int, space: Any, name: str) -> None:
    """Refuses a number of lists that is not one per dimension of ``space``."""
    if lists != _dims(space):
        raise _core.InvalidArgumentError(
            f"invalid {name}: {lists} lists for {space} (expected one per dimension, {_dims(space)})"
        )


def _box(space: Any, role: str, name: str) -> Any:
    """``space`` (or None), refused unless it is a ``Box``."""
    if space is not None and not isinstance(space, gymnasium_spaces().Box):
        raise _core.InvalidArgumentError(f"invalid {role} encoding: {name} of {space} (expected a Box space)")
    return space


def _quantiles(column: np.ndarray, bins: int) -> np.ndarray:
    """The edges of ``bins`` bins at quantiles of ``column`` (none where it is empty)."""
    if column.size == 0:
        return np.empty(0)
    return np.unique(np.quantile(column, np.linspace(0, 1, bins + 1)[1:-1]))


__all__ = ["Bins", "Flat", "Grid", "Hashed", "encoding"]
