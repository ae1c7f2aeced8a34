"""Gymnasium environments as worlds of the engine (Gymnasium in; ``cehmm.gym`` is Gymnasium out).

Each space is encoded as indices by :mod:`cehmm.spaces` (finite spaces flattened, large ones
hashed, ``Box`` observations cut into bins, ``Box`` actions a grid of values), the encodings
recorded in the world's description (``"spaces"``) and so in policy files. An environment that
names no horizon (no ``max_episode_steps``, no ``horizon``) has :data:`DEFAULT_HORIZON`, and a
:class:`HorizonWarning` says so.

An environment steps one episode at a time (the episode protocol); a vector environment steps
``num_envs`` episodes at once (the batched protocol), its automatic resets ignored (the engine
stops feeding an episode once it has ended). Observations are checked against their space; the
rewards and flags are passed on as given, for the engine to check as any world's
(docs/python-worlds.md, "Values").
"""

from __future__ import annotations

import os
import sys
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np

from .spaces import Encoding, Flat, encoding
from .spaces import gymnasium as _gymnasium

__all__ = ["DEFAULT_HORIZON", "EnvEpisodes", "HorizonWarning", "VectorBatch", "adapt", "flat", "make_env"]

#: Most steps of an episode of an environment that names none (:class:`HorizonWarning`).
DEFAULT_HORIZON = 1000


class HorizonWarning(UserWarning):
    """An environment that names no horizon got :data:`DEFAULT_HORIZON`: its episodes are cut
    there, which may be far more steps than a good episode takes (a long search for less), or
    fewer. Told once per environment and line of code; ``horizon=`` chooses.

    Example:
        >>> import warnings
        >>> from gymnasium.envs.toy_text import FrozenLakeEnv
        >>> env = FrozenLakeEnv()  # made without gymnasium.make: no spec, no max_episode_steps
        >>> with warnings.catch_warnings(record=True) as told:
        ...     warnings.simplefilter("always")
        ...     world = cehmm.PythonWorld(env)
        >>> world.horizon, told[0].category.__name__
        (1000, 'HorizonWarning')
        >>> print(told[0].message)  # doctest: +ELLIPSIS
        gymnasium.envs.toy_text.frozen_lake.FrozenLakeEnv names no horizon (no max_episode_steps): ...
        >>> cehmm.PythonWorld(env, horizon=40).horizon  # chosen: nothing to tell
        40
    """


def _horizon(env: Any, horizon: int | None) -> int:
    """The horizon given, else the environment's ``max_episode_steps``, else
    :data:`DEFAULT_HORIZON` with a :class:`HorizonWarning` (on the line of the caller's code)."""
    if horizon is not None:
        return int(horizon)
    steps = getattr(getattr(env, "spec", None), "max_episode_steps", None)
    if steps is not None:
        return int(steps)
    spec, unwrapped = getattr(env, "spec", None), getattr(env, "unwrapped", env)
    label = getattr(spec, "id", None) or f"{type(unwrapped).__module__}.{type(unwrapped).__qualname__}"
    warnings.warn(
        f"{label} names no horizon (no max_episode_steps): its episodes are cut at {DEFAULT_HORIZON} steps "
        f"(cehmm.gym_adapt.DEFAULT_HORIZON); pass horizon= to choose (about twice the steps a good episode takes: "
        "a shorter horizon makes a faster search, one too short cuts the episodes a good policy needs)",
        HorizonWarning,
        stacklevel=_callers_level(),
    )
    return DEFAULT_HORIZON


def _callers_level() -> int:
    """The ``stacklevel`` of the innermost frame outside this package, seen from the function that
    calls this one."""
    package = os.path.join(os.path.dirname(__file__), "")
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_code.co_filename.startswith(package):
        frame, level = frame.f_back, level + 1
    return level


def make_env(world: Any) -> Any:
    """The environment of an id (``gymnasium.make``) or of a factory (called with no argument).

    Example:
        >>> import gymnasium
        >>> make_env("FrozenLake-v1").spec.max_episode_steps
        100
        >>> make_env(lambda: gymnasium.make("CartPole-v1")).observation_space.shape
        (4,)
    """
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


def flat(space: Any, role: str = "observation") -> Flat:
    """The flattening of a finite Gymnasium space (:class:`cehmm.spaces.Flat`); ``role`` names it in errors.

    Example:
        >>> from gymnasium.spaces import MultiDiscrete
        >>> cells = flat(MultiDiscrete([3, 4]))  # row-major: the last component varies fastest
        >>> cells.size, cells.index(np.array([2, 1])), cells.value(9)
        (12, 9, array([2, 1]))
    """
    return Flat(space, role)


class _Adapted:
    """An environment's encoded spaces (:mod:`cehmm.spaces`), sizes and horizon."""

    def __init__(
        self, env: Any, observation_space: Any, action_space: Any, horizon: int | None, choices: dict[str, Any]
    ) -> None:
        self.env = env
        self.horizon = _horizon(env, horizon)
        self.actions: Encoding = encoding(action_space, "action", choices.get("actions"))
        self.observations: Encoding = encoding(
            observation_space,
            "observation",
            choices.get("observations"),
            lambda n, seed: _warmup_observations(env, n, seed, self.horizon),
        )
        self.n_observations = self.observations.size
        self.n_decisions = self.actions.size

    def spaces(self) -> dict[str, Any]:
        """What the description records of the encodings; an observation of several parts (the
        dimensions of a ``Box`` cut into bins, of a ``MultiDiscrete``, a ``Tuple``'s spaces) with
        their ``radices`` (its index is their row-major number), where a learner looks at some
        parts only (model §10's lenses)."""
        observation = self.observations.record()
        if len(self.observations.radices) > 1:
            observation["radices"] = [int(r) for r in self.observations.radices]
        return {"observation": observation, "action": self.actions.record()}


class EnvEpisodes(_Adapted):
    """A Gymnasium environment in the episode protocol: observations checked against their space
    and flattened; the reward and flags passed on as the environment gave them (the engine
    checks them, as it does any world's).

    Example:
        >>> import gymnasium
        >>> world = EnvEpisodes(gymnasium.make("FrozenLake-v1"))
        >>> world.n_observations, world.n_decisions, world.horizon
        (16, 4, 100)
        >>> world.reset(seed=0), world.step(2)[:4]  # from cell 0, "right" slipped down to cell 4
        (0, (4, 0, False, False))
    """

    def __init__(self, env: Any, horizon: int | None = None, choices: dict[str, Any] | None = None) -> None:
        super().__init__(env, env.observation_space, env.action_space, horizon, choices or {})

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

    Example:
        >>> import gymnasium
        >>> batch = VectorBatch(gymnasium.make_vec("FrozenLake-v1", num_envs=4))
        >>> batch.batched, batch.max_batch, batch.n_observations, batch.n_decisions
        (True, 4, 16, 4)
        >>> batch.reset(3, seed=0)  # 3 episodes: the fourth sub-environment's are ignored
        array([0, 0, 0])
        >>> observations, rewards, terminated, truncated, _ = batch.step(np.array([2, 2, 1]))
        >>> observations.shape, rewards.shape, terminated.dtype
        ((3,), (3,), dtype('bool'))
    """

    batched = True

    def __init__(self, env: Any, horizon: int | None = None, choices: dict[str, Any] | None = None) -> None:
        super().__init__(env, env.single_observation_space, env.single_action_space, horizon, choices or {})
        self.max_batch = int(env.num_envs)
        gymnasium = _gymnasium()
        utils = gymnasium.vector.utils
        self._iterate: Callable[..., Any] = utils.iterate
        self._concatenate: Callable[..., Any] = utils.concatenate
        self._empty = utils.create_empty_array(env.single_action_space, env.num_envs)
        finite = isinstance(self.observations, Flat)
        self._batched_observations = Flat(env.observation_space, "observations") if finite else None
        mode = getattr(gymnasium.vector, "AutoresetMode", None)
        self._reset_ended = mode is not None and env.metadata.get("autoreset_mode") == mode.DISABLED

    def _indices(self, observations: Any, n: int) -> np.ndarray:
        encoded = self.observations
        if self._batched_observations is not None and isinstance(encoded, Flat):
            self._batched_observations.check(observations)
            if encoded.kind == "discrete":
                return np.asarray(observations, dtype=np.int64)[:n] - int(encoded.start or 0)
            index = encoded._index
        else:
            index = encoded.index
        items = self._iterate(self.env.observation_space, observations)
        return np.fromiter((index(o) for o in items), dtype=np.int64, count=self.max_batch)[:n]

    def reset(self, n: int, seed: int) -> np.ndarray:
        self._n = n
        observations, _ = self.env.reset(seed=seed)
        return self._indices(observations, n)

    def step(self, decisions: np.ndarray) -> tuple[np.ndarray, Any, Any, Any, dict[str, Any]]:
        padded = np.zeros(self.max_batch, dtype=np.int64)
        padded[: len(decisions)] = decisions
        if isinstance(self.actions, Flat) and self.actions.kind == "discrete":
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


def adapt(env: Any, horizon: int | None = None, choices: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
    """An environment (or vector environment) in one of the two protocols, and its description;
    ``choices`` are the encodings asked for (``{"observations": ..., "actions": ...}``).

    Example:
        >>> import gymnasium
        >>> world, description = adapt(gymnasium.make("FrozenLake-v1"), horizon=50)
        >>> type(world).__name__, world.horizon, description["id"]
        ('EnvEpisodes', 50, 'FrozenLake-v1')
        >>> description["spaces"]["observation"]
        {'encoding': 'flat', 'space': {'type': 'Discrete', 'n': 16, 'start': 0}}
        >>> from cehmm.spaces import Bins, Grid
        >>> choices = {"observations": Bins(4, fit="bounds"), "actions": Grid(3)}
        >>> world, _ = adapt(gymnasium.make("Pendulum-v1"), choices=choices)  # 3 bounded dimensions, 1 torque
        >>> world.n_observations, world.n_decisions, world.actions.value(2)
        (64, 3, array([2.], dtype=float32))
    """
    gymnasium = _gymnasium()
    spec = getattr(env, "spec", None)
    description: dict[str, Any] = {"id": spec.id} if spec is not None else {}
    unwrapped = getattr(env, "unwrapped", env)
    description.setdefault("class", f"{type(unwrapped).__module__}.{type(unwrapped).__qualname__}")
    kind = VectorBatch if isinstance(env, gymnasium.vector.VectorEnv) else EnvEpisodes
    adapted = kind(env, horizon, choices)
    description["spaces"] = adapted.spaces()
    return adapted, description


def _warmup_observations(env: Any, steps: int, seed: int, horizon: int | None) -> list[Any]:
    """The observations met in ``steps`` steps of uniformly random actions in ``env`` (an
    environment, or a vector environment: each of its observations), as the environment gave
    them, for :class:`cehmm.spaces.Bins` to check against the space and fit; its episodes reset
    with seeds ``seed``, ``seed + 1``, ... and cut at ``horizon``."""
    vector = hasattr(env, "num_envs") and hasattr(env, "single_observation_space")
    env.action_space.seed(seed)
    seen: list[Any] = []
    if vector:
        observations, _ = env.reset(seed=seed)
        while len(seen) < steps:
            seen.extend(_each(observations, env.num_envs))
            observations, *_ = env.step(env.action_space.sample())
        return seen[:steps]
    episode = 0
    while len(seen) < steps:
        observation, _ = env.reset(seed=seed + episode)
        episode += 1
        seen.append(_kept(observation))
        t, done = 0, False
        while not done and len(seen) < steps and (horizon is None or t < horizon):
            observation, _, terminated, truncated, _ = env.step(env.action_space.sample())
            seen.append(_kept(observation))
            t += 1
            done = bool(terminated or truncated)
    return seen


def _kept(observation: Any) -> Any:
    """An observation kept for later (a copy of an array the environment may write again)."""
    return observation.copy() if isinstance(observation, np.ndarray) else observation


def _each(observations: Any, n: int) -> list[Any]:
    """The ``n`` observations of a vector environment's batch (the batch itself where it has not
    ``n``: the check names it)."""
    try:
        return [_kept(observations[k]) for k in range(n)] if len(observations) == n else [observations]
    except (TypeError, IndexError, KeyError):
        return [observations]
