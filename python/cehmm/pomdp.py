"""Tabular POMDPs read from Cassandra ``.pomdp`` files and APPL ``.pomdpx`` files (model §7)."""

from __future__ import annotations

import os
from typing import Any, Union

import numpy as np

from . import _core
from .world import World

PathLike = Union[str, "os.PathLike[str]"]


class PomdpWorld(World):
    """A tabular POMDP read from a Cassandra ``.pomdp`` file or an APPL ``.pomdpx`` file (model §7).

    A ``.pomdpx`` file (told by its content: an XML document) is flattened: a state is a value of
    every state variable, named by the values joined with ``_`` (an action, an observation
    likewise); a fully observed state variable is part of the observation.

    An observation follows each action and none precedes the first: at ``t = 1`` the world
    emits the start symbol ``len(observations)``, so a policy sees ``len(observations) + 1``
    observations. An episode has ``horizon`` steps and its reward is
    ``Σ_{t=1..H} γ^(t-1) r_t`` with ``r_t = R(s_t, a_t, s_{t+1}, o_{t+1})`` (costs negated; ``γ``
    the file's discount, 1 when it has none, unless ``discount`` is given). With
    ``reward="belief"`` a step adds instead the expectation of its reward given what the policy
    has seen (same expected value, less noise for the cross-entropy method).

    The policy files of such a world record the file's name and SHA-256: a policy is never
    evaluated on another model by mistake.

    Raises:
        ModelFormatError: the file is not a valid ``.pomdp`` or ``.pomdpx`` file (the message names
            the line and column, what was found and what was expected).
        OSError: the file cannot be read.

    Example:
        >>> world = PomdpWorld.from_file("data/pomdp/tiger.95.POMDP", horizon=100)
        >>> world.actions
        ['listen', 'open-left', 'open-right']
    """

    __slots__ = ("_model",)

    registered_name = "pomdp"

    def __init__(
        self,
        file: PathLike,
        horizon: int = 100,
        discount: float | None = None,
        reward: str = "sampled",
        **params: Any,
    ) -> None:
        self._core = _core.World(
            self.registered_name, file=os.fsdecode(file), horizon=horizon, discount=discount, reward=reward, **params
        )

    @classmethod
    def from_file(
        cls, path: PathLike, horizon: int = 100, discount: float | None = None, reward: str = "sampled"
    ) -> PomdpWorld:
        """The world of the ``.pomdp`` or ``.pomdpx`` file ``path`` with episodes of ``horizon`` steps."""
        return cls(path, horizon=horizon, discount=discount, reward=reward)

    def _tables(self) -> dict[str, Any]:
        try:
            return self._model
        except AttributeError:
            self._model: dict[str, Any] = self._core.model()
            return self._model

    @property
    def file(self) -> str:
        """The ``.pomdp`` or ``.pomdpx`` file, as given."""
        return self.params["file"]

    @property
    def sha256(self) -> str:
        """The SHA-256 of the file's bytes."""
        return self.params["sha256"]

    @property
    def states(self) -> list[str]:
        """State names (``"0"``, ``"1"``, ... when the file gives a count)."""
        return list(self._tables()["states"])

    @property
    def actions(self) -> list[str]:
        """Action names: decision ``d`` is ``actions[d]``."""
        return list(self._tables()["actions"])

    @property
    def observations(self) -> list[str]:
        """Observation names: observation ``y`` is ``observations[y]``; ``y = len(observations)``
        is the start symbol."""
        return list(self._tables()["observations"])

    @property
    def discount(self) -> float:
        """The discount ``γ`` used."""
        return self._tables()["discount"]

    @property
    def start(self) -> np.ndarray:
        """The start distribution over states, shape ``(S,)``."""
        return self._tables()["start"].copy()

    @property
    def transition(self) -> np.ndarray:
        """``T[a, s, s']``, shape ``(A, S, S)``."""
        return self._tables()["transition"].copy()

    @property
    def observation(self) -> np.ndarray:
        """``O[a, s', o]``, shape ``(A, S, O)``."""
        return self._tables()["observation"].copy()

    @property
    def reward(self) -> np.ndarray:
        """The expected immediate reward ``R[a, s] = Σ T O R``, costs negated, shape ``(A, S)``."""
        return self._tables()["reward"].copy()

    def __repr__(self) -> str:
        p = self.params
        extra = "".join(f", {k}={p[k]!r}" for k in ("discount", "reward") if p.get(k) not in (None, "sampled"))
        return f"PomdpWorld({p['file']!r}, horizon={p['horizon']}{extra})"
