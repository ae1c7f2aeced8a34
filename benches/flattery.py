"""Whose decisions the kept steps hold (issue 47, model §10 "Past decisions in the kept steps"): a
sketch apart from the engine that shows when the model of a lens flatters its plan on
CountRecallEasy, and that weighting each step by the inverse of its decision's probability mends
it. Needs the ``popgym`` extra.

    python3 benches/flattery.py [--episodes 1000] [--seed 0]

For each behaviour, episodes are played, the lens of the current observation and the one ``lag``
steps back is planned on half of them (each state's decision of highest mean reward: the
observations of CountRecall do not depend on the decisions, so a plan's value is the sum of its
pairs' mean rewards over the steps) and valued on the model of the others, then played on 300
fresh episodes (seeds 50,000+). Behaviours: decisions drawn uniformly at each step; random
16-node Moore tables (explorers drawn from uniform laws); a plan that holds the time (as a
confirmed table may) with each decision drawn again uniformly with probability 0.3, its pairs
counted as they are and weighted by the inverse of each decision's probability.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

import numpy as np
from popgym.envs.count_recall import CountRecallEasy

EXPLORE = 0.3
# A step: (observation, decision, reward, the decision's probability under the behaviour).
Step = tuple[int, int, float, float]


def observation(obs: np.ndarray) -> int:
    return int(obs[0]) * 2 + int(obs[1])


def state(history: list[int], lag: int) -> int:
    t = len(history) - 1
    return (history[t - lag] + 1 if t >= lag else 0) * 4 + history[t]


def play(
    env: CountRecallEasy, n: int, behaviour: Callable[[], Callable[[int], tuple[int, float]]], rng: np.random.Generator
) -> list[list[Step]]:
    episodes = []
    for _ in range(n):
        obs, _ = env.reset(seed=int(rng.integers(1 << 30)))
        decide, steps, done = behaviour(), [], False
        while not done:
            y = observation(obs)
            d, p = decide(y)
            obs, r, terminated, truncated, _ = env.step(d)
            steps.append((y, d, r, p))
            done = terminated or truncated
        episodes.append(steps)
    return episodes


def pairs(episodes: list[list[Step]], lag: int, actions: int, weighted: bool) -> np.ndarray:
    """Each (state, decision)'s mean reward (NaN where never taken)."""
    sums, weights = np.zeros((20, actions)), np.zeros((20, actions))
    for steps in episodes:
        history: list[int] = []
        for y, d, r, p in steps:
            history.append(y)
            s, w = state(history, lag), 1.0 / p if weighted else 1.0
            sums[s, d] += w * r
            weights[s, d] += w
    with np.errstate(invalid="ignore", divide="ignore"):
        return sums / weights


def model_value(plan: np.ndarray, mean: np.ndarray, episodes: list[list[Step]], lag: int) -> float:
    """The mean over ``episodes`` of the summed mean rewards of ``plan``'s pairs (0 where never taken)."""
    total = 0.0
    for steps in episodes:
        history: list[int] = []
        for y, *_ in steps:
            history.append(y)
            s = state(history, lag)
            total += 0.0 if np.isnan(mean[s, plan[s]]) else mean[s, plan[s]]
    return total / len(episodes)


def world_value(env: CountRecallEasy, plan: np.ndarray, lag: int, episodes: int = 300) -> float:
    total = 0.0
    for e in range(episodes):
        obs, _ = env.reset(seed=50_000 + e)
        history, done = [], False
        while not done:
            history.append(observation(obs))
            obs, r, terminated, truncated, _ = env.step(int(plan[state(history, lag)]))
            total += r
            done = terminated or truncated
    return total / episodes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    env = CountRecallEasy()
    actions = int(env.action_space.n)
    rng = np.random.default_rng(args.seed)

    def uniform():
        return lambda y: (int(rng.integers(actions)), 1.0 / actions)

    def table():
        act, successor, node = rng.integers(actions, size=16), rng.integers(16, size=(16, 4)), [0]

        def decide(y: int) -> tuple[int, float]:
            node[0] = successor[node[0], y]
            return int(act[node[0]]), 1.0

        return decide

    def timed():
        # Half the time so far, give or take one (a different offset at each time), each decision
        # drawn again uniformly with probability EXPLORE.
        offset, t = rng.integers(-1, 2, size=64), [0]

        def decide(y: int) -> tuple[int, float]:
            planned = max(0, min(actions - 1, t[0] // 2 + int(offset[min(t[0], 63)])))
            t[0] += 1
            d = int(rng.integers(actions)) if rng.random() < EXPLORE else planned
            return d, EXPLORE / actions + (1 - EXPLORE) * (d == planned)

        return decide

    for name, behaviour, weighted in [
        ("uniform at each step", uniform, False),
        ("random 16-node tables", table, False),
        ("a plan that holds the time", timed, False),
        ("the same, weighted 1/p", timed, True),
    ]:
        episodes = play(env, args.episodes, behaviour, rng)
        for lag in (1, 3):
            fitted = pairs(episodes[0::2], lag, actions, weighted)
            plan = np.argmax(np.where(np.isnan(fitted), -np.inf, fitted), axis=1)
            held_out = pairs(episodes[1::2], lag, actions, weighted)
            print(
                f"{name:28s} lag {lag}: model {model_value(plan, held_out, episodes[1::2], lag):7.3f}"
                f"  world {world_value(env, plan, lag):7.3f}",
                flush=True,
            )


if __name__ == "__main__":
    main()
