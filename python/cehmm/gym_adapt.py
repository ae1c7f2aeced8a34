"""Gymnasium environments as worlds of the engine (Gymnasium in; ``cehmm.gym`` is Gymnasium out).

Spaces must be finite: ``Discrete``, ``MultiDiscrete``, ``MultiBinary`` or ``Tuple`` of them. Each
is flattened to one index: ``Discrete(n, start)`` gives ``x - start``; a ``MultiDiscrete`` or
``MultiBinary`` its components in row-major order (the last one varying fastest, as
``numpy.ravel_multi_index``); a ``Tuple`` its components' indices in the same order. A policy's
observation ``y`` and decision ``d`` are those indices; :func:`flat` gives the mapping both ways.

An environment steps one episode at a time (the episode protocol); a vector environment steps
``num_envs`` episodes at once (the batched protocol), its automatic resets ignored (the engine
stops feeding an episode once it has ended).
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
        if isinstance(space, spaces.Discrete):
            self.radices = [int(space.n)]
            self.start = int(space.start)
            self.size = int(space.n)
            return
        self.start = None
        if isinstance(space, (spaces.MultiDiscrete, spaces.MultiBinary)):
            nvec = np.full(space.shape, 2) if isinstance(space, spaces.MultiBinary) else space.nvec
            self.radices = [int(n) for n in np.ravel(nvec)]
            self._offset = np.ravel(getattr(space, "start", np.zeros_like(nvec)))
            self.parts: list[Flat] = []
        elif isinstance(space, spaces.Tuple):
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
        # Exact (Python ints): numpy's int64 product wraps silently past 2**63.
        self.size = math.prod(self.radices)
        if self.size > _MAX_SIZE:
            raise _core.InvalidArgumentError(
                f"invalid {role} space: {space} has {self.size} values (at most 2**63 - 1 can be indexed; "
                "group or discretise its values with a wrapper)"
            )

    def index(self, value: Any) -> int:
        """The index of a value of the space."""
        if self.start is not None:
            return int(value) - self.start
        if self.parts:
            return int(np.ravel_multi_index([p.index(v) for p, v in zip(self.parts, value)], self.radices))
        return int(np.ravel_multi_index(np.ravel(value) - self._offset, self.radices))

    def value(self, index: int) -> Any:
        """The value of the space at an index."""
        if self.start is not None:
            return self.start + int(index)
        digits = np.unravel_index(int(index), self.radices)
        if self.parts:
            return tuple(p.value(d) for p, d in zip(self.parts, digits))
        return (np.asarray(digits) + self._offset).astype(self.space.dtype).reshape(self.space.shape)


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
    """A Gymnasium environment in the episode protocol."""

    def __init__(self, env: Any) -> None:
        super().__init__(env, env.observation_space, env.action_space)

    def reset(self, seed: int) -> int:
        observation, _ = self.env.reset(seed=seed)
        return self.observations.index(observation)

    def step(self, decision: int) -> tuple[int, float, bool]:
        observation, reward, terminated, truncated, _ = self.env.step(self.actions.value(decision))
        return self.observations.index(observation), float(reward), bool(terminated or truncated)


class VectorBatch(_Adapted):
    """A Gymnasium vector environment in the batched protocol (``num_envs`` episodes at once)."""

    batched = True

    def __init__(self, env: Any) -> None:
        super().__init__(env, env.single_observation_space, env.single_action_space)
        self.max_batch = int(env.num_envs)
        utils = _gymnasium().vector.utils
        self._iterate: Callable[..., Any] = utils.iterate
        self._concatenate: Callable[..., Any] = utils.concatenate
        self._empty = utils.create_empty_array(env.single_action_space, env.num_envs)

    def _indices(self, observations: Any, n: int) -> np.ndarray:
        if self.observations.start is not None:
            return np.asarray(observations, dtype=np.int64)[:n] - self.observations.start
        items = self._iterate(self.env.single_observation_space, observations)
        return np.fromiter((self.observations.index(o) for o in items), dtype=np.int64, count=self.max_batch)[:n]

    def reset(self, n: int, seed: int) -> np.ndarray:
        self._n = n
        observations, _ = self.env.reset(seed=seed)
        return self._indices(observations, n)

    def step(self, decisions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        padded = np.zeros(self.max_batch, dtype=np.int64)
        padded[: len(decisions)] = decisions
        if self.actions.start is not None:
            actions = (padded + self.actions.start).astype(self.env.single_action_space.dtype)
        else:
            items = [self.actions.value(d) for d in padded]
            actions = self._concatenate(self.env.single_action_space, items, self._empty)
        observations, rewards, terminated, truncated, _ = self.env.step(actions)
        n = self._n
        done = np.logical_or(terminated, truncated)[:n]
        return self._indices(observations, n), np.asarray(rewards, dtype=np.float64)[:n], done


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
