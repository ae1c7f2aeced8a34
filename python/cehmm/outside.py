"""Worlds written in Python (model §1): any object that speaks one of two protocols, or a
Gymnasium environment, optimised and evaluated by the engine like its own worlds.

**Episode protocol** (one episode at a time; the interpreter is crossed once per step)::

    class MyWorld:
        n_observations = 5       # observations are 0..4
        n_decisions = 3          # decisions are 0..2
        horizon = 50             # most steps of an episode

        def reset(self, seed: int) -> int: ...                          # the first observation
        def step(self, decision: int) -> tuple[int, float, bool]: ...   # (observation, reward, done)

``reset`` may also return Gymnasium's ``(observation, info)`` and ``step`` its five-tuple
``(observation, reward, terminated, truncated, info)``.

**Batched protocol** (``batched = True``; many episodes in lockstep, the interpreter crossed once
per time step for all of them, so numpy code runs at the speed of the engine)::

    class MyBatchWorld:
        batched = True
        n_observations, n_decisions, horizon = 5, 3, 50
        max_batch = 1024         # optional: most episodes per call (default 1024)

        def reset(self, n: int, seed: int) -> np.ndarray: ...     # observations[n]
        def step(self, decisions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...
                                 # (observations[n], rewards[n], done[n])

An episode ends at ``done`` or after ``horizon`` steps; the engine counts only the steps it ran.
In a batch, the episodes that have ended keep receiving decision 0, and what the world returns
for them is ignored. The world draws its own randomness from the seed ``reset`` receives; the
policy's side stays in the engine (parallel, one random stream per episode).

An episode's value is the sum of its rewards (discounted by ``discount``), or whatever
``score(observations, decisions, rewards) -> float`` says of the whole episode (numpy arrays of
its steps): reach a goal at least once, the worst step, a threshold...
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

import numpy as np

from . import _core

#: Episodes a batched world steps at once unless it says otherwise (its ``max_batch``).
DEFAULT_MAX_BATCH = 1024

#: A score: a function of one episode's observations, decisions and rewards.
Score = Callable[[np.ndarray, np.ndarray, np.ndarray], float]


class PythonWorld:
    """A world written in Python (or a Gymnasium environment), ready for the engine.

    :func:`cehmm.optimize`, :meth:`Policy.evaluate` and :meth:`Policy.rollout` make one from any
    world they do not know; make it yourself to give a score, a discount or a horizon.

    Args:
        world: an object of the episode or the batched protocol (module docstring), a Gymnasium
            environment, a Gymnasium vector environment (stepped as a batch of ``num_envs``), a
            registered environment id (``"FrozenLake-v1"``), or a function of no argument that
            returns one of these.
        horizon: most steps of an episode (default: the world's ``horizon``, or the
            environment's ``max_episode_steps``, or for an environment that names neither
            ``cehmm.gym_adapt.DEFAULT_HORIZON``, 1000).
        score: the value of an episode from its ``(observations, decisions, rewards)``
            (default: the sum of the rewards, discounted).
        discount: ``0 <= discount <= 1`` (as in ``.pomdp`` files); step ``t`` (from 0) weighs ``discount ** t`` in the
            default score.
        name: how errors and policy files name it (default: its class, or the environment id).
        observations: for a Gymnasium environment, how its observations become indices: None
            (the default of :mod:`cehmm.spaces`: finite spaces flattened, those of more than
            4096 values hashed, a ``Box`` cut into bins at quantiles of a warm-up), or an
            encoding of :mod:`cehmm.spaces` (``Flat()``, ``Hashed(128)``, ``Bins(8)``,
            ``Bins(8, fit="bounds")``, ``Bins(edges=...)``). Recorded in policy files.
        actions: for a Gymnasium environment, how its actions are indexed: None (finite
            spaces flattened, a ``Box`` a grid of 5 values a dimension) or ``Grid(k)``,
            ``Grid(values=...)``. Recorded in policy files.

    Raises:
        TypeError: ``world`` speaks neither protocol, or lacks ``n_observations``,
            ``n_decisions`` or ``horizon``.
        InvalidArgumentError: a size or ``discount`` out of its domain; an environment whose
            spaces are not finite (the message says how to discretise it).

    Example:
        >>> class Coin:  # decision 1 pays 1, decision 0 nothing
        ...     n_observations, n_decisions, horizon = 1, 2, 10
        ...     def reset(self, seed):
        ...         return 0
        ...     def step(self, decision):
        ...         return 0, float(decision), False
        >>> world = PythonWorld(Coin(), name="coin")
        >>> world
        PythonWorld(coin, observations=1, decisions=2, horizon=10)
        >>> result = cehmm.optimize(world, levels=[2], samples=100, max_iterations=5, eval_episodes=1000,
        ...                         progress=False)
        >>> round(result.evaluation.mean, 1)  # at most 10: decision 1 at each of the 10 steps
        9.3
        >>> PythonWorld("FrozenLake-v1")
        PythonWorld(FrozenLake-v1, observations=16, decisions=4, horizon=100)
    """

    def __init__(
        self,
        world: Any,
        *,
        horizon: int | None = None,
        score: Score | None = None,
        discount: float = 1.0,
        name: str | None = None,
        observations: Any = None,
        actions: Any = None,
    ) -> None:
        #: What was given (an environment, its id, a factory...), before any adapting.
        self.world = world
        self._options: dict[str, Any] = dict(horizon=horizon, score=score, discount=discount, name=name)
        if isinstance(world, str) or _is_factory(world):
            from .gym_adapt import make_env

            world = make_env(world)
        description: dict[str, Any] = {}
        if _is_gym_env(world):
            from .gym_adapt import adapt

            world, description = adapt(world, horizon, {"observations": observations, "actions": actions})
            # Fitted once (a warm-up, say): a copy made elsewhere (a backend's worker) reuses them.
            self._options.update(observations=world.observations, actions=world.actions)
        elif not (callable(getattr(world, "reset", None)) and callable(getattr(world, "step", None))):
            raise TypeError(
                f"invalid world: {world!r} (expected a cehmm world, an object with reset() and step() "
                "(see cehmm.outside), a Gymnasium environment, an environment id or a factory)"
            )
        else:
            description["class"] = f"{type(world).__module__}.{type(world).__qualname__}"
            for what, given in (("observations", observations), ("actions", actions)):
                if given is not None:
                    raise TypeError(
                        f"invalid {what}: {given!r} for {description['class']} (encodings apply to Gymnasium "
                        "environments; a world of the episode or batched protocol gives indices itself)"
                    )
        if name is not None:
            if not isinstance(name, str):
                raise TypeError(f"invalid name: {name!r} is {type(name).__name__} (expected a str)")
            description["class"] = name
        batched = bool(getattr(world, "batched", False))
        if horizon is None:
            horizon = _attribute(world, "horizon", description)
        self.score = score
        self._core = _core.OutsideWorld(
            world,
            observations=_attribute(world, "n_observations", description),
            decisions=_attribute(world, "n_decisions", description),
            horizon=horizon,
            batched=batched,
            batch=getattr(world, "max_batch", DEFAULT_MAX_BATCH) if batched else 1,
            description=description,
            discount=discount,
            score=score,
        )

    @property
    def description(self) -> dict[str, Any]:
        """What policy files record of it: ``{"name": "outside", "class" or "id": ...,
        "observations", "decisions", "horizon"}``."""
        return self._core.description

    @property
    def n_observations(self) -> int:
        """Number of observations ``Y``."""
        return int(self.description["observations"])

    @property
    def n_decisions(self) -> int:
        """Number of decisions ``D``."""
        return int(self.description["decisions"])

    @property
    def horizon(self) -> int:
        """Most steps of an episode."""
        return int(self.description["horizon"])

    @property
    def batch(self) -> int:
        """Episodes stepped at once (1 for the episode protocol)."""
        return self._core.batch

    def __reduce__(self) -> tuple[Any, ...]:
        # Pickled as what it was made from (to reach the workers of a backend, say).
        return (_python_world, (self.world, self._options))

    def __repr__(self) -> str:
        d = self.description
        label = d.get("id", d.get("class", "?"))
        sizes = f"observations={d['observations']}, decisions={d['decisions']}, horizon={d['horizon']}"
        return f"PythonWorld({label}, {sizes})"


def _python_world(world: Any, options: dict[str, Any]) -> PythonWorld:
    return PythonWorld(world, **options)


def _attribute(world: Any, name: str, description: dict[str, Any]) -> Any:
    if not hasattr(world, name):
        label = description.get("class", description.get("id", repr(world)))
        hint = " (pass horizon=...)" if name == "horizon" else ""
        raise TypeError(f"invalid world: {label} has no attribute {name!r}{hint}")
    return getattr(world, name)


def _is_gym_env(world: Any) -> bool:
    return hasattr(world, "observation_space") and hasattr(world, "action_space")


def _is_factory(world: Any) -> bool:
    """A function (or class) of no argument that makes a world, not a world itself."""
    if not callable(world) or hasattr(world, "reset") and not inspect.isclass(world):
        return False
    try:
        signature = inspect.signature(world)
    except (TypeError, ValueError):
        return False
    return all(
        p.default is not p.empty or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD) for p in signature.parameters.values()
    )
