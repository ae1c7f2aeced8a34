"""Episode-steps per second of the controller search on sampled values (model §8) against the
episode CE (model §3), on the same world and thread count, measured in one run.

    python3 benches/controller_speed.py [--threads 1 2] [--repeats 3]

For each world (target tracking case 3, tiger's `.pomdp` world, the numpy RepeatFirst of
``cehmm.memory_tasks``) and thread count, it times a few iterations of each optimiser and counts
every episode-step it ran: for the episode CE ``samples × horizon`` per iteration; for the
controller search ``(samples × episodes + candidates × select_episodes) × horizon`` (its
selection episodes included). The evaluation of the result is left out of both (a few
episodes). It prints a Markdown table: steps/s of each and their ratio (best of ``--repeats``).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import cehmm
from cehmm.memory_tasks import RepeatFirst

DATA = Path(__file__).resolve().parents[1] / "data" / "pomdp"


def worlds() -> dict[str, tuple[object, int]]:
    """name -> (world, horizon)."""
    tiger = cehmm.PomdpWorld.from_file(DATA / "tiger.95.POMDP", horizon=100)
    return {
        "target tracking, case 3": (cehmm.TargetTracking(case=3), 100),
        "tiger.95 (.pomdp)": (tiger, 100),
        "RepeatFirst (numpy, batched)": (RepeatFirst(), RepeatFirst().horizon),
    }


def episode_ce(world: object, horizon: int, threads: int, iterations: int) -> float:
    samples = 2000
    started = time.perf_counter()
    cehmm.optimize(
        world,
        levels=[8, 8],
        samples=samples,
        max_iterations=iterations,
        threads=threads,
        eval_episodes=2,
        progress=False,
    )
    return samples * horizon * iterations / (time.perf_counter() - started)


def controller(world: object, horizon: int, threads: int, iterations: int) -> float:
    samples, episodes, candidates, select = 500, 40, 4, 200
    started = time.perf_counter()
    cehmm.optimize_controller(
        world,
        nodes=8,
        value="sampled",
        search="ce",
        samples=samples,
        episodes=episodes,
        candidates=candidates,
        select_episodes=select,
        max_iterations=iterations,
        threads=threads,
        eval_episodes=2,
        progress=False,
    )
    steps = (samples * episodes + candidates * select) * horizon * iterations
    return steps / (time.perf_counter() - started)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--iterations", type=int, default=5)
    args = p.parse_args()
    print("| world | threads | episode CE steps/s | controller search steps/s | ratio |")
    print("|---|---:|---:|---:|---:|")
    for name, (world, horizon) in worlds().items():
        for threads in args.threads:
            ce = max(episode_ce(world, horizon, threads, args.iterations) for _ in range(args.repeats))
            cs = max(controller(world, horizon, threads, args.iterations) for _ in range(args.repeats))
            print(f"| {name} | {threads} | {ce / 1e6:.2f} M | {cs / 1e6:.2f} M | {cs / ce:.2f} |", flush=True)


if __name__ == "__main__":
    main()
