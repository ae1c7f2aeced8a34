"""A world written in a few lines of Python, optimised for a non-additive objective.

Run: ``pip install -e . && python examples/python_world.py`` (about twenty seconds on 2 cores).

A lost hiker walks a trail of 7 cells between two huts (cells 0 and 6) in fog: she only sees
whether she stands at a hut, and which one, when she is there; elsewhere every cell looks the
same. She starts in the middle. Each step she walks left or right (a gust of wind reverses the
step one time in five). The objective is **not a sum of step rewards**: an episode scores 1 if
she has **reached both huts** within 24 steps (a patrol), 0 otherwise. In the fog a memoryless
walker cannot tell whether to go on or to turn back, and does no better than a random one; a
walker who counts her steps (a memory used as a clock, ``init="clock"``) learns a plan: "right
for so many steps, then left".

The world follows the episode protocol (``reset(seed)``, ``step(decision)``); its step rewards
only report which hut she stands at, and ``score=`` turns the recorded episode into the value.
"""

from __future__ import annotations

import numpy as np

import cehmm

LEFT_HUT, RIGHT_HUT = 0, 6


class FoggyTrail:
    """Observations: 0 fog, 1 left hut, 2 right hut. Decisions: 0 left, 1 right."""

    n_observations, n_decisions, horizon = 3, 2, 24

    def reset(self, seed: int) -> int:
        self.rng = np.random.default_rng(seed)
        self.cell = 3
        return 0

    def step(self, decision: int) -> tuple[int, float, bool]:
        move = 1 if decision == 1 else -1
        if self.rng.random() < 0.2:
            move = -move
        self.cell = min(RIGHT_HUT, max(LEFT_HUT, self.cell + move))
        hut = {LEFT_HUT: 1, RIGHT_HUT: 2}.get(self.cell, 0)
        # The "reward" tells the score where she stands: -1 left hut, +1 right hut, 0 fog.
        return hut, {1: -1.0, 2: 1.0}.get(hut, 0.0), False


def both_huts(observations: np.ndarray, decisions: np.ndarray, rewards: np.ndarray) -> float:
    """1 if the episode reached both huts, else 0 (a function of the whole episode)."""
    return float((rewards < 0).any() and (rewards > 0).any())


world = cehmm.PythonWorld(FoggyTrail(), score=both_huts)
settings = dict(samples=1000, rho=0.05, smoothing=0.3, patience=50, max_iterations=150, progress=False)
for name, levels, init in (("memoryless", [2], "random"), ("step counter", [24, 24], "clock")):
    result = cehmm.optimize(world, levels=levels, init=init, **settings)
    e = result.evaluation
    done = f"{e.mean:.3f} ± {e.std_error:.3f}"
    print(f"{name:13} {str(levels):9} patrols completed: {done} ({result.iterations} iterations)")
print(f"uniform random walker            {cehmm.Policy.uniform(world, [1]).evaluate(world).mean:.3f}")
