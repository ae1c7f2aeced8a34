"""The Ray backend's cost against the local one, in one run: seconds per CE iteration for a few
N and world costs, locally and on a local Ray of ``--cpus`` CPUs with 1, 2 and 4 workers, then
a model of the overhead fitted to those times (docs/performance.md, "The Ray backend").

Worlds: the engine's target tracking (case 3, ≈ 50 ns a step), and a corridor written in Python
(episode protocol, horizon 10) whose step spins for ``cost`` µs of CPU (a stand-in for a
simulator: spinning, not sleeping, so that it needs a core).

The model: an iteration on Ray takes ``a + b·W + (1 + ρ)·S/min(W, cpus)`` seconds, ``S`` the
iteration's work on one core (measured locally, one thread), ``(1 + ρ)`` because the workers
sample the N episodes then re-run the elite's ρN to count them (model §9), ``a`` the fixed cost
of the two round trips (rewards, then counts) and ``b`` the cost of one more task; ``a`` and
``b`` are fitted by least squares to the Ray times of the cheap cases (``S`` under
``FIT_BELOW``, where the overhead is most of the time), then checked against the others.

Usage::

    python3 benches/ray_overhead.py                 # about three minutes on this machine
    python3 benches/ray_overhead.py --iterations 4 --cpus 2
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import ray

import cehmm

RHO = 0.5  # the default selective rate
FIT_BELOW = 0.1  # seconds of one-core work per iteration


class Spins:
    """Cells 0..5 (the corridor of tests/worlds.py without wind), each step spinning `cost` µs."""

    n_observations, n_decisions, horizon = 6, 2, 10

    def __init__(self, cost: float) -> None:
        self.cost = cost * 1e-6

    def reset(self, seed: int) -> int:
        self.cell = 0
        return 0

    def step(self, decision: int) -> tuple[int, float, bool]:
        end = time.perf_counter() + self.cost
        while time.perf_counter() < end:
            pass
        self.cell = min(5, max(0, self.cell + (1 if decision == 1 else -1)))
        return self.cell, float(self.cell == 5), False


def per_iteration(world: object, samples: int, iterations: int, **options: object) -> float:
    """Seconds per iteration after the first (start-up and the evaluation left out)."""
    result = cehmm.optimize(
        world,
        levels=[2],
        samples=samples,
        rho=RHO,
        max_iterations=iterations + 1,
        patience=10**6,
        eval_episodes=1,
        progress=False,
        **options,
    )
    seconds = result.history["seconds"]
    return float(seconds[-1] - seconds[0]) / (len(seconds) - 1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--iterations", type=int, default=3)
    parser.add_argument("--cpus", type=int, default=2)
    args = parser.parse_args()
    start = time.perf_counter()
    loopback = dict(include_dashboard=False, _node_ip_address="127.0.0.1", log_to_driver=False)
    ray.init(address="local", num_cpus=args.cpus, **loopback)
    print(f"local Ray started in {time.perf_counter() - start:.1f} s ({args.cpus} CPUs, Ray {ray.__version__})")
    cases = [
        ("target tracking (engine)", cehmm.TargetTracking(case=3), 1000),
        ("target tracking (engine)", cehmm.TargetTracking(case=3), 10000),
        ("Python corridor, 0 µs", Spins(0), 1000),
        ("Python corridor, 10 µs", Spins(10), 1000),
        ("Python corridor, 100 µs", Spins(100), 1000),
        ("Python corridor, 100 µs", Spins(100), 4000),
    ]
    workers = [1, 2, 4]
    print(
        "| world | N | local, 1 thread | local, 2 threads |"
        + "".join(f" Ray, {w} worker{'s' if w > 1 else ''} |" for w in workers)
        + " best Ray / best local |"
    )
    print("|---|---:|" + "---:|" * (3 + len(workers)))
    rows = []
    for name, world, samples in cases:
        one = per_iteration(world, samples, args.iterations, threads=1)
        two = per_iteration(world, samples, args.iterations, threads=2)
        remote = [per_iteration(world, samples, args.iterations, backend="ray", workers=w) for w in workers]
        rows.append((one, remote))
        cells = "".join(f" {t * 1e3:.1f} ms |" for t in [one, two, *remote])
        print(f"| {name} | {samples} |{cells} {min(remote) / min(one, two):.2f} |")

    # Least squares for t_ray − (1 + ρ)·S/min(W, cpus) = a + b·W, on the cheap cases.
    def work(one: float, w: int) -> float:
        return (1 + RHO) * one / min(w, args.cpus)

    cheap = [(one, w, t) for one, remote in rows if one < FIT_BELOW for w, t in zip(workers, remote)]
    design = np.array([[1.0, w] for _, w, _ in cheap])
    (a, b), *_ = np.linalg.lstsq(design, np.array([t - work(one, w) for one, w, t in cheap]), rcond=None)
    print(f"\nfitted on the {len(cheap)} times with S < {FIT_BELOW * 1e3:.0f} ms:", end=" ")
    print(f"a = {a * 1e3:.1f} ms, b = {b * 1e3:.2f} ms")
    print("\n| S (1 core) |" + "".join(f" {w} worker(s): model / measured |" for w in workers))
    print("|---:|" + "---:|" * len(workers))
    for one, remote in rows:
        model = [a + b * w + work(one, w) for w in workers]
        cells = "".join(f" {m * 1e3:.0f} / {t * 1e3:.0f} ms |" for m, t in zip(model, remote))
        print(f"| {one * 1e3:.1f} ms |{cells}")
    for w in (2, 4, 16, 64):
        # Ray on w cores beats one core when a + b·w + (1 + ρ)·S/w < S.
        gain = 1 - (1 + RHO) / w
        if gain > 0:
            print(f"{w} workers beat one core when S > {(a + b * w) / gain * 1e3:.0f} ms per iteration")
    ray.shutdown()


if __name__ == "__main__":
    main()
