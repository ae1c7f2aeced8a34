"""A learned cehmm policy as an agent in a plain Gymnasium loop, on ``cehmm/TargetTracking-v0``.

Run: ``pip install -e '.[gym]' && python examples/gym_agent.py`` (about ten seconds on 2 cores).
It learns a [16, 16] policy for case 3 by the cross-entropy method, then plays 1,000 episodes of
the Gymnasium environment with ``policy.agent()`` and compares their mean return with the
engine's own evaluation of the same policy.
"""

from __future__ import annotations

import gymnasium
import numpy as np

import cehmm
import cehmm.gym  # registers cehmm/TargetTracking-v0

world = cehmm.TargetTracking(case=3)
result = cehmm.optimize(world, levels=[16, 16], samples=1000, rho=0.1, smoothing=0.5, patience=50, seed=0)
engine = result.policy.evaluate(world, episodes=20_000, seed=1)

env = gymnasium.make(cehmm.gym.ENV_ID, case=3)
agent = result.policy.agent(seed=0)
returns = []
for episode in range(1000):  # the plain loop; cehmm.gym.play(env, agent, 1000) does the same
    observation, _ = env.reset(seed=episode)
    agent.reset()
    total, done = 0.0, False
    while not done:
        observation, reward, terminated, truncated, _ = env.step(agent.act(observation))
        total += reward
        done = terminated or truncated
    returns.append(total)

mean, se = np.mean(returns), np.std(returns, ddof=1) / np.sqrt(len(returns))
print(f"Gymnasium loop, 1000 episodes: {mean:.2f} ± {se:.2f}")
print(f"engine evaluation, {engine.episodes} episodes: {engine.mean:.2f} ± {engine.std_error:.2f}")
