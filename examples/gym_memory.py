"""A Gymnasium environment from a real package that needs memory: POPGym's Battleship.

Run: ``pip install -e '.[gym]' popgym && python examples/gym_memory.py`` (about two minutes on
2 cores).

Why this one: POPGym (``pip install popgym``: pure Python, needs only numpy and gymnasium) is a
benchmark suite of partially observable environments made to test memory. In
``popgym-BattleshipEasy-v0`` four ships (12 cells) hide on an 8 × 8 board; each step fires at
one cell (a ``MultiDiscrete([8, 8])`` action, which cehmm flattens to 64 decisions) and observes
only hit or miss (``Discrete(2)``). A hit earns 1/12, a miss costs 1/52; the episode ends when
every ship is sunk (early termination) or after 64 shots. A memoryless policy sees one bit and
keeps firing at the same few cells; firing at every cell once, in any order, scores about +0.08
on average. Remembering how far one has got in a firing plan is the memory this needs: a policy
whose memory counts the shots (``init="clock"``) learns such a plan.

The learned policy is then played in a plain Gymnasium loop, its decisions mapped back to the
environment's actions.
"""

from __future__ import annotations

import gymnasium
import numpy as np
import popgym  # noqa: F401  (registers the popgym-* environments)

import cehmm
import cehmm.gym

ENV_ID = "popgym-BattleshipEasy-v0"

world = cehmm.PythonWorld(gymnasium.make(ENV_ID), horizon=64)
print(f"{world}: uniform random policy {cehmm.Policy.uniform(world, [1]).evaluate(world, episodes=2000).mean:+.3f}")
settings = dict(samples=500, rho=0.1, smoothing=0.5, eval_episodes=2000, progress=False)
memoryless = cehmm.optimize(world, levels=[2], init="random", max_iterations=100, **settings)
print(f"memoryless [2]:        {memoryless.evaluation.mean:+.3f} ± {memoryless.evaluation.std_error:.3f}")
result = cehmm.optimize(world, levels=[64, 64], init="clock", max_iterations=300, patience=300, **settings)
e = result.evaluation
print(
    f"shot counter [64, 64]: {e.mean:+.3f} ± {e.std_error:.3f} ({result.iterations} iterations, {result.seconds:.0f} s)"
)

# The agent in a Gymnasium loop (cehmm.gym.play maps observations and actions through the
# flattening of the environment's spaces: here MultiDiscrete([8, 8]) actions).
returns = cehmm.gym.play(gymnasium.make(ENV_ID), result.policy.agent(seed=0), episodes=500, seed=10_000)
print(f"Gymnasium loop, 500 episodes: {returns.mean():+.3f} ± {returns.std(ddof=1) / np.sqrt(500):.3f}")
