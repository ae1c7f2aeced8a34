"""The progress of a run: one line per finished job, with the count and an ETA."""

from __future__ import annotations

import sys
import time
from typing import Any

import numpy as np

from .text import _fmt_duration


class _Progress:
    """One line per finished job, with the count and an ETA from the finished jobs' times."""

    def __init__(self, jobs: list[dict[str, Any]], parallel: int, stream: Any = None) -> None:
        self.pending = {(j["row"], j["seed"]) for j in jobs}
        self.rows = {j["row"]: j for j in jobs}
        self.total = len(jobs)
        self.done = 0
        self.parallel = max(1, parallel)
        self.times: dict[str, list[float]] = {}
        self.start = time.perf_counter()
        self.stream = stream or sys.stdout

    def finished(self, record: dict[str, Any]) -> None:
        self.done += 1
        self.pending.discard((record["row"], record["seed"]))
        self.times.setdefault(record["row"], []).append(record["seconds"])
        every = [t for ts in self.times.values() for t in ts]
        overall = sum(every) / len(every)
        left = sum(np.mean(self.times[row]) if row in self.times else overall for row, _ in self.pending)
        eta = left / self.parallel
        width = len(str(self.total))
        print(
            f"[{self.done:>{width}}/{self.total}] {record['row']:<20} seed {record['seed']}: "
            f"{record['mean']:6.2f} ± {record['std_error']:.2f}  {record['iterations']:5d} it "
            f"(best {record['best_iteration']}, {record['stop_reason']})  {record['seconds']:6.1f} s"
            f"  | elapsed {_fmt_duration(time.perf_counter() - self.start)}, ETA {_fmt_duration(eta)}",
            file=self.stream,
            flush=True,
        )
