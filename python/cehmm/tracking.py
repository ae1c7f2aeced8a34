"""The paper's example world: two slow mobiles tracking an evasive target on a grid (model §4)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from . import _core
from ._validate import invalid

_NAME = "target-tracking"
_DEFAULTS: dict[str, Any] = _core.TargetTracking().params


class TargetTracking:
    """The target-tracking world of the paper (section 5) under the conventions of model §4.

    A ``width × height`` grid (20 × 20); mobiles B and C start in the bottom corners facing down
    and each turn left, turn right, move forward or stay (16 joint decisions); a step is rewarded
    when a mobile is within Chebyshev distance ``reward_radius`` (3) of the target; an episode has
    ``horizon`` (100) steps and its reward is the number of rewarded steps.

    * ``case=1``: the target stays at ``target_cell``; 16 observations.
    * ``case=2``: the target starts uniformly on rows ``target_rows`` and flees; a single, constant
      observation.
    * ``case=3``: as case 2, with the 16 observations (per mobile: target ahead, target near).

    Args:
        case: 1, 2 or 3.
        **params: any other world parameter: ``width``, ``height``, ``horizon``, ``start_b``,
            ``start_c``, ``start_heading``, ``reward_radius``, ``observe_radius``,
            ``target_cell``, ``target_rows`` (cells and row ranges as ``[a, b]``).

    Raises:
        InvalidArgumentError: an unknown parameter (the message lists the valid ones) or a value
            out of its range.

    Example:
        >>> world = TargetTracking(case=1, horizon=50)
        >>> world.optimum()
        36
    """

    __slots__ = ("_core",)

    def __init__(self, case: int = 3, **params: Any) -> None:
        if case is None:
            raise invalid("case", case, "1, 2 or 3")
        self._core = _core.TargetTracking(case, **params)

    @classmethod
    def from_dict(cls, world: Mapping[str, Any]) -> TargetTracking:
        """The world described by a policy file's ``"world"`` object (or :attr:`params`)."""
        if not isinstance(world, Mapping):
            raise invalid("world", world, "a dict of world parameters")
        params = dict(world)
        name = params.pop("name", _NAME)
        if name != _NAME:
            raise invalid("world.name", name, repr(_NAME))
        return cls(**params)

    @classmethod
    def _wrap(cls, core: _core.TargetTracking) -> TargetTracking:
        world = cls.__new__(cls)
        world._core = core
        return world

    @property
    def case(self) -> int:
        """1: fixed target; 2: moving target, unobserved; 3: moving target, observed."""
        return self._core.case

    @property
    def n_observations(self) -> int:
        """Number of observations ``Y`` (16, or 1 in case 2)."""
        return self._core.n_observations

    @property
    def n_decisions(self) -> int:
        """Number of decisions ``D`` (16)."""
        return self._core.n_decisions

    @property
    def horizon(self) -> int:
        """Steps per episode ``T``."""
        return self._core.horizon

    @property
    def params(self) -> dict[str, Any]:
        """Every parameter, ``case`` included (a fresh dict)."""
        return self._core.params

    @property
    def state_labels(self) -> list[str]:
        """Names of the columns of a rollout's ``x``."""
        return self._core.state_labels()

    def to_dict(self) -> dict[str, Any]:
        """The world as stored in policy files: ``{"name": "target-tracking", **params}``."""
        return self._core.to_dict()

    def optimum(self) -> int:
        """The exact optimum of the mean reward (case 1 only: 86 with the defaults).

        Raises:
            InvalidArgumentError: for cases 2 and 3, whose optimum is unknown.
        """
        return self._core.optimum()

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, TargetTracking):
            return NotImplemented
        return self.params == other.params

    def __hash__(self) -> int:
        return hash(tuple((k, tuple(v) if isinstance(v, list) else v) for k, v in sorted(self.params.items())))

    def __reduce__(self) -> tuple[Any, ...]:
        return (_rebuild, (self.params,))

    def __repr__(self) -> str:
        params = self.params
        changed = [f"{k}={v!r}" for k, v in params.items() if k != "case" and v != _DEFAULTS.get(k)]
        shown = ["case=" + repr(params["case"]), *changed]
        return "TargetTracking(" + ", ".join(shown) + ")"


def _rebuild(params: dict[str, Any]) -> TargetTracking:
    return TargetTracking(**params)


def core_world(world: Any) -> _core.TargetTracking:
    """The compiled world behind ``world``, or an :class:`InvalidArgumentError`."""
    if isinstance(world, TargetTracking):
        return world._core
    raise invalid("world", world, "a cehmm.TargetTracking")
