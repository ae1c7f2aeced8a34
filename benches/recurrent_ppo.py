"""The rival of issue 31: sb3-contrib's RecurrentPPO on POPGym's games, at a fixed time each, on
one thread, evaluated as ``benches/sampled_defaults.py`` evaluates the controller search.

    pip install -e '.[rivals]'
    python3 benches/recurrent_ppo.py [--tasks RepeatPreviousEasy ...] [--seconds 300] [--seeds 0 1 2]
        [--episodes 500] [--curves curves.jsonl]

For each task and seed it trains ``RecurrentPPO("MlpLstmPolicy", env, n_steps=512)`` (the
settings of issue 31's measurement, sb3-contrib's defaults otherwise) until ``--seconds`` of
wall-clock have passed, checked after each environment step, then plays ``--episodes`` fresh
episodes with the deterministic policy and prints a Markdown table: the mean undiscounted return,
the environment steps of training, and the seconds. With ``--curves`` it appends one JSON line per
rollout (task, seed, seconds, env steps, mean return of the last 100 training episodes) for the
learning curves. Observations that are tuples or several discrete parts (Autoencode, CountRecall)
are one-hot encoded by Gymnasium's ``FlattenObservation``; ``MultiDiscrete`` actions (Battleship,
MineSweeper) are taken as they are. A heavy optional extra: never run in CI.
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import gymnasium as gym
import numpy as np
import popgym  # noqa: F401  (registers its environments)
import torch
from sb3_contrib import RecurrentPPO
from stable_baselines3.common.callbacks import BaseCallback

TASKS = [
    "HigherLowerEasy",
    "RepeatFirstEasy",
    "RepeatPreviousEasy",
    "AutoencodeEasy",
    "CountRecallEasy",
    "MultiarmedBanditEasy",
    "BattleshipEasy",
    "MineSweeperEasy",
    "PositionOnlyCartPoleEasy",
    "NoisyPositionOnlyCartPoleEasy",
    "PositionOnlyPendulumEasy",
]


def make(name: str) -> gym.Env:
    env = gym.make(f"popgym-{name}-v0")
    if not isinstance(env.observation_space, gym.spaces.Discrete | gym.spaces.Box):
        env = gym.wrappers.FlattenObservation(env)
    return env


class Clock(BaseCallback):  # type: ignore[misc]
    """Stops training once the time is spent; records the learning curve after each rollout."""

    def __init__(self, seconds: float, curve: list[dict[str, float]]) -> None:
        super().__init__()
        self.seconds, self.curve, self.start = seconds, curve, time.perf_counter()

    def _on_step(self) -> bool:
        return time.perf_counter() - self.start < self.seconds

    def _on_rollout_end(self) -> None:
        returns = [info["r"] for info in self.model.ep_info_buffer]
        if returns:
            elapsed = time.perf_counter() - self.start
            self.curve.append({"seconds": elapsed, "env_steps": self.num_timesteps, "mean": float(np.mean(returns))})


def evaluate(model: Any, name: str, episodes: int, seed: int) -> float:
    env = make(name)
    total = 0.0
    for k in range(episodes):
        obs, _ = env.reset(seed=10_000 + 1_000 * seed + k)
        state, start, done = None, np.ones((1,), dtype=bool), False
        while not done:
            action, state = model.predict(obs, state=state, episode_start=start, deterministic=True)
            obs, reward, terminated, truncated, _ = env.step(action)
            total += float(reward)
            start = np.zeros((1,), dtype=bool)
            done = terminated or truncated
    return total / episodes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", nargs="+", default=TASKS, choices=TASKS)
    parser.add_argument("--seconds", type=float, default=300.0)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--episodes", type=int, default=500)
    parser.add_argument("--curves", help="append the learning curves to this JSON-lines file")
    args = parser.parse_args()
    torch.set_num_threads(1)
    print(f"RecurrentPPO MlpLstmPolicy n_steps=512; {args.seconds:g} s each, one thread")
    print("| task | seed | value | env steps | seconds |")
    print("|---|---:|---:|---:|---:|")
    for name in args.tasks:
        for seed in args.seeds:
            curve: list[dict[str, float]] = []
            start = time.perf_counter()
            model = RecurrentPPO("MlpLstmPolicy", make(name), n_steps=512, seed=seed, device="cpu", verbose=0)
            model.learn(total_timesteps=10**9, callback=Clock(args.seconds, curve))
            seconds = time.perf_counter() - start
            value = evaluate(model, name, args.episodes, seed)
            print(f"| {name} | {seed} | {value:.4f} | {model.num_timesteps:,} | {seconds:.1f} |", flush=True)
            if args.curves:
                with open(args.curves, "a") as out:
                    line = {"method": "RecurrentPPO", "task": name, "seed": seed, "curve": curve, "final": value}
                    out.write(json.dumps(line) + "\n")


if __name__ == "__main__":
    main()
