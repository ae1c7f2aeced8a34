"""The controller search on sampled values with its defaults (model §8), or with other settings,
on memory tasks of the engine, numpy and POPGym (through Gymnasium), at a fixed time each.

    python3 benches/sampled_defaults.py [--tasks t-maze repeat-first ...] [--seconds 60]
        [--seeds 0 1 2] [--settings '{"samples": 1000, "episodes": 100, "select_episodes": 2000}']
        [--curves curves.jsonl] [--bins '{"bins": 8, "fit": "bounds"}']

For each task and seed it runs ``optimize_controller(world, time_limit=seconds, threads=1,
seed=seed, **settings)`` and prints a Markdown table: the value on fresh episodes, iterations, the iteration whose
memoryless stage ended (``-`` where none did), the nodes of the policy file (its upper level: a
Mealy controller's lower level holds its (decision, next node) pairs), the seconds
taken and, on POPGym tasks, the environment steps taken (both with the final evaluation, its
``eval_episodes`` fresh episodes), and the value of the uniformly random policy on the same
number of fresh episodes (``random``). POPGym tasks need ``pip install popgym``; ``--bins``
chooses how a ``Box`` observation is cut (:class:`cehmm.spaces.Bins`'s keywords; default its
default). With ``--curves``
it appends one JSON line per task and seed with the learning curve (after each iteration: the
seconds and the best value so far on the selection episodes), as ``benches/recurrent_ppo.py``
does for its rival; ``benches/plot_curves.py`` draws them.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from typing import Any

import cehmm
import cehmm.spaces
from cehmm.memory_tasks import RepeatFirst, RepeatPrevious, TMaze

STEPS = [0]
BINS: dict[str, Any] = {}


def _popgym(name: str) -> Callable[[], Any]:
    def make() -> Any:
        import gymnasium as gym
        import popgym  # noqa: F401  (registers its environments)

        class Counted(gym.Wrapper):  # type: ignore[misc]
            def step(self, action: Any) -> Any:
                STEPS[0] += 1
                return self.env.step(action)

        # Longer than every Easy game (MultiarmedBandit's 200 steps): each plays to its end.
        env = Counted(gym.make(f"popgym-{name}-v0"))
        observations = cehmm.spaces.Bins(**BINS) if isinstance(env.observation_space, gym.spaces.Box) else None
        return cehmm.PythonWorld(env, horizon=256, observations=observations)

    return make


TASKS: dict[str, Callable[[], Any]] = {
    "t-maze": lambda: TMaze(corridor=10),
    "repeat-first": RepeatFirst,
    "repeat-previous": RepeatPrevious,
    "tracking-1": lambda: cehmm.TargetTracking(case=1),
    "tracking-2": lambda: cehmm.TargetTracking(case=2),
    "tracking-3": lambda: cehmm.TargetTracking(case=3),
    "HigherLowerEasy": _popgym("HigherLowerEasy"),
    "RepeatFirstEasy": _popgym("RepeatFirstEasy"),
    "RepeatPreviousEasy": _popgym("RepeatPreviousEasy"),
    "AutoencodeEasy": _popgym("AutoencodeEasy"),
    "CountRecallEasy": _popgym("CountRecallEasy"),
    "MultiarmedBanditEasy": _popgym("MultiarmedBanditEasy"),
    "BattleshipEasy": _popgym("BattleshipEasy"),
    "MineSweeperEasy": _popgym("MineSweeperEasy"),
    "PositionOnlyCartPoleEasy": _popgym("PositionOnlyCartPoleEasy"),
    "NoisyPositionOnlyCartPoleEasy": _popgym("NoisyPositionOnlyCartPoleEasy"),
    "PositionOnlyPendulumEasy": _popgym("PositionOnlyPendulumEasy"),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", nargs="+", default=list(TASKS)[:6], choices=list(TASKS))
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--settings", type=json.loads, default={}, help="more settings, as a JSON object")
    parser.add_argument("--curves", help="append the learning curves to this JSON-lines file")
    parser.add_argument("--bins", type=json.loads, default={}, help="cehmm.spaces.Bins keywords, as a JSON object")
    args = parser.parse_args()
    BINS.update(args.bins)
    print(f"settings: defaults, {args.settings}, bins {args.bins}; {args.seconds:g} s each, one thread")
    print("| task | seed | value | random | iterations | stage ended | nodes | seconds | env steps |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name in args.tasks:
        for seed in args.seeds:
            STEPS[0] = 0
            start = time.perf_counter()
            world = TASKS[name]()
            result = cehmm.optimize_controller(
                world, time_limit=args.seconds, threads=1, seed=seed, progress=False, **args.settings
            )
            seconds = time.perf_counter() - start
            steps = f"{STEPS[0]:,}" if STEPS[0] else "-"
            episodes = result.evaluation.episodes if result.evaluation is not None else 10_000
            uniform = cehmm.Policy.uniform(world, [1]).evaluate(world, episodes=episodes, seed=seed + 1, threads=1)
            history = result.history
            ended = [i for i, w in enumerate(history["widened"]) if w]
            row = [
                name,
                seed,
                f"{result.value:.4f}",
                f"{uniform.mean:.4f}",
                len(history["mean"]),
                ended[0] if ended else "-",
            ]
            cells = [*row, result.policy.levels[-1], f"{seconds:.1f}", steps]
            print("| " + " | ".join(str(x) for x in cells) + " |", flush=True)
            if args.curves:
                curve = [
                    {"seconds": float(t), "mean": float(v)}
                    for t, v in zip(history["seconds"], history["best_so_far"], strict=True)
                ]
                line = {"method": "cehmm", "task": name, "seed": seed, "curve": curve, "final": result.value}
                with open(args.curves, "a") as out:
                    out.write(json.dumps(line) + "\n")


if __name__ == "__main__":
    main()
