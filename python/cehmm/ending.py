"""What every optimiser's result shares: :class:`Ending`, how its run ended, and the making of a
result from the dict the engine returns.

A result's fields are named twice: once in the engine's summary that the bindings hand on
(``ceworld::ce::record::Ending``, ``CeSummary``, ``ControllerSummary``, serialised by name), once
in the class a user reads (:class:`cehmm.OptimizeResult`, :class:`cehmm.ControllerResult`,
:class:`cehmm.RunResult`, each an :class:`Ending`); the class is made from the dict by name, so a
field one side lacks fails at once (``tests/test_signatures.py`` runs each).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, TypeVar

from .policy import Policy
from .results import evaluation

_Result = TypeVar("_Result", bound="Ending")


@dataclass(frozen=True, eq=False)
class Ending:
    """How an optimiser's run ended: the fields that :class:`cehmm.OptimizeResult`,
    :class:`cehmm.ControllerResult` and :class:`cehmm.RunResult` share (the engine's
    ``ceworld::ce::record::Ending``).

    Attributes:
        stop_reason: why it stopped: ``"patience"``, ``"max_iterations"``, ``"time_limit"``,
            ``"max_env_steps"``, ``"target"``, ``"callback"`` (``callback=`` returned ``False``)
            or ``"interrupted"`` (Ctrl-C).
        seconds: wall time, every run and session together, the final evaluation included.
        env_steps: the world's steps learning took, every run and session together (0 on exact
            values).
        eval_env_steps: the world's steps of the final evaluation, counted apart.
    """

    stop_reason: str
    seconds: float
    env_steps: int
    eval_env_steps: int

    @property
    def interrupted(self) -> bool:
        """Whether Ctrl-C (or an exception in the callback) stopped it."""
        return self.stop_reason == "interrupted"

    @classmethod
    def _from_core(cls: type[_Result], raw: Mapping[str, Any]) -> _Result:
        """The result of the engine's dict, field by field: its policies as :class:`cehmm.Policy`,
        its evaluation as :class:`Evaluation`."""
        translated = {key: Policy(raw[key]) for key in ("policy", "last_policy") if key in raw}
        found = raw.get("evaluation")
        return cls(**{**raw, **translated, "evaluation": None if found is None else evaluation(found)})
