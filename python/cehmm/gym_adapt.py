"""Gymnasium environments as worlds of the engine (Gymnasium in; ``cehmm.gym`` is Gymnasium out).

Spaces must be finite: ``Discrete``, ``MultiDiscrete``, ``MultiBinary`` or ``Tuple`` of them. Each
is flattened to one index: ``Discrete(n, start)`` gives ``x - start``; a ``MultiDiscrete`` or
``MultiBinary`` its components in row-major order (the last one varying fastest, as
``numpy.ravel_multi_index``); a ``Tuple`` its components' indices in the same order. A policy's
observation ``y`` and decision ``d`` are those indices; :func:`flat` gives the mapping both ways.

An environment steps one episode at a time (the episode protocol); a vector environment steps
``num_envs`` episodes at once (the batched protocol), its automatic resets ignored (the engine
stops feeding an episode once it has ended). Observations are checked against their space; the
rewards and flags are passed on as given, for the engine to check as any world's
(docs/python-worlds.md, "Values").
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from . import _core


def _gymnasium() -> Any:
    try:
        import gymnasium
    except ImportError as e:  # pragma: no cover - the test extra installs it
        raise ImportError("Gymnasium environments need gymnasium: pip install 'cehmm[gym]'") from e
    return gymnasium


def make_env(world: Any) -> Any:
    """The environment of an id (``gymnasium.make``) or of a factory (called with no argument)."""
    if isinstance(world, str):
        gymnasium = _gymnasium()
        try:
            return gymnasium.make(world)
        except gymnasium.error.Error as e:
            raise TypeError(
                f"invalid world: {world!r} (expected a cehmm world, a world written in Python, or the id of a "
                f"registered Gymnasium environment: {e})"
            ) from e
    return world()


# The most values a flattened space may have: its indices are 64-bit signed integers.
_MAX_SIZE = 2**63 - 1


class Flat:
    """A finite space flattened to the indices ``0..size``.

    Raises:
        InvalidArgumentError: a space that is not finite (``Box``: discretise it first) or not
            one of the kinds above.
    """

    def __init__(self, space: Any, role: str) -> None:
        spaces = _gymnasium().spaces
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
                " is continuous: cehmm learns over finite spaces. Wrap the environment in a "
                "gymnasium.ObservationWrapper (or ActionWrapper) that maps each value to a cell index, "
                "with a Discrete space (e.g. np.digitize per dimension, then np.ravel_multi_index)"
                if isinstance(space, spaces.Box)
                else " (expected Discrete, MultiDiscrete, MultiBinary or a Tuple of them)"
            )
            raise _core.InvalidArgumentError(f"invalid {role} space: {space}{hint}")
        # Exact (Python ints): numpy's int64 product wraps silently past 2**63. A Tuple of
        # nothing has one value, ().
        self.size = math.prod(self.radices)
        if self.size > _MAX_SIZE:
            raise _core.InvalidArgumentError(
                f"invalid {role} space: {space} has {self.size} values (at most 2**63 - 1 can be indexed; "
                "group or discretise its values with a wrapper)"
            )

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
            raise _core.WorldError(f"{self.role} {_shown(value)} is not in the space {self.space}")

    def index(self, value: Any) -> int:
        """The index of a value of the space (checked to be in it)."""
        self.check(value)
        return self._index(value)

    def _index(self, value: Any) -> int:
        if self.kind == "discrete":
            return int(value) - int(self.start or 0)
        if self.kind == "tuple":
            return int(np.ravel_multi_index([p._index(v) for p, v in zip(self.parts, value)], self.radices))
        return int(np.ravel_multi_index(np.ravel(value) - self._offset, self.radices))

    def value(self, index: int) -> Any:
        """The value of the space at an index."""
        if self.kind == "discrete":
            return int(self.start or 0) + int(index)
        digits = np.unravel_index(int(index), self.radices)
        if self.kind == "tuple":
            return tuple(p.value(d) for p, d in zip(self.parts, digits))
        return (np.asarray(digits) + self._offset).astype(self.space.dtype).reshape(self.space.shape)


def _shown(value: Any) -> str:
    """A value as an error shows it: its repr, cut at 80 characters."""
    text = repr(value)
    return text if len(text) <= 80 else text[:79] + "…"


def flat(space: Any, role: str = "observation") -> Flat:
    """The flattening of a finite Gymnasium space (module docstring); ``role`` names it in errors."""
    return Flat(space, role)


class _Adapted:
    """An environment's flattened spaces, sizes and horizon (where its spec gives one)."""

    def __init__(self, env: Any, observation_space: Any, action_space: Any) -> None:
        self.env = env
        self.observations = Flat(observation_space, "observation")
        self.actions = Flat(action_space, "action")
        self.n_observations = self.observations.size
        self.n_decisions = self.actions.size
        steps = getattr(getattr(env, "spec", None), "max_episode_steps", None)
        if steps is not None:
            self.horizon = int(steps)


class EnvEpisodes(_Adapted):
    """A Gymnasium environment in the episode protocol: observations checked against their space
    and flattened; the reward and flags passed on as the environment gave them (the engine
    checks them, as it does any world's)."""

    def __init__(self, env: Any) -> None:
        super().__init__(env, env.observation_space, env.action_space)

    def reset(self, seed: int) -> int:
        observation, _ = self.env.reset(seed=seed)
        return self.observations.index(observation)

    def step(self, decision: int) -> tuple[int, Any, Any, Any, Any]:
        observation, reward, terminated, truncated, info = self.env.step(self.actions.value(decision))
        return self.observations.index(observation), reward, terminated, truncated, info


class VectorBatch(_Adapted):
    """A Gymnasium vector environment in the batched protocol (``num_envs`` episodes at once).

    Its observations are checked against its (batched) observation space. In
    ``AutoresetMode.DISABLED`` the sub-environments that end are reset at once (their later
    steps are ignored by the engine), as that mode asks before they are stepped again.
    """

    batched = True

    def __init__(self, env: Any) -> None:
        super().__init__(env, env.single_observation_space, env.single_action_space)
        self.max_batch = int(env.num_envs)
        gymnasium = _gymnasium()
        utils = gymnasium.vector.utils
        self._iterate: Callable[..., Any] = utils.iterate
        self._concatenate: Callable[..., Any] = utils.concatenate
        self._empty = utils.create_empty_array(env.single_action_space, env.num_envs)
        self._batched_observations = Flat(env.observation_space, "observations")
        mode = getattr(gymnasium.vector, "AutoresetMode", None)
        self._reset_ended = mode is not None and env.metadata.get("autoreset_mode") == mode.DISABLED

    def _indices(self, observations: Any, n: int) -> np.ndarray:
        self._batched_observations.check(observations)
        if self.observations.kind == "discrete":
            return np.asarray(observations, dtype=np.int64)[:n] - int(self.observations.start or 0)
        items = self._iterate(self.env.observation_space, observations)
        indices = (self.observations._index(o) for o in items)
        return np.fromiter(indices, dtype=np.int64, count=self.max_batch)[:n]

    def reset(self, n: int, seed: int) -> np.ndarray:
        self._n = n
        observations, _ = self.env.reset(seed=seed)
        return self._indices(observations, n)

    def step(self, decisions: np.ndarray) -> tuple[np.ndarray, Any, Any, Any, dict[str, Any]]:
        padded = np.zeros(self.max_batch, dtype=np.int64)
        padded[: len(decisions)] = decisions
        if self.actions.kind == "discrete":
            actions = (padded + int(self.actions.start or 0)).astype(self.env.single_action_space.dtype)
        else:
            items = [self.actions.value(d) for d in padded]
            actions = self._concatenate(self.env.single_action_space, items, self._empty)
        observations, rewards, terminated, truncated, _ = self.env.step(actions)
        n = self._n
        indices = self._indices(observations, n)
        if self._reset_ended:
            ended = np.logical_or(np.asarray(terminated, dtype=bool), np.asarray(truncated, dtype=bool))
            if ended.any():
                self.env.reset(options={"reset_mask": ended})
        return indices, _head(rewards, n), _head(terminated, n), _head(truncated, n), {}


def _head(values: Any, n: int) -> Any:
    """The first `n` of a vector environment's values, as it gave them (an array, a list...)."""
    return np.asarray(values)[:n]


def adapt(env: Any) -> tuple[Any, dict[str, Any]]:
    """An environment (or vector environment) in one of the two protocols, and its description."""
    gymnasium = _gymnasium()
    spec = getattr(env, "spec", None)
    description: dict[str, Any] = {"id": spec.id} if spec is not None else {}
    unwrapped = getattr(env, "unwrapped", env)
    description.setdefault("class", f"{type(unwrapped).__module__}.{type(unwrapped).__qualname__}")
    if isinstance(env, gymnasium.vector.VectorEnv):
        return VectorBatch(env), description
    return EnvEpisodes(env), description
