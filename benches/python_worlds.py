"""Episode-steps per second of the CE optimiser on one thread, for the same world written four
ways: the engine's own (Rust), in Python with the episode protocol, in numpy with the batched
protocol, and as a Gymnasium environment (cehmm/TargetTracking-v0, stepped through the episode
protocol). Case 3, levels [16, 16], N = 1000 episodes per iteration, all in one run.

For each it also times the world's own code alone (the same calls from a plain Python loop, with
random decisions), so that the engine's overhead per step (the policy's draws, recording,
counting, the refit, and crossing into the interpreter) is the difference of the two.

Usage::

    python3 benches/python_worlds.py               # about two minutes on this machine
    python3 benches/python_worlds.py --iterations 5
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from typing import Any

import gymnasium
import numpy as np

import cehmm
import cehmm.gym
from cehmm.pyworlds import TrackingBatch, TrackingEpisodes

SAMPLES, HORIZON, LEVELS = 1000, 100, [16, 16]


class NoOp:
    """A world that does nothing (episode protocol): what remains is the engine's cost."""

    n_observations, n_decisions, horizon = 16, 16, HORIZON

    def reset(self, seed: int) -> int:
        return 0

    def step(self, decision: int) -> tuple[int, float, bool]:
        return 0, 0.0, False


class NoOpBatch:
    """A world that does nothing (batched protocol)."""

    batched = True
    n_observations, n_decisions, horizon = 16, 16, HORIZON

    def reset(self, n: int, seed: int) -> np.ndarray:
        self.out = (np.zeros(n, dtype=np.int64), np.zeros(n), np.zeros(n, dtype=bool))
        return self.out[0]

    def step(self, decisions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.out


def optimise_rate(world: Any, iterations: int) -> float:
    """Episode-steps per second of `iterations` CE iterations (their own seconds, not the final
    evaluation's), the best of two runs."""
    best = 0.0
    for seed in (0, 1):
        r = cehmm.optimize(
            world,
            levels=LEVELS,
            samples=SAMPLES,
            max_iterations=iterations,
            patience=10**6,
            threads=1,
            seed=seed,
            eval_episodes=1,
            progress=False,
        )
        best = max(best, iterations * SAMPLES * HORIZON / float(r.history["seconds"][-1]))
    return best


def alone_episodes(make: Callable[[], Any], episodes: int) -> float:
    """Seconds per step of an episode-protocol world's own code."""
    world, rng = make(), np.random.default_rng(0)
    decisions = rng.integers(0, 16, size=HORIZON).tolist()
    start = time.perf_counter()
    for k in range(episodes):
        world.reset(k)
        for d in decisions:
            world.step(d)
    return (time.perf_counter() - start) / (episodes * HORIZON)


def gym_env() -> Any:
    return gymnasium.make(cehmm.gym.ENV_ID, case=3)


def alone_gym(episodes: int) -> float:
    env = gym_env()
    decisions = np.random.default_rng(0).integers(0, 16, size=HORIZON).tolist()
    start = time.perf_counter()
    for k in range(episodes):
        env.reset(seed=k)
        for d in decisions:
            env.step(d)
    return (time.perf_counter() - start) / (episodes * HORIZON)


def alone_batch(repeats: int, make: Callable[[], Any] = lambda: TrackingBatch(case=3)) -> float:
    world, rng = make(), np.random.default_rng(0)
    decisions = rng.integers(0, 16, size=(HORIZON, SAMPLES))
    best = float("inf")
    for k in range(repeats):
        start = time.perf_counter()
        world.reset(SAMPLES, k)
        for d in decisions:
            world.step(d)
        best = min(best, time.perf_counter() - start)
    return best / (SAMPLES * HORIZON)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=3, help="CE iterations per timed run (default 3)")
    args = parser.parse_args()
    k = args.iterations
    rows = [
        ("Rust world (`TargetTracking(case=3)`)", optimise_rate(cehmm.TargetTracking(case=3), 10 * k), None),
        ("numpy, batched protocol (`TrackingBatch`)", optimise_rate(TrackingBatch(case=3), k), alone_batch(3)),
        (
            "Python, episode protocol (`TrackingEpisodes`)",
            optimise_rate(TrackingEpisodes(case=3), k),
            alone_episodes(lambda: TrackingEpisodes(case=3), 200),
        ),
        (
            'Gymnasium env (`gymnasium.make("cehmm/TargetTracking-v0")`)',
            optimise_rate(cehmm.PythonWorld(gym_env(), horizon=HORIZON), k),
            alone_gym(100),
        ),
    ]
    rows += [
        ("no-op world, batched protocol", optimise_rate(NoOpBatch(), 10 * k), alone_batch(3, NoOpBatch)),
        ("no-op world, episode protocol", optimise_rate(NoOp(), k), alone_episodes(NoOp, 200)),
    ]
    rust = rows[0][1]
    print(f"case 3, levels {LEVELS}, N = {SAMPLES}, T = {HORIZON}, one thread, {k} iterations per run (Rust: {10 * k})")
    print()
    print("| world | CE episode-steps/s | vs Rust | world's code alone, per step | engine's overhead per step |")
    print("|---|---|---|---|---|")
    for name, rate, alone in rows:
        per_step = 1 / rate
        overhead = f"{(per_step - alone) * 1e9:.0f} ns" if alone is not None else f"{per_step * 1e9:.0f} ns (all)"
        alone_text = f"{alone * 1e9:.0f} ns" if alone is not None else "–"
        print(f"| {name} | {rate / 1e6:.2f} M | {rate / rust:.3f} | {alone_text} | {overhead} |")


if __name__ == "__main__":
    main()
