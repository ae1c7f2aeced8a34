"""A policy's encodings of a Gymnasium environment's spaces as its file records them
(:mod:`cehmm.spaces`, the world's ``"spaces"``), and the agent that speaks the environment's
values through them (:meth:`cehmm.Policy.agent`, :func:`cehmm.gym.play`)."""

from __future__ import annotations

from typing import Any

from . import _core
from .spaces import Bins, Encoding, Flat, Grid, Hashed, _shown, space_of


def from_record(record: dict[str, Any], role: str, field: str | None = None) -> Encoding:
    """The encoding a policy file recorded (:meth:`Encoding.record`), checked as the user's
    would be (its space, its size, its edges or values of the space); ``field`` names it in
    errors (default: ``"ROLE encoding record"``).

    Raises:
        PolicyFormatError: naming the field, the record and what was wrong.

    Example:
        >>> from gymnasium.spaces import Box
        >>> from_record(Grid(3).fit(Box(-2.0, 2.0), "action").record(), "action").value(0)
        array([-2.], dtype=float32)
    """
    field = field or f"{role} encoding record"
    try:
        space = space_of(record["space"])
        kind = record["encoding"]
        if kind == "flat":
            return Flat(space, role)
        if kind == "hashed":
            return Hashed(record["size"], space, role)
        # Fitted: one list a dimension (not Grid(5)'s count, nor no edges at all).
        if kind in ("bins", "grid") and not isinstance(record["edges" if kind == "bins" else "values"], list):
            raise TypeError(f"expected the {'edges' if kind == 'bins' else 'values'} of each dimension, a list")
        if kind == "bins":
            return Bins(edges=record["edges"], space=space, role=role)
        if kind == "grid":
            return Grid(record["values"], space=space, role=role)
    # A record is the file's: whatever it holds (gymnasium's own asserts included) is a format error.
    except (LookupError, TypeError, ValueError, ArithmeticError, AssertionError, AttributeError, RecursionError) as e:
        raise _core.PolicyFormatError(f"invalid {field}: {_shown(record)} ({e})") from e
    raise _core.PolicyFormatError(
        f"invalid {field}: {_shown(record)} (expected an encoding flat, hashed, bins or grid)"
    )


def recorded(world: dict[str, Any], source: str = "world") -> tuple[Encoding, Encoding] | None:
    """The observation and action encodings a world records, or None (a world of the engine's,
    or one written in Python without spaces: its indices are its values); ``source`` names the
    world in errors.

    Raises:
        PolicyFormatError: spaces that are not a dict of two valid records, naming the field.

    Example:
        >>> [type(e).__name__ for e in recorded(cehmm.PythonWorld("FrozenLake-v1").description)]
        ['Flat', 'Flat']
        >>> recorded(cehmm.TargetTracking(case=1).to_dict()) is None
        True
    """
    if "spaces" not in world:
        return None
    found = world["spaces"]
    if not isinstance(found, dict):
        raise _core.PolicyFormatError(
            f"invalid {source}: world.spaces: {_shown(found)} (expected a dict of the observation and action encodings)"
        )
    missing = [role for role in ("observation", "action") if role not in found]
    if missing:
        raise _core.PolicyFormatError(
            f"invalid {source}: world.spaces.{missing[0]}: missing (expected the {missing[0]} encoding's record)"
        )
    fields = {role: f"{source}: world.spaces.{role}" for role in ("observation", "action")}
    return tuple(from_record(found[role], role, fields[role]) for role in ("observation", "action"))  # type: ignore[return-value]


def policy_encodings(
    world: dict[str, Any], n_obs: int, n_actions: int, source: str = "policy"
) -> tuple[Encoding, Encoding] | None:
    """The encodings a policy's world records, checked against the policy: each record valid
    (:func:`recorded`) and of the policy's sizes (``n_obs`` observations, ``n_actions``
    decisions). The one check of :meth:`cehmm.Policy.load`, :meth:`~cehmm.Policy.from_json`,
    :meth:`~cehmm.Policy.agent` and :meth:`~cehmm.Policy.evaluate` (and so of
    :func:`cehmm.gym.play`, which takes the agent).

    Raises:
        PolicyFormatError: naming the field (``world.spaces.observation``, ...), its value and
            what was expected.

    Example:
        >>> world = cehmm.PythonWorld("FrozenLake-v1").description
        >>> [e.size for e in policy_encodings(world, 16, 4)]
        [16, 4]
        >>> policy_encodings(world, 16, 5)
        Traceback (most recent call last):
        ...
        cehmm.PolicyFormatError: invalid policy: world.spaces.action: 4 decisions (Flat of Discrete(4)) (expected the policy's n_actions, 5)
    """  # noqa: E501
    found = recorded(world, source)
    if found is None:
        return None
    for encoded, size, what, name in zip(
        found, (n_obs, n_actions), ("observations", "decisions"), ("n_obs", "n_actions")
    ):
        if encoded.size != size:
            raise _core.PolicyFormatError(
                f"invalid {source}: world.spaces.{encoded.role}: {encoded.size} {what} ({type(encoded).__name__} of "
                f"{encoded.space}) (expected the policy's {name}, {size})"
            )
    return found


class EnvAgent:
    """A policy's agent (:meth:`cehmm.Policy.agent`) that speaks an environment's spaces:
    ``act`` takes the observation the environment returned and answers an action of its action
    space, through the encodings the policy file recorded.

    Example:
        >>> import numpy as np
        >>> from gymnasium.spaces import Box
        >>> box, agent = Box(-1.0, 1.0, shape=(2,)), cehmm.Policy.uniform(cehmm.TargetTracking(case=1), [2]).agent()
        >>> agent = EnvAgent(agent, Bins(4, fit="bounds").fit(box, "observation"), Grid(4).fit(box, "action"))
        >>> agent.reset()
        >>> agent.act(np.array([0.1, -0.9], dtype=np.float32)) in box  # 16 observations, 16 actions
        True
    """

    def __init__(self, agent: Any, observations: Encoding, actions: Encoding) -> None:
        self.indices = agent
        self.observations = observations
        self.actions = actions

    def reset(self) -> None:
        """Starts an episode (the memory forgets)."""
        self.indices.reset()

    def act(self, observation: Any) -> Any:
        """The action after ``observation`` (a value of the environment's observation space)."""
        return self.actions.value(self.indices.act(self.observations.index(observation)))

    def __repr__(self) -> str:
        return f"EnvAgent({self.observations.space} -> {self.actions.space})"


__all__ = ["EnvAgent", "from_record", "policy_encodings", "recorded"]
