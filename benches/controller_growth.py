"""What growth buys the controller search (model §8): a search started with too few nodes,
with and without ``growths``, against one started with enough, on exact values.

    python3 benches/controller_growth.py [--files tiger.95.POMDP shuttle.95.POMDP cheese.95.POMDP]

For each file it runs ``optimize_controller`` with ``patience=20`` and otherwise default
settings: 3 nodes; 3 nodes with ``growths=2`` (``injection`` 0.2 and 0.5); 5 nodes. It prints a
Markdown table: the nodes of the controller returned, its exact value, iterations and seconds.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import cehmm

DATA = Path(__file__).resolve().parents[1] / "data" / "pomdp"
SETTINGS = [
    ("3 nodes", dict(nodes=3)),
    ("3 nodes, growths 2", dict(nodes=3, growths=2)),
    ("3 nodes, growths 2, injection 0.5", dict(nodes=3, growths=2, injection=0.5)),
    ("5 nodes", dict(nodes=5)),
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--files", nargs="+", default=["tiger.95.POMDP", "shuttle.95.POMDP", "cheese.95.POMDP"])
    args = parser.parse_args()
    print("| file | search | nodes returned | exact value | iterations | seconds |")
    print("|---|---|---:|---:|---:|---:|")
    for name in args.files:
        world = cehmm.PomdpWorld.from_file(DATA / name)
        for label, settings in SETTINGS:
            start = time.perf_counter()
            r = cehmm.optimize_controller(world, patience=20, progress=False, **settings)  # type: ignore[arg-type]
            seconds = time.perf_counter() - start
            row = [name, label, r.policy.levels[0], f"{r.value:.4f}", len(r.history["mean"]), f"{seconds:.1f}"]
            print("| " + " | ".join(str(cell) for cell in row) + " |")


if __name__ == "__main__":
    main()
