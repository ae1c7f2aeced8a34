"""The memory benchmark: tasks that need memory, learnt by each method under budgets of the
world's steps and of seconds, every policy valued the same way
(``python -m cehmm.benchmarks.memory``).

Tasks: POPGym's Easy games through Gymnasium (``pip install popgym``) and the T-maze of
:mod:`cehmm.memory_tasks`. Budgets: ``50k`` and ``200k`` environment steps of learning
(``max_env_steps``: equal environment steps is the comparison that counts) and ``300s`` of wall
time on one core; ``--budgets`` takes others (``5k``, ``1000``, ``30s``). Methods:

* ``random``: the uniform policy (no learning; one cell per task);
* ``memoryless``: the controller search (model §8) over one node, with its defaults: the best
  memoryless policy it finds in the budget;
* ``cehmm``: the cross-entropy method over controllers on sampled values, with its defaults
  (:func:`cehmm.optimize_controller` with ``search="ce"``: the default learner of sampled worlds
  before the model search);
* ``model-search``: the search of memories on the model of every step (``cehmm.run("model-search",
  ...)``, issue 47), with its defaults: the default learner of sampled worlds
  (:func:`cehmm.optimize_controller`'s defaults);
* ``recurrent-ppo``: sb3-contrib's RecurrentPPO (:mod:`cehmm.benchmarks.rival`; optional: ``pip
  install -e '.[rivals]'``), trained once per task and seed to the largest budget, valued at each.

Every policy is valued on the same ``--episodes`` fresh episodes (seeds ``EVAL_SEED + k``) played
through the environment's own loop by its agent (:meth:`cehmm.Policy.agent`; the rival's LSTM
likewise, deterministic actions). Each finished cell is one line of ``OUT/data/memory.jsonl``: a
cell already there is not run again (the rival's records, costly, are reused as they are);
``--jobs`` runs cells in parallel, one core each. The page is ``OUT/memory-benchmark.md`` with its
figures in ``OUT/img/memory/`` (:mod:`cehmm.benchmarks.memory_report`).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import multiprocessing
import re
import sys
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

import cehmm

from ..memory_tasks import TMaze
from ..reproduce.machine import machine_text, source_commit
from ..reproduce.records import append_record, read_records
from .memory_report import write_page

PROG = "python -m cehmm.benchmarks.memory"
#: Seeds of the fresh episodes every policy is valued on (``EVAL_SEED + k``).
EVAL_SEED = 50_000
METHODS = ("random", "memoryless", "cehmm", "model-search", "recurrent-ppo")
BUDGETS = ("50k", "200k", "300s")
#: Points of a training curve kept per cell.
CURVE_POINTS = 200


@dataclass(frozen=True)
class Task:
    """A task: the environment every policy is valued in (and the rival learns in), the world
    the engine learns in, and the best value where known."""

    env: Callable[[], Any]
    world: Callable[[], Any]
    optimum: float | None
    source: str
    #: The rival's environment, where its observations need flattening.
    rival_env: Callable[[], Any] | None = None


def _popgym(name: str, optimum: float | None) -> Task:
    def env() -> Any:
        import gymnasium
        import popgym  # noqa: F401  (registers its environments)

        return gymnasium.make(f"popgym-{name}-v0")

    def world() -> Any:
        import gymnasium

        made = env()
        box = isinstance(made.observation_space, gymnasium.spaces.Box)
        # Longer than every Easy game (MultiarmedBandit's 200 steps): each plays to its end.
        return cehmm.PythonWorld(made, horizon=256, observations=cehmm.spaces.Bins() if box else None)

    def rival_env() -> Any:
        import gymnasium

        made = env()
        if isinstance(made.observation_space, gymnasium.spaces.Discrete | gymnasium.spaces.Box):
            return made
        return gymnasium.wrappers.FlattenObservation(made)

    return Task(env, world, optimum, f"POPGym {name}", rival_env)


TASKS: dict[str, Task] = {
    "RepeatFirstEasy": _popgym("RepeatFirstEasy", 1.0),
    "RepeatPreviousEasy": _popgym("RepeatPreviousEasy", 1.0),
    "AutoencodeEasy": _popgym("AutoencodeEasy", 1.0),
    "CountRecallEasy": _popgym("CountRecallEasy", 1.0),
    "HigherLowerEasy": _popgym("HigherLowerEasy", None),
    "MultiarmedBanditEasy": _popgym("MultiarmedBanditEasy", None),
    "BattleshipEasy": _popgym("BattleshipEasy", 1.0),
    "MineSweeperEasy": _popgym("MineSweeperEasy", 1.0),
    "PositionOnlyCartPoleEasy": _popgym("PositionOnlyCartPoleEasy", 1.0),
    "t-maze-10": Task(lambda: _one_episode(TMaze(corridor=10)), lambda: TMaze(corridor=10), 1.0, "Bakker 2002 (TMaze)"),
}
QUICK_TASKS = ("t-maze-10",)


def budget(text: str) -> tuple[int | None, float | None]:
    """A budget's name as (steps, seconds): ``50k`` (steps, ``k`` for thousands, ``M`` for
    millions), ``1000`` (steps) or ``300s`` (seconds)."""
    found = re.fullmatch(r"(\d+(?:\.\d+)?)(k|M|s)?", text)
    if found is None or float(found[1]) <= 0:
        raise ValueError(f"invalid budget: {text!r} (expected steps such as 50k, 2M or 1000, or seconds such as 300s)")
    number, unit = float(found[1]), found[2]
    if unit == "s":
        return None, number
    return int(number * {"k": 1e3, "M": 1e6, None: 1}[unit]), None


def _budget_order(name: str) -> tuple[int, float]:
    """Budgets in steps first, then in seconds, each growing."""
    steps, seconds = budget(name)
    return (0, float(steps)) if steps is not None else (1, float(seconds or 0))


def value_of(task: Task, agent: Callable[[], Any], episodes: int, rival: bool = False) -> tuple[float, float]:
    """The mean return and its standard error of ``agent()`` (``reset``, ``act``) on ``episodes``
    fresh episodes of ``task``'s environment (seeds ``EVAL_SEED + k``), played in its own loop
    (:func:`cehmm.gym.play`)."""
    from ..gym import play

    env = task.rival_env() if rival and task.rival_env is not None else task.env()
    returns = play(env, agent(), episodes, seed=EVAL_SEED)
    return float(returns.mean()), float(returns.std(ddof=1) / np.sqrt(len(returns)))


def run_cell(name: str, method: str, spent: str, seed: int, episodes: int) -> list[dict[str, Any]]:
    """Learns task ``name`` with ``method`` under the budget ``spent`` (see :func:`budget`) and
    values the policy; the rival gives one record per budget of ``spent`` (a comma-separated
    list), the others one."""
    task = TASKS[name]
    if method == "recurrent-ppo":
        from .rival import run_rival

        budgets = {b: budget(b) for b in spent.split(",")}
        rival = run_rival(task.rival_env or task.env, budgets, seed, lambda a: value_of(task, a, episodes, True))
        record = {"task": name, "method": method, "seed": seed, "episodes": episodes}
        return [{**record, **r, "curve": _thin(r["curve"])} for r in rival]
    world = task.world()
    started = time.perf_counter()
    extra: dict[str, Any] = {}
    if method == "random":
        policy, steps = cehmm.Policy.uniform(world, [1]), 0
    elif method in ("memoryless", "cehmm", "model-search"):
        steps_limit, seconds_limit = budget(spent)
        limits: dict[str, Any] = {"max_env_steps": steps_limit, "time_limit": seconds_limit, "threads": 1, "seed": seed}
        limits.update(eval_episodes=100, progress=False)
        if method == "model-search":
            found: Any = cehmm.run("model-search", world, **limits)
            best = found.history["best"]
        else:
            nodes: dict[str, Any] = {"nodes": 1} if method == "memoryless" else {}
            found = cehmm.optimize_controller(world, value="sampled", search="ce", **limits, **nodes)
            best = found.history["best_so_far"]
        policy, steps = found.policy, found.env_steps
        points = zip(found.history["env_steps"], found.history["seconds"], best, strict=True)
        extra = {
            "stop": found.stop_reason,
            "nodes": found.policy.levels[-1],
            "curve": _thin([[int(s), round(float(t), 2), round(float(v), 4)] for s, t, v in points]),
        }
    else:
        raise ValueError(f"invalid method: {method!r} (expected one of {', '.join(METHODS)})")
    seconds = time.perf_counter() - started
    mean, error = value_of(task, lambda: policy.agent(seed=seed), episodes)
    record = {"task": name, "method": method, "budget": spent, "seed": seed, "episodes": episodes}
    return [{**record, "value": mean, "std_error": error, "env_steps": steps, "seconds": seconds, **extra}]


def _thin(curve: list[list[float]]) -> list[list[float]]:
    if len(curve) <= CURVE_POINTS:
        return curve
    step = len(curve) / CURVE_POINTS
    return [curve[int(k * step)] for k in range(CURVE_POINTS - 1)] + [curve[-1]]


def _one_episode(world: Any) -> Any:
    """A batched world of :mod:`cehmm.memory_tasks` as a Gymnasium environment of one episode at
    a time (the sum of its rewards is its value)."""
    import gymnasium

    class OneEpisode(gymnasium.Env):  # type: ignore[misc]
        def __init__(self) -> None:
            self.observation_space = gymnasium.spaces.Discrete(world.n_observations)
            self.action_space = gymnasium.spaces.Discrete(world.n_decisions)
            self._seed, self._t = 0, 0

        def reset(self, *, seed: int | None = None, options: Any = None) -> tuple[int, dict[str, Any]]:
            self._seed = self._seed + 1 if seed is None else seed
            self._t = 0
            return int(np.asarray(world.reset(1, self._seed))[0]), {}

        def step(self, action: Any) -> tuple[int, float, bool, bool, dict[str, Any]]:
            self._t += 1
            ys, rewards, dones = world.step(np.asarray(action, dtype=np.int64).reshape(1))
            done = bool(dones[0])
            return int(ys[0]), float(rewards[0]), done, not done and self._t >= world.horizon, {}

    return OneEpisode()


def jobs(
    names: Sequence[str], methods: Sequence[str], budgets: Sequence[str], seeds: Sequence[int], done: set[tuple]
) -> list[tuple[str, str, str, int]]:
    """The cells still to run, as ``run_cell``'s first four arguments: the rival's budgets of a
    task and seed in one job (one training run), ``random`` once per task (seed 0, budget 0)."""
    todo = []
    for name in names:
        for method in methods:
            if method == "random":
                if (name, method, "0", 0) not in done:
                    todo.append((name, method, "0", 0))
                continue
            for seed in seeds if method != "recurrent-ppo" else seeds[:1]:
                missing = [b for b in budgets if (name, method, b, seed) not in done]
                if method == "recurrent-ppo" and missing:
                    todo.append((name, method, ",".join(missing), seed))
                else:
                    todo.extend((name, method, b, seed) for b in missing)
    return todo


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0] if __doc__ else None)
    p.add_argument("--tasks", nargs="+", choices=list(TASKS), help="tasks (default: every one)")
    p.add_argument("--methods", nargs="+", choices=METHODS, default=list(METHODS), help="methods (default: all)")
    p.add_argument("--budgets", nargs="+", default=list(BUDGETS), help="budgets: 50k (steps), 300s (seconds)")
    p.add_argument(
        "--seeds", nargs="+", type=int, default=[0, 1, 2], help="seeds of the learners (the rival: the first)"
    )
    p.add_argument("--episodes", type=int, default=300, help="fresh episodes each policy is valued on")
    p.add_argument("--jobs", type=int, default=1, help="cells run at once, one core each")
    p.add_argument("--quick", action="store_true", help=f"tasks {', '.join(QUICK_TASKS)}, budget 5k, one seed")
    p.add_argument("--out", type=Path, default=Path("docs"), help="where data/memory.jsonl and the page go")
    p.add_argument("--report-only", action="store_true", help="run nothing: rebuild the page from the data")
    args = p.parse_args(argv)
    for b in args.budgets:
        try:
            budget(b)
        except ValueError as e:
            p.error(str(e))
    if args.episodes < 2 or args.jobs < 1:
        p.error("--episodes must be at least 2 and --jobs at least 1")
    budgets, seeds = (["5k"], [0]) if args.quick else (args.budgets, args.seeds)
    names = args.tasks or (list(QUICK_TASKS) if args.quick else list(TASKS))
    data = args.out / "data" / "memory.jsonl"
    records = read_records(data)
    if not args.report_only:
        done = {(r["task"], r["method"], r["budget"], r["seed"]) for r in records if "task" in r}
        todo = jobs(names, args.methods, budgets, seeds, done)
        stamp = {"commit": source_commit(), "date": _dt.date.today().isoformat(), "machine": machine_text()}
        for found in _run_all(todo, args.episodes, args.jobs):
            for record in found:
                record = {**record, **stamp}
                print(
                    f"{record['task']:26} {record['method']:14} {record['budget']:>6} seed {record['seed']}  "
                    f"{record['value']:8.3f} ± {record['std_error']:.3f}  {record['env_steps']:>9,} steps  "
                    f"{record['seconds']:7.1f} s",
                    flush=True,
                )
                append_record(data, record)
    # The page of the data as it is now: other runs may have added cells (or a cell been dropped)
    # since this one read it.
    write_page(args.out, read_records(data), TASKS, _budget_order)
    return 0


def _run_all(todo: list[tuple[str, str, str, int]], episodes: int, workers: int) -> Any:
    """Each job's records as it finishes: here one after another, or in ``workers`` processes."""
    if workers == 1:
        for job in todo:
            yield run_cell(*job, episodes)
        return
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        for future in as_completed([pool.submit(run_cell, *job, episodes) for job in todo]):
            yield future.result()


if __name__ == "__main__":
    sys.exit(main())
