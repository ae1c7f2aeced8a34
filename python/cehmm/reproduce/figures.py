"""The report's figures: which ones the data calls for, the policies they need, and drawing them."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

from .._files import write_atomic
from ..paper_table import PAPER_BEST
from .text import model_text


def planned_figures(summary: list[dict[str, Any]]) -> list[str]:
    """The figures a report of ``summary`` shows: decided by the data alone, so that the report's
    text does not depend on whether they were (re)drawn this time."""
    case3 = [s for s in summary if s["case"] == 3]
    names = ["summary"] if summary else []
    if case3:
        names += ["learning_curves", "trajectory"]
    if any(len(s["levels"]) >= 2 for s in case3):
        names.append("memory")
    return names


def job_policy(run: dict[str, Any], out_dir: Path) -> Any:
    """The policy of a finished job: its file under ``out_dir``, or else the job replayed (it is
    deterministic: same seed and settings, same policy whatever the thread count)."""
    import cehmm

    path = out_dir / run["policy"]
    if path.exists():
        return cehmm.Policy.load(path)
    print(f"replaying {run['row']} seed {run['seed']} for its policy ({path} is not here)", file=sys.stderr, flush=True)
    result = cehmm.optimize(cehmm.TargetTracking(case=run["case"]), seed=run["seed"], progress=False, **run["kwargs"])
    if result.evaluation.mean != run["mean"]:
        print(
            f"warning: the replay of {run['row']} seed {run['seed']} evaluates to {result.evaluation.mean}, the record "
            f"says {run['mean']} (recorded at commit {run.get('commit', 'unknown')})",
            file=sys.stderr,
            flush=True,
        )
    path.parent.mkdir(parents=True, exist_ok=True)
    result.policy.save(path, overwrite=True)
    return result.policy


def make_figures(summary: list[dict[str, Any]], out_dir: Path, img_dir: Path, rollouts: int = 1000) -> dict[str, Path]:
    """Draws the figures of :func:`planned_figures` as PNG files; returns {name: path}. Needs
    matplotlib (warns and draws nothing without it)."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        print("matplotlib is not installed: no figures (pip install 'cehmm[plot]')", file=sys.stderr)
        return {}
    import cehmm

    from .. import plots

    planned = planned_figures(summary)
    img_dir.mkdir(parents=True, exist_ok=True)
    written: dict[str, Path] = {}

    def save(name: str, fig: Any) -> None:
        path = img_dir / f"{name}.png"
        write_atomic(path, lambda f: fig.savefig(f, dpi=110, format="png"), binary=True)
        written[name] = path

    if "summary" in planned:
        save("summary", plots.summary_bars(summary, paper_best=PAPER_BEST))

    case3 = [s for s in summary if s["case"] == 3]
    if "learning_curves" in planned:
        curves = []
        for s in case3:
            run = min(s["runs"], key=lambda r: r["seed"])
            history = {k: np.asarray(v) for k, v in run["history"].items()}
            history["iteration"] = np.arange(len(history["mean"]))
            curves.append(
                {
                    "title": f"{model_text(s)}, {s['criterion']} (seed {run['seed']})",
                    "history": history,
                    "paper": s["paper_reward"],
                    "best_iteration": run["best_iteration"],
                }
            )
        save("learning_curves", plots.learning_curves(curves))

    def best_policy(candidates: list[dict[str, Any]]) -> tuple[Any, dict[str, Any]]:
        r, s = max(((r, s) for s in candidates for r in s["runs"]), key=lambda rs: rs[0]["mean"])
        return job_policy(r, out_dir), {**r, "title": f"{model_text(s)}, {s['criterion']}"}

    world = cehmm.TargetTracking(case=3)
    if "trajectory" in planned:
        policy, run = best_policy(case3)
        title = f"{run['title']}, seed {run['seed']} (evaluated mean {run['mean']:.1f})"
        save("trajectory", plots.trajectory(policy, world, title=title))
    if "memory" in planned:
        two_level = [s for s in case3 if list(s["levels"]) == [16, 16]] or [s for s in case3 if len(s["levels"]) >= 2]
        policy, run = best_policy(two_level)
        title = f"{run['title']}, seed {run['seed']} (evaluated mean {run['mean']:.1f})"
        save("memory", plots.memory_heatmap(policy, world, episodes=rollouts, title=title))
    return written
