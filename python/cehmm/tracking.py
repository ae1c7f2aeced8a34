"""The paper's example world: two slow mobiles tracking an evasive target on a grid (model §4)."""

from __future__ import annotations

from typing import Any

from . import _core
from .world import World


class TargetTracking(World):
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
        TypeError: a parameter of the wrong type.

    Example:
        >>> world = TargetTracking(case=1, horizon=50)
        >>> world.optimum()
        36
    """

    __slots__ = ()

    registered_name = "target-tracking"

    def __init__(self, case: int = 3, **params: Any) -> None:
        self._core = _core.World(self.registered_name, case=case, **params)

    @property
    def case(self) -> int:
        """1: fixed target; 2: moving target, unobserved; 3: moving target, observed."""
        return self.params["case"]

    def optimum(self) -> int:
        """The exact optimum of the mean reward (case 1 only: 86 with the defaults).

        Raises:
            InvalidArgumentError: for cases 2 and 3, whose optimum is unknown.
        """
        return round(self._core.exact_optimum())

    def __repr__(self) -> str:
        defaults = _core.World.defaults(self.registered_name)
        params = self.params
        changed = [f"{k}={v!r}" for k, v in params.items() if k != "case" and v != defaults.get(k)]
        return "TargetTracking(" + ", ".join(["case=" + repr(params["case"]), *changed]) + ")"
