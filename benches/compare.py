"""Times cehmm.optimize (Rust engine) against the plain numpy version in benches/numpy_ce.py.

Both run the same algorithm (model §2–4) on the target-tracking world, case 3, N = 1000,
rho = 0.5, alpha = 1, for a fixed number of iterations (patience set out of reach). Speed is
reported as episode-steps per second, iterations × N × T / seconds, where seconds are those of the
iterations themselves (cehmm's ``history["seconds"]``, which leaves out the final evaluation), for
the fastest run (robust to other load on the machine) and for all runs together.

Every timed run covers the same iterations 0..K-1 from a uniform start, so both engines work in
the same regime (early, near-uniform policies); cehmm's short runs are repeated with other seeds
until the total is long enough to time reliably.

Usage::

    python3 benches/compare.py            # levels [16,16] and [16], about a minute on 2 cores
    python3 benches/compare.py --levels 16,16 --iterations 20
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy_ce  # noqa: E402  (the sibling module, found through the path set just above)

import cehmm  # noqa: E402

SAMPLES, RHO, CASE, SEED = 1000, 0.5, 3, 0
NEVER = 10**9  # patience out of reach: every run stops at max_iterations


class Clock:
    """Wall and CPU time of this process (all its threads) around each timed call."""

    def __init__(self) -> None:
        self.wall = self.cpu = 0.0

    def __enter__(self) -> Clock:
        self._wall, self._cpu = time.perf_counter(), time.process_time()
        return self

    def __exit__(self, *exc: object) -> None:
        self.wall += time.perf_counter() - self._wall
        self.cpu += time.process_time() - self._cpu

    @property
    def cores(self) -> float:
        """CPU seconds per wall second: how many cores were busy on average."""
        return self.cpu / self.wall


def time_numpy(levels: list[int], iterations: int, repeats: int) -> tuple[list[float], list[np.ndarray], float]:
    """Seconds of each of ``repeats`` numpy runs of ``iterations`` iterations (seeds 0, 1, ...),
    each run's mean reward per iteration, and the cores used."""
    world = numpy_ce.Tracking(case=CASE)
    seconds, means, clock = [], [], Clock()
    for r in range(repeats):
        with clock:
            result = numpy_ce.optimize(
                world, levels=levels, samples=SAMPLES, rho=RHO, patience=NEVER, max_iterations=iterations, seed=SEED + r
            )
        seconds.append(float(result.history["seconds"][-1]))
        means.append(result.history["mean"])
    return seconds, means, clock.cores


def time_cehmm(
    levels: list[int], iterations: int, threads: int | None, min_seconds: float
) -> tuple[list[float], list[np.ndarray], float]:
    """Seconds of each cehmm run of ``iterations`` iterations, repeated (seeds 0, 1, ...) until they
    add up to ``min_seconds`` (at least 3 runs), each run's mean reward per iteration, and the cores
    used."""
    world = cehmm.TargetTracking(case=CASE)
    seconds, means, clock = [], [], Clock()
    while len(seconds) < 3 or sum(seconds) < min_seconds:
        with clock:
            result = cehmm.optimize(
                world, levels=levels, samples=SAMPLES, rho=RHO, patience=NEVER, max_iterations=iterations,
                seed=SEED + len(seconds), threads=threads, progress=False, eval_episodes=1,
            )  # fmt: skip
        seconds.append(float(result.history["seconds"][-1]))
        means.append(result.history["mean"])
    return seconds, means, clock.cores


def _mean_se(runs: list[np.ndarray]) -> str:
    per_run = np.array([r.mean() for r in runs])
    se = per_run.std(ddof=1) / np.sqrt(per_run.size) if per_run.size > 1 else float("nan")
    return f"{per_run.mean():.2f} ± {se:.2f}"


def machine() -> list[str]:
    u = platform.uname()
    names = ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE", "OPENBLAS_NUM_THREADS")
    blas = ", ".join(f"{k}={os.environ.get(k, '(unset)')}" for k in names)
    return [
        f"- machine: {u.system} {u.release} {u.machine}, os.cpu_count() = {os.cpu_count()}, "
        f"processor = {platform.processor() or '(empty)'}, {_cpu_model()}",
        f"- Python {platform.python_version()}, numpy {np.__version__}, cehmm {getattr(cehmm, '__version__', '?')}",
        f"- {blas} (numpy_ce does elementwise work and no BLAS calls: recorded only)",
        f"- command: `python3 {' '.join(sys.argv)}`",
    ]


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "cpu model unknown"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument(
        "--levels", action="append", help="levels to time, e.g. 16,16 (repeatable; default 16,16 and 16)"
    )
    parser.add_argument("--iterations", type=int, default=20, help="iterations per timed run (default 20)")
    parser.add_argument("--numpy-repeats", type=int, default=3, help="numpy runs per configuration (default 3)")
    parser.add_argument("--min-seconds", type=float, default=3.0, help="least cehmm time per configuration")
    args = parser.parse_args()
    configs = [[int(x) for x in s.split(",")] for s in (args.levels or ["16,16", "16"])]
    k, horizon = args.iterations, numpy_ce.Tracking(case=CASE).horizon

    load_before = os.getloadavg()
    started = time.perf_counter()
    steps = k * SAMPLES * horizon  # episode-steps of one run
    rows, curves = [], []
    for levels in configs:
        np_s, np_means, np_cores = time_numpy(levels, k, args.numpy_repeats)
        np_best = steps / min(np_s)
        rows.append((levels, "numpy_ce", "1", np_s, np_best, 1.0, np_cores))
        for threads in (1, None):
            s, means, cores = time_cehmm(levels, k, threads, args.min_seconds)
            label = str(threads) if threads else f"None = all ({os.cpu_count()})"
            rows.append((levels, "cehmm", label, s, steps / min(s), steps / min(s) / np_best, cores))
            if threads == 1:
                curves.append((levels, np_means, means))
    total = time.perf_counter() - started
    load_after = os.getloadavg()

    print(f"## cehmm vs numpy_ce: case {CASE}, N = {SAMPLES}, rho = {RHO}, alpha = 1, T = {horizon}\n")
    print("\n".join(machine()))
    print(f"- every run: iterations 0..{k - 1} from uniform tables, {steps:,} episode-steps")
    print("- episode-steps/s: of the fastest run (robust to other load on the machine) and of all runs together")
    print("- × numpy: fastest-run rates; cores busy: CPU seconds / wall seconds of the process during the runs\n")
    print("| levels | engine | threads | runs | seconds (all) | episode-steps/s fastest | all | × numpy | cores busy |")
    print("|---|---|---|---:|---:|---:|---:|---:|---:|")
    for levels, engine, threads, s, best, ratio, cores in rows:
        total_rate = len(s) * steps / sum(s)
        print(
            f"| {levels} | {engine} | {threads} | {len(s)} | {sum(s):.2f} | {best / 1e6:.2f} M "
            f"| {total_rate / 1e6:.2f} M | {ratio:.1f} | {cores:.2f} |"
        )
    # Anything else running on the machine skews these numbers: the load shows it.
    print(
        f"\n(total run time {total:.0f} s; 1-minute load average {load_before[0]:.2f} before, "
        f"{load_after[0]:.2f} after; this script alone adds about 1)\n"
    )
    # The same iterations' mean rewards: the engines have different random streams, so only their
    # distributions should agree; a cheap check that both run the same algorithm.
    for levels, a, b in curves:
        print(f"mean reward per iteration, levels {levels}, seed 0:")
        print("  numpy_ce: " + " ".join(f"{x:.2f}" for x in a[0]))
        print("  cehmm:    " + " ".join(f"{x:.2f}" for x in b[0]))
        both = ", ".join(f"{name} {_mean_se(r)} ({len(r)} runs)" for name, r in (("numpy_ce", a), ("cehmm", b)))
        print(f"  average over iterations 0..{k - 1}, mean ± s.e. over runs (seeds 0, 1, ...): {both}\n")


if __name__ == "__main__":
    main()
