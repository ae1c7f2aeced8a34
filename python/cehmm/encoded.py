"""A policy's encodings of a Gymnasium environment's spaces as its file records them
(:mod:`cehmm.spaces`, the world's ``"spaces"``), and the agent that speaks the environment's
values through them (:meth:`cehmm.Policy.agent`, :func:`cehmm.gym.play`)."""

from __future__ import annotations

from typing import Any

from . import _core
from .spaces import Bins, Encoding, Flat, Grid, Hashed, _shown, space_of


def from_record(record: dict[str, Any], role: str) -> Encoding:
    """The encoding a policy file recorded (:meth:`Encoding.record`).

    Example:
        >>> from gymnasium.spaces import Box
        >>> from_record(Grid(3).fit(Box(-2.0, 2.0), "action").record(), "action").value(0)
        array([-2.], dtype=float32)
    """
    try:
        space = space_of(record["space"])
        kind = record["encoding"]
        if kind == "flat":
            return Flat(space, role)
        if kind == "hashed":
            return Hashed(int(record["size"]), space, role)
        if kind == "bins":
            return Bins(edges=record["edges"], space=space, role=role)
        if kind == "grid":
            return Grid(record["values"], space=space, role=role)
    except (KeyError, TypeError, ValueError) as e:
        raise _core.PolicyFormatError(f"invalid {role} encoding record: {_shown(record)} ({e})") from e
    raise _core.PolicyFormatError(
        f"invalid {role} encoding record: {_shown(record)} (expected an encoding flat, hashed, bins or grid)"
    )


def recorded(world: dict[str, Any]) -> tuple[Encoding, Encoding] | None:
    """The observation and action encodings a policy's world records, or None (a world of the
    engine's, or one written in Python without spaces: its indices are its values).

    Example:
        >>> [type(e).__name__ for e in recorded(cehmm.PythonWorld("FrozenLake-v1").description)]
        ['Flat', 'Flat']
        >>> recorded(cehmm.TargetTracking(case=1).to_dict()) is None
        True
    """
    found = world.get("spaces")
    if not isinstance(found, dict):
        return None
    return from_record(found["observation"], "observation"), from_record(found["action"], "action")


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


__all__ = ["EnvAgent", "from_record", "recorded"]
