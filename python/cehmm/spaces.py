"""Gymnasium spaces as the finite indices a policy reads and writes, and back: the encodings
that policy files record (docs/python-worlds.md, "Spaces").

A policy's observation ``y`` and decision ``d`` are indices ``0..size``. An environment's values
map to them through an encoding of its space, chosen by :class:`~cehmm.PythonWorld`
(``observations=``, ``actions=``) or by default:

* :class:`Flat` (finite spaces, the default where they have at most :data:`MAX_FLAT` values):
  ``Discrete(n, start)`` gives ``x - start``; a ``MultiDiscrete`` or ``MultiBinary`` its
  components in row-major order (the last one varying fastest, as ``numpy.ravel_multi_index``);
  a ``Tuple`` its components' indices in the same order. Exact both ways.
* :class:`Hashed` (finite observations with more values, the default there: ``Hashed(256)``):
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
import math
from collections.abc import Callable, Iterable, Sequence
from typing import Any

import numpy as np

from . import _core

#: The most values a finite observation space is flattened over by default (more: hashed).
MAX_FLAT = 4096
#: The cells of the default :class:`Hashed` encoding: a 64-node Mealy controller over 256 cells
#: and 104 decisions saves as at most 109 million entries (model §8), within the engine's bound.
HASHED_CELLS = 256
#: The most cells of a default :class:`Bins` encoding (bins per dimension: the most ``b <= 16``
#: with ``b ** dims <= 64``, at least 2).
BINS_CELLS = 64
#: Steps of random actions the default :class:`Bins` fits its quantiles on.
WARMUP_STEPS = 2000
#: Values per dimension of the default :class:`Grid`.
GRID_VALUES = 5
#: The most indices the engine takes (its observations are 16-bit).
MAX_INDICES = 65535


def gymnasium() -> Any:
    """The ``gymnasium`` module, or an ``ImportError`` that says how to install it."""
    try:
        import gymnasium
    except ImportError as e:  # pragma: no cover - the test extra installs it
        raise ImportError("Gymnasium environments need gymnasium: pip install 'cehmm[gym]'") from e
    return gymnasium


def _gymnasium_spaces() -> Any:
    return gymnasium().spaces


class Encoding:
    """A space's values as indices ``0..size`` (subclasses below). ``role`` names it in errors."""

    space: Any
    role: str
    size: int

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
        spaces = _gymnasium_spaces()
        self.space = space
        self.role = role
        self.start: int | None = None
        self.parts: list[Flat] = []
        if isinstance(space, spaces.Discrete):
            self.kind = "discrete"
            self.radices = [int(space.n)]
            self.start = int(space.start)
        elif isinstance(space, (spaces.MultiDiscrete, spaces.MultiBinary)):
            self.kind = "multi"
            nvec = np.full(space.shape, 2) if isinstance(space, spaces.MultiBinary) else space.nvec
            self.radices = [int(n) for n in np.ravel(nvec)]
            self._offset = np.ravel(getattr(space, "start", np.zeros_like(nvec)))
        elif isinstance(space, spaces.Tuple):
            self.kind = "tuple"
            self.parts = [Flat(s, f"{role}[{k}]") for k, s in enumerate(space.spaces)]
            self.radices = [p.size for p in self.parts]
        else:
            hint = (
                " is continuous (expected a finite space: a Box is encoded by cehmm.spaces.Bins for observations "
                "and cehmm.spaces.Grid for actions)"
                if isinstance(space, spaces.Box)
                else " (expected Discrete, MultiDiscrete, MultiBinary, a Tuple of them, or a Box)"
            )
            raise _core.InvalidArgumentError(f"invalid {role} space: {space}{hint}")
        # Exact (Python ints): numpy's int64 product wraps silently past 2**63. A Tuple of
        # nothing has one value, ().
        self.size = math.prod(self.radices)
        if self.size > 2**63 - 1:
            raise _core.InvalidArgumentError(
                f"invalid {role} space: {space} has {self.size} values (at most 2**63 - 1 can be indexed; "
                "observations that many are hashed: cehmm.spaces.Hashed)"
            )

    def index(self, value: Any) -> int:
        self.check(value)
        return self._index(value)

    def _index(self, value: Any) -> int:
        if self.kind == "discrete":
            return int(value) - int(self.start or 0)
        if self.kind == "tuple":
            return int(np.ravel_multi_index([p._index(v) for p, v in zip(self.parts, value)], self.radices))
        return int(np.ravel_multi_index(np.ravel(value) - self._offset, self.radices))

    def value(self, index: int) -> Any:
        if self.kind == "discrete":
            return int(self.start or 0) + int(index)
        digits = np.unravel_index(int(index), self.radices)
        if self.kind == "tuple":
            return tuple(p.value(d) for p, d in zip(self.parts, digits))
        return (np.asarray(digits) + self._offset).astype(self.space.dtype).reshape(self.space.shape)

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
        self.space = space
        self.role = role
        # A value's components, read the same way at every step: made once.
        self._digits = None if space is None else _digits_of(space, role)

    def fit(self, space: Any, role: str) -> Hashed:
        """This encoding for ``space``: it must be finite (``Discrete``, ``MultiDiscrete``,
        ``MultiBinary`` or a ``Tuple`` of them)."""
        return Hashed(self.size, space, role)

    def index(self, value: Any) -> int:
        assert self._digits is not None, "an unfitted Hashed has no space"
        self.check(value)
        digits = np.asarray(self._digits(value), dtype="<i8")
        digest = hashlib.blake2b(digits.tobytes(), digest_size=8).digest()
        return int.from_bytes(digest, "little") % self.size

    def record(self) -> dict[str, Any]:
        return {"encoding": "hashed", "size": self.size, "space": space_record(self.space)}


def _digits_of(space: Any, role: str) -> Callable[[Any], list[int]]:
    """The components of a finite space's values, in row-major order."""
    spaces = _gymnasium_spaces()
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
      ``seed``, ``seed + 1``, ...);
    * ``Bins(8, fit="bounds")``: edges evenly between the space's (finite) bounds;
    * ``Bins(edges=[[...], [...]])``: one sorted list per dimension.

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
        edges: Sequence[Sequence[float]] | None = None,
        warmup: int = WARMUP_STEPS,
        seed: int = 0,
        space: Any = None,
        role: str = "observation",
    ) -> None:
        if fit not in ("quantiles", "bounds"):
            raise _core.InvalidArgumentError(f"invalid Bins fit: {fit!r} (expected 'quantiles' or 'bounds')")
        if isinstance(warmup, bool) or not isinstance(warmup, (int, np.integer)) or warmup < 1:
            raise _core.InvalidArgumentError(f"invalid Bins warmup: {warmup!r} (expected a positive int of steps)")
        self.bins, self.fit_from, self.warmup, self.seed = bins, fit, int(warmup), int(seed)
        self.space, self.role = space, role
        self.edges: list[np.ndarray] | None = None
        if edges is not None:
            self.edges = [np.asarray(e, dtype=float) for e in edges]
            for i, e in enumerate(self.edges):
                if e.ndim != 1 or not np.all(np.isfinite(e)) or np.any(np.diff(e) <= 0):
                    raise _core.InvalidArgumentError(
                        f"invalid Bins edges[{i}]: {_shown(e.tolist())} (expected finite numbers in increasing order)"
                    )
            self.radices = [len(e) + 1 for e in self.edges]
            self.size = math.prod(self.radices)

    def needs_warmup(self) -> bool:
        """Whether fitting reads observations of a warm-up."""
        return self.edges is None and self.fit_from == "quantiles"

    def fit(self, space: Any, role: str, sample: Callable[[int, int], np.ndarray] | None = None) -> Bins:
        """This encoding for the ``Box`` ``space``; ``sample(steps, seed)`` gives observations
        (rows) of a warm-up where the edges are quantiles."""
        spaces = _gymnasium_spaces()
        if not isinstance(space, spaces.Box):
            raise _core.InvalidArgumentError(f"invalid {role} encoding: Bins of {space} (expected a Box space)")
        dims = int(np.prod(space.shape))
        if self.edges is not None:
            edges = self.edges
        else:
            bins = self._bins(dims, role)
            low, high = np.ravel(space.low).astype(float), np.ravel(space.high).astype(float)
            if self.fit_from == "bounds":
                if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high))):
                    raise _core.InvalidArgumentError(
                        f'invalid {role} encoding: Bins(fit="bounds") of {space}, whose bounds are not all finite '
                        '(expected fit="quantiles" or edges=...)'
                    )
                edges = [np.linspace(lo, hi, b + 1)[1:-1] for lo, hi, b in zip(low, high, bins)]
            else:
                assert sample is not None, "a quantile fit needs a warm-up"
                seen = np.asarray(sample(self.warmup, self.seed), dtype=float).reshape(-1, dims)
                edges = [np.unique(np.quantile(seen[:, i], np.linspace(0, 1, b + 1)[1:-1])) for i, b in enumerate(bins)]
        if len(edges) != dims:
            raise _core.InvalidArgumentError(
                f"invalid Bins edges: {len(edges)} lists for {space} (expected one per dimension, {dims})"
            )
        fitted = Bins(edges=[e.tolist() for e in edges], space=space, role=role)
        if fitted.size > MAX_INDICES:
            raise _core.InvalidArgumentError(
                f"invalid {role} encoding: {fitted.size} cells of {space} (at most {MAX_INDICES}: fewer bins, or a "
                "wrapper that keeps the dimensions that matter)"
            )
        return fitted

    def _bins(self, dims: int, role: str) -> list[int]:
        if self.bins is None:
            per = max((b for b in range(2, 17) if b**dims <= BINS_CELLS), default=2)
            return [per] * dims
        bins = [self.bins] * dims if isinstance(self.bins, (int, np.integer)) else list(self.bins)
        if len(bins) != dims or any(isinstance(b, bool) or not isinstance(b, (int, np.integer)) or b < 1 for b in bins):
            raise _core.InvalidArgumentError(
                f"invalid Bins bins: {self.bins!r} (expected a positive int, or one per dimension: {dims})"
            )
        return [int(b) for b in bins]

    def index(self, value: Any) -> int:
        assert self.edges is not None, "an unfitted Bins has no cells"
        x = _floats(value)
        if x is None or x.shape != tuple(self.space.shape) or not np.all(np.isfinite(x)):
            self._refuse(value)
        digits = [int(np.searchsorted(e, v, side="right")) for e, v in zip(self.edges, np.ravel(x))]
        return int(np.ravel_multi_index(digits, self.radices))

    def record(self) -> dict[str, Any]:
        assert self.edges is not None
        return {"encoding": "bins", "edges": [e.tolist() for e in self.edges], "space": space_record(self.space)}


class Grid(Encoding):
    """A ``Box`` action as a finite set: dimension ``i`` takes one of ``values[i]`` (by default
    ``values`` evenly spaced values between its finite bounds, both included), a decision the
    row-major index of the choices. Unfitted: ``Grid()``, ``Grid(9)``, ``Grid(values=[[-2, 0, 2]])``.

    Example:
        >>> from gymnasium.spaces import Box
        >>> Grid(3).fit(Box(-2.0, 2.0, shape=(1,)), "action").value(2)  # of -2, 0, 2
        array([2.], dtype=float32)
    """

    def __init__(
        self,
        values: int | Sequence[Sequence[float]] = GRID_VALUES,
        *,
        space: Any = None,
        role: str = "action",
    ) -> None:
        self.space, self.role = space, role
        self.count: int | None = None
        self.values: list[np.ndarray] | None = None
        if isinstance(values, (int, np.integer)) and not isinstance(values, bool):
            if values < 1:
                raise _core.InvalidArgumentError(f"invalid Grid values: {values!r} (expected a positive int)")
            self.count = int(values)
        else:
            self.values = [np.asarray(v, dtype=float) for v in values]
            if any(v.ndim != 1 or v.size == 0 or not np.all(np.isfinite(v)) for v in self.values):
                raise _core.InvalidArgumentError(
                    f"invalid Grid values: {_shown(values)} (expected a non-empty list of finite numbers a dimension)"
                )
            self.radices = [len(v) for v in self.values]
            self.size = math.prod(self.radices)

    def fit(self, space: Any, role: str) -> Grid:
        """This encoding for the ``Box`` ``space``."""
        spaces = _gymnasium_spaces()
        if not isinstance(space, spaces.Box):
            raise _core.InvalidArgumentError(f"invalid {role} encoding: Grid of {space} (expected a Box space)")
        dims = int(np.prod(space.shape))
        if self.values is None:
            low, high = np.ravel(space.low).astype(float), np.ravel(space.high).astype(float)
            if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high))):
                raise _core.InvalidArgumentError(
                    f"invalid {role} space: {space} has bounds that are not finite (expected Grid(values=[[...], ...]))"
                )
            values = [np.linspace(lo, hi, self.count or GRID_VALUES) for lo, hi in zip(low, high)]
        else:
            values = self.values
        if len(values) != dims:
            raise _core.InvalidArgumentError(
                f"invalid Grid values: {len(values)} lists for {space} (expected one per dimension, {dims})"
            )
        fitted = Grid([v.tolist() for v in values], space=space, role=role)
        if fitted.size > MAX_INDICES:
            raise _core.InvalidArgumentError(
                f"invalid {role} encoding: {fitted.size} actions of {space} (at most {MAX_INDICES}: fewer values)"
            )
        return fitted

    def index(self, value: Any) -> int:
        """The index of the grid's nearest action (each dimension's nearest value)."""
        assert self.values is not None
        x = np.ravel(np.asarray(value, dtype=float))
        if x.size != len(self.values):
            self._refuse(value)
        digits = [int(np.argmin(np.abs(v - c))) for v, c in zip(self.values, x)]
        return int(np.ravel_multi_index(digits, self.radices))

    def value(self, index: int) -> Any:
        assert self.values is not None
        digits = np.unravel_index(int(index), self.radices)
        chosen = np.array([v[d] for v, d in zip(self.values, digits)])
        return chosen.astype(self.space.dtype).reshape(self.space.shape)

    def record(self) -> dict[str, Any]:
        assert self.values is not None
        return {"encoding": "grid", "values": [v.tolist() for v in self.values], "space": space_record(self.space)}


def encoding(
    space: Any,
    role: str,
    choice: Any = None,
    sample: Callable[[int, int], np.ndarray] | None = None,
) -> Encoding:
    """The fitted encoding of ``space`` (``role``: ``"observation"`` or ``"action"``) from the
    user's ``choice`` (``None``: the default of the module docstring; an encoding, fitted or
    not); ``sample(steps, seed)`` gives a warm-up's observations where a fit needs them.

    Example:
        >>> from gymnasium.spaces import Box, Discrete
        >>> type(encoding(Discrete(5), "observation")).__name__, type(encoding(Box(-1.0, 1.0), "action")).__name__
        ('Flat', 'Grid')
        >>> encoding(Box(-1.0, 1.0, shape=(2,)), "observation", Bins(4, fit="bounds")).index(np.array([0.1, -0.9]))
        8
    """
    spaces = _gymnasium_spaces()
    if choice is None:
        if isinstance(space, spaces.Box):
            choice = Bins() if role == "observation" else Grid()
        elif role == "observation" and _finite_size(space) > MAX_FLAT:
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
    if choice == "flat":
        return Flat(space, role)
    raise TypeError(
        f"invalid {role}s: {choice!r} (expected None, 'flat' or a cehmm.spaces encoding: Flat, Hashed, Bins, Grid)"
    )


def _finite_size(space: Any) -> int:
    """The values of a finite space (0 where it is not one of the finite kinds: Flat names it)."""
    spaces = _gymnasium_spaces()
    if isinstance(space, spaces.Discrete):
        return int(space.n)
    if isinstance(space, spaces.MultiDiscrete):
        return math.prod(int(n) for n in np.ravel(space.nvec))
    if isinstance(space, spaces.MultiBinary):
        return 2 ** int(np.prod(space.shape))
    if isinstance(space, spaces.Tuple):
        return math.prod(_finite_size(s) for s in space.spaces)
    return 0


# -- records: what a policy file holds --------------------------------------------------------------


def space_record(space: Any) -> dict[str, Any]:
    """A Gymnasium space as JSON (infinite bounds as the strings ``"inf"``, ``"-inf"``)."""
    spaces = _gymnasium_spaces()
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
    return [float(b) if np.isfinite(b) else ("inf" if b > 0 else "-inf") for b in np.ravel(bounds)]


def space_of(record: dict[str, Any]) -> Any:
    """The Gymnasium space of a :func:`space_record`."""
    spaces = _gymnasium_spaces()
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
        low = np.array([float(b) for b in record["low"]], dtype=dtype).reshape(shape)
        high = np.array([float(b) for b in record["high"]], dtype=dtype).reshape(shape)
        return spaces.Box(low, high, shape=shape, dtype=dtype)
    raise _core.PolicyFormatError(f"invalid space record: {_shown(record)} (expected a type Discrete, ..., Box)")


def _floats(value: Any) -> np.ndarray | None:
    """A value as an array of floats, or None where it is not numbers."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return None


def _shown(value: Any) -> str:
    """A value as an error shows it: its repr, cut at 80 characters."""
    text = repr(value)
    return text if len(text) <= 80 else text[:79] + "…"


__all__: Iterable[str] = ["Bins", "Flat", "Grid", "Hashed", "encoding"]
