"""What a budget in the world's steps costs episode CE (issue 46): the same run with and without
``max_env_steps`` (a budget it never reaches, so that every iteration is run in cuts of about 256
episodes and looked at between them), timed alternately in one process, the tables checked
bit-equal.

    python3 benches/budget_cut.py [--repeats 6] [--threads 2]

It prints the ratio of each pair (with budget / without) and their median; the first pair
carries the process's warm-up.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import cehmm


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=6)
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    world = cehmm.TargetTracking(case=3)
    settings = dict(levels=[16, 16], samples=2000, max_iterations=15, eval_episodes=100, progress=False)

    def timed(**budget: int) -> tuple[float, cehmm.OptimizeResult]:
        started = time.perf_counter()
        result = cehmm.optimize(world, threads=args.threads, **settings, **budget)
        return time.perf_counter() - started, result

    ratios = []
    for _ in range(args.repeats):
        free, a = timed()
        cut, b = timed(max_env_steps=10**12)
        assert all(np.array_equal(a.policy.tables[k], b.policy.tables[k]) for k in ("h0", "h1"))
        assert a.env_steps == b.env_steps
        ratios.append(cut / free)
    shown = ", ".join(f"{r:.3f}" for r in ratios)
    print(f"{a.env_steps} steps a run; with budget / without: {shown}; median {statistics.median(ratios):.3f}")


if __name__ == "__main__":
    main()
