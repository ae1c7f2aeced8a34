"""Small worlds written in Python, shared by the tests."""

from __future__ import annotations

import os
import signal
import time
from typing import Any

import gymnasium as gym
import numpy as np


class Corridor:
    """Cells 0..5, start at 0; decision 1 moves right, 0 left, but the wind reverses a move with
    probability 0.1. A step's reward is 1 at cell 5. The observation is the cell."""

    n_observations, n_decisions, horizon = 6, 2, 10

    def reset(self, seed: int) -> int:
        self.rng = np.random.default_rng(seed)
        self.cell = 0
        return self.cell

    def step(self, decision: int) -> tuple[int, float, bool]:
        move = 1 if decision == 1 else -1
        if self.rng.random() < 0.1:
            move = -move
        self.cell = min(5, max(0, self.cell + move))
        return self.cell, float(self.cell == 5), False


class Slow(Corridor):
    """The corridor at 1 ms a step (10 steps an episode)."""

    def step(self, decision: int) -> tuple[int, float, bool]:
        time.sleep(0.001)
        return super().step(decision)


class KillsItsWorker(Corridor):
    """The corridor, but the first episode begun in a process other than the one that made it
    (a worker) kills that process, once: when no file `marker` exists (it makes it)."""

    def __init__(self, marker: str) -> None:
        self.marker, self.maker = marker, os.getpid()

    def reset(self, seed: int) -> int:
        if os.getpid() != self.maker:
            try:
                open(self.marker, "x").close()
            except FileExistsError:
                pass  # killed already (or another worker is being killed)
            else:
                os.kill(os.getpid(), signal.SIGKILL)
        return super().reset(seed)


class Raises(Corridor):
    """The corridor, its third step raising `ValueError`."""

    def step(self, decision: int) -> tuple[int, float, bool]:
        if self.steps == 2:
            raise ValueError("the corridor's third step")
        self.steps += 1
        return super().step(decision)

    def reset(self, seed: int) -> int:
        self.steps = 0
        return super().reset(seed)


class Shows(gym.Env):
    """Observes `value` in `space` from reset and from its one step (reward 1)."""

    action_space = gym.spaces.Discrete(2)

    def __init__(self, space: gym.Space, value: Any) -> None:
        self.observation_space, self.value = space, value

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[Any, dict]:
        super().reset(seed=seed)
        return self.value, {}

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        return self.value, 1.0, True, False, {}


def reached(observations: np.ndarray, decisions: np.ndarray, rewards: np.ndarray) -> float:
    """A score of a whole episode: 1 if it ever reached a rewarding cell, else 0."""
    return float(rewards.max() > 0)


class CoarseCartPole(gym.ObservationWrapper):
    """Gymnasium's CartPole-v1 (its state a numpy array), each observation cut to 9 cells: the
    pole's angle and its angular velocity, 3 bins each."""

    def __init__(self) -> None:
        super().__init__(gym.make("CartPole-v1"))
        self.observation_space = gym.spaces.Discrete(9)

    def observation(self, observation: np.ndarray) -> int:
        angle = int(np.digitize(observation[2], [-0.05, 0.05]))
        turning = int(np.digitize(observation[3], [-0.5, 0.5]))
        return 3 * angle + turning
