"""Learning curves of every method against wall-clock, one figure per task, from the JSON lines
that ``benches/sampled_defaults.py --curves`` and ``benches/recurrent_ppo.py --curves`` append.

    python3 benches/plot_curves.py curves.jsonl [more.jsonl ...] --out figures/

A line is ``{"method", "task", "seed", "curve": [{"seconds", "mean"}, ...], "final"}``: cehmm's
curve is the best value so far on its selection episodes after each iteration, RecurrentPPO's the
mean return of its last 100 training episodes after each rollout; ``final`` (the value on fresh
episodes after the run) is drawn as a marker at the curve's end. Each method has one colour, each
seed one line. Writes ``<out>/<task>.png``.
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict
from pathlib import Path
from typing import Any

from cehmm.plots._figure import figure

COLOURS = {"cehmm": "tab:blue", "RecurrentPPO": "tab:orange"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="+", type=Path)
    parser.add_argument("--out", type=Path, default=Path("."))
    args = parser.parse_args()
    tasks: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for path in args.files:
        for number, text in enumerate(path.read_text().splitlines(), 1):
            if text.strip():
                try:
                    line = json.loads(text)
                    tasks[line["task"]].append(line)
                except (json.JSONDecodeError, KeyError, TypeError) as e:
                    expected = "expected a JSON object with a task"
                    raise SystemExit(f"{path}:{number}: invalid curve line ({e!r}): {expected}") from None
    args.out.mkdir(parents=True, exist_ok=True)
    for task, lines in sorted(tasks.items()):
        fig = figure(figsize=(6.4, 4.0), layout="constrained")
        ax = fig.add_subplot()
        labelled: set[str] = set()
        for line in sorted(lines, key=lambda x: (x["method"], x["seed"])):
            method = line["method"]
            colour = COLOURS.get(method, "tab:gray")
            xs = [point["seconds"] for point in line["curve"]]
            ys = [point["mean"] for point in line["curve"]]
            label = method if method not in labelled else None
            labelled.add(method)
            ax.plot(xs, ys, color=colour, alpha=0.8, label=label)
            if "final" in line and xs:
                ax.plot([xs[-1]], [line["final"]], marker="o", color=colour)
        ax.set_xlabel("seconds of training (one core)")
        ax.set_ylabel("value (mean return); dot: on fresh episodes")
        ax.set_title(task)
        ax.legend(loc="best")
        fig.savefig(args.out / f"{task}.png", dpi=100)
        print(args.out / f"{task}.png")


if __name__ == "__main__":
    main()
