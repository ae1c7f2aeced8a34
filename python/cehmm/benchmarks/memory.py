"""The memory benchmark: tasks that need memory, learnt by every method under one time budget
and evaluated the same way (``python -m cehmm.benchmarks.memory``).

Tasks: the T-maze and POPGym's games of :mod:`cehmm.memory_tasks` (numpy, batched), POPGym's own
environments where ``popgym`` is installed (through Gymnasium, one episode at a time), the
target-tracking cases, and ``.pomdp`` files learnt as black boxes (sampled values) beside their
exact values. Methods:

* ``random``: the uniform policy;
* ``memoryless``: episode CE (model §3) over memoryless policies, levels ``[8]``;
* ``episode-ce``: episode CE with memory, levels ``[8, 8]``;
* ``controller``: the controller search on sampled values (model §8) with its defaults, 8 nodes;
* ``controller-exact``: the same on exact values (``.pomdp`` files only);
* ``recurrent-ppo``: sb3-contrib's RecurrentPPO (an LSTM policy; optional: ``pip install
  sb3-contrib``), trained for the same wall-clock budget.

Every method's policy is evaluated on the same ``--episodes`` fresh episodes of the task
(``Policy.evaluate(seed=EVAL_SEED)``; RecurrentPPO's LSTM on the same number of episodes of the
same world, deterministic actions). Each finished cell is one line of ``OUT/data/memory.jsonl``
(a cell already there is not run again); the report is ``OUT/memory-benchmark.md``.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

import cehmm

from .._files import write_text
from ..memory_tasks import RepeatFirst, RepeatPrevious, TMaze
from ..reproduce.machine import machine_info, source_commit
from ..reproduce.records import append_record, read_records

PROG = "python -m cehmm.benchmarks.memory"
DATA = Path(__file__).resolve().parents[3] / "data" / "pomdp"
EVAL_SEED = 12345
METHODS = ("random", "memoryless", "episode-ce", "controller", "controller-exact", "recurrent-ppo")


@dataclass(frozen=True)
class Task:
    """A task: how to make its world, its best value where known, and where it comes from."""

    make: Callable[[], Any]
    optimum: float | None
    source: str
    #: ``horizon=`` for a Gymnasium environment without one.
    horizon: int | None = None
    tabular: bool = False
    needs: str | None = None


def _pomdp(name: str, horizon: int) -> Callable[[], Any]:
    return lambda: cehmm.PomdpWorld.from_file(DATA / name, horizon=horizon)


TASKS: dict[str, Task] = {
    "t-maze-10": Task(lambda: TMaze(10), 1.0, "Bakker 2002 (cehmm.memory_tasks.TMaze)"),
    "repeat-first": Task(RepeatFirst, 1.0, "POPGym RepeatFirst, numpy (cehmm.memory_tasks)"),
    "repeat-previous": Task(RepeatPrevious, 1.0, "POPGym RepeatPrevious k=4, numpy (cehmm.memory_tasks)"),
    "popgym-RepeatFirstEasy": Task(
        lambda: "popgym-RepeatFirstEasy-v0", 1.0, "POPGym through Gymnasium", horizon=52, needs="popgym"
    ),
    "popgym-RepeatPreviousEasy": Task(
        lambda: "popgym-RepeatPreviousEasy-v0", 1.0, "POPGym through Gymnasium", horizon=52, needs="popgym"
    ),
    "tracking-1": Task(lambda: cehmm.TargetTracking(case=1), 86.0, "model §4, exact optimum"),
    "tracking-2": Task(lambda: cehmm.TargetTracking(case=2), None, "model §4 (paper: 34.1 with a clock)"),
    "tracking-3": Task(lambda: cehmm.TargetTracking(case=3), None, "model §4 (memoryless [16]: 75.7)"),
    "tiger": Task(_pomdp("tiger.95.POMDP", 100), 19.37, "SARSOP (data/pomdp/SOURCES.md)", tabular=True),
    "shuttle": Task(_pomdp("shuttle.95.POMDP", 100), 32.89, "SARSOP", tabular=True),
    "cheese": Task(_pomdp("cheese.95.POMDP", 100), 3.49, "SARSOP", tabular=True),
    "4x3": Task(_pomdp("4x3.95.POMDP", 100), 1.89, "SARSOP", tabular=True),
}
QUICK_TASKS = ("t-maze-10", "tracking-1")


def _available(task: Task) -> bool:
    if task.needs is None:
        return True
    try:
        __import__(task.needs)
    except ImportError:
        return False
    return True


def _world(task: Task) -> Any:
    world = task.make()
    if isinstance(world, str):
        import gymnasium

        return cehmm.PythonWorld(gymnasium.make(world), horizon=task.horizon)
    return world


def run_cell(name: str, method: str, budget: float, episodes: int, seed: int) -> dict[str, Any] | None:
    """Learns ``name`` with ``method`` for at most ``budget`` seconds and evaluates the result;
    ``None`` where the method does not apply."""
    if method == "recurrent-ppo":
        return _recurrent_ppo(name, budget, episodes, seed)
    task = TASKS[name]
    world = _world(task)
    started = time.perf_counter()
    extra: dict[str, Any] = {}
    if method == "random":
        policy = cehmm.Policy.uniform(world, [1])
    elif method in ("memoryless", "episode-ce"):
        levels = [8] if method == "memoryless" else [8, 8]
        policy = cehmm.optimize(
            world, levels=levels, time_limit=budget, seed=seed, progress=False, eval_episodes=100
        ).policy
    elif method in ("controller", "controller-exact"):
        if method == "controller-exact" and not task.tabular:
            return None
        value = "exact" if method == "controller-exact" else "sampled"
        found = cehmm.optimize_controller(
            world, nodes=8, value=value, time_limit=budget, seed=seed, progress=False, eval_episodes=100
        )
        policy = found.policy
        extra["iterations"] = len(found.history["mean"])
        extra["stop"] = found.stop_reason
    else:
        raise ValueError(f"invalid method: {method!r} (expected one of {', '.join(METHODS)})")
    seconds = time.perf_counter() - started
    e = policy.evaluate(world, episodes=episodes, seed=EVAL_SEED)
    if task.tabular:
        extra["exact"] = policy.evaluate_exact(world).value
    return {"task": name, "method": method, "value": e.mean, "std_error": e.std_error, "seconds": seconds, **extra}


def _recurrent_ppo(name: str, budget: float, episodes: int, seed: int) -> dict[str, Any] | None:
    """RecurrentPPO on the task as a Gymnasium environment (one-hot observations), trained for
    ``budget`` seconds, evaluated on ``episodes`` episodes; ``None`` without sb3-contrib, or for
    a world of the engine (its episodes are not a Gymnasium environment here)."""
    try:
        from sb3_contrib import RecurrentPPO
        from stable_baselines3.common.callbacks import BaseCallback
    except ImportError:
        return None
    made = TASKS[name].make()
    if not (isinstance(made, str) or getattr(made, "batched", False)):
        return None

    class Budget(BaseCallback):  # type: ignore[misc]
        def _on_step(self) -> bool:
            return time.perf_counter() - started < budget

    started = time.perf_counter()
    model = RecurrentPPO("MlpLstmPolicy", _rival_env(made), n_steps=512, seed=seed, verbose=0, device="cpu")
    model.learn(total_timesteps=10**9, callback=Budget())
    seconds = time.perf_counter() - started
    test = _rival_env(TASKS[name].make())
    values = []
    for k in range(episodes):
        obs, _ = test.reset(seed=EVAL_SEED + k)
        state, start, total, done = None, np.ones((1,), dtype=bool), 0.0, False
        while not done:
            action, state = model.predict(obs, state=state, episode_start=start, deterministic=True)
            obs, reward, terminated, truncated, _ = test.step(int(action))
            start = np.zeros((1,), dtype=bool)
            total, done = total + float(reward), terminated or truncated
        values.append(total)
    v = np.asarray(values)
    return {
        "task": name,
        "method": "recurrent-ppo",
        "value": float(v.mean()),
        "std_error": float(v.std(ddof=1) / np.sqrt(len(v))),
        "seconds": seconds,
        "steps": int(model.num_timesteps),
    }


def _rival_env(made: Any) -> Any:
    """A Gymnasium environment with one-hot observations: a POPGym id, or a batched world of
    :mod:`cehmm.memory_tasks` stepped one episode at a time (the sum of its rewards is its value)."""
    import gymnasium

    if isinstance(made, str):
        env = gymnasium.make(made)
        n = int(env.observation_space.n)
    else:
        env, n = _one_episode(made), made.n_observations
    eye = np.eye(n, dtype=np.float32)
    return gymnasium.wrappers.TransformObservation(
        env, lambda y: eye[int(y)], gymnasium.spaces.Box(0.0, 1.0, (n,), dtype=np.float32)
    )


def _one_episode(world: Any) -> Any:
    """A batched world as a Gymnasium environment of one episode at a time."""
    import gymnasium

    class OneEpisode(gymnasium.Env):  # type: ignore[misc]
        def __init__(self) -> None:
            self.observation_space = gymnasium.spaces.Discrete(world.n_observations)
            self.action_space = gymnasium.spaces.Discrete(world.n_decisions)
            self._seed = 0

        def reset(self, *, seed: int | None = None, options: Any = None) -> tuple[int, dict[str, Any]]:
            self._seed = self._seed + 1 if seed is None else seed
            self._t = 0
            return int(np.asarray(world.reset(1, self._seed))[0]), {}

        def step(self, action: int) -> tuple[int, float, bool, bool, dict[str, Any]]:
            self._t += 1
            ys, rewards, dones = world.step(np.asarray([action], dtype=np.int64))
            done = bool(dones[0])
            return int(ys[0]), float(rewards[0]), done, not done and self._t >= world.horizon, {}

    return OneEpisode()


def render(records: list[dict[str, Any]], header: dict[str, Any] | None) -> str:
    """The report: one row per task, one column per method, each cell value ± s.e. and seconds."""
    cells = {(r["task"], r["method"]): r for r in records if "task" in r}
    methods = [m for m in METHODS if any(k[1] == m for k in cells)]
    lines = [
        "# Memory benchmark",
        "",
        f"Generated by `{PROG}` from `docs/data/memory.jsonl`; do not edit by hand.",
        "",
    ]
    if header:
        lines += [
            f"Each method learns for at most **{header['budget']:g} s** of wall time (the controller search and "
            f"episode CE may stop earlier on their own rules), seed {header['seed']}; every policy is then "
            f"evaluated on the same {header['episodes']} fresh episodes. Machine: {header['machine']}; "
            f"commit {header['commit']}, {header['date']}.",
            "",
        ]
    lines += [
        "Each cell: mean value ± standard error (training seconds). For `.pomdp` files the controller's exact "
        "value follows in brackets. Methods: " + "; ".join(_METHOD_TEXT[m] for m in methods) + ".",
        "",
        "| task | optimum | " + " | ".join(methods) + " |",
        "|---|---:|" + "---:|" * len(methods),
    ]
    for name, task in TASKS.items():
        if not any((name, m) in cells for m in methods):
            continue
        row = [name, "" if task.optimum is None else f"{task.optimum:g}"]
        for m in methods:
            r = cells.get((name, m))
            if r is None:
                row.append("—")
                continue
            text = f"{r['value']:.3f} ± {r['std_error']:.3f} ({r['seconds']:.0f} s)"
            if "exact" in r:
                text += f" [{r['exact']:.3f}]"
            row.append(text)
        lines.append("| " + " | ".join(row) + " |")
    lines += ["", "Sources of the optima: " + "; ".join(f"{n}: {t.source}" for n, t in TASKS.items()) + ".", ""]
    return "\n".join(lines)


_METHOD_TEXT = {
    "random": "`random` the uniform policy",
    "memoryless": "`memoryless` episode CE with levels [8]",
    "episode-ce": "`episode-ce` episode CE with levels [8, 8]",
    "controller": "`controller` the controller search on sampled values, 8 nodes, defaults",
    "controller-exact": "`controller-exact` the same on exact values",
    "recurrent-ppo": "`recurrent-ppo` sb3-contrib's RecurrentPPO (MlpLstmPolicy, n_steps 512, CPU)",
}


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0] if __doc__ else None)
    p.add_argument("--tasks", nargs="+", choices=list(TASKS), help="tasks (default: every available one)")
    p.add_argument("--methods", nargs="+", choices=METHODS, help="methods (default: all that are installed)")
    p.add_argument("--budget", type=float, default=60.0, help="wall-clock seconds of learning per cell")
    p.add_argument("--episodes", type=int, default=1000, help="evaluation episodes per cell")
    p.add_argument("--seed", type=int, default=0, help="seed of every learner")
    p.add_argument("--quick", action="store_true", help=f"tasks {', '.join(QUICK_TASKS)}, 5 s per cell")
    p.add_argument("--out", type=Path, default=Path("docs"), help="where data/memory.jsonl and the report go")
    p.add_argument("--report-only", action="store_true", help="run nothing: rebuild the report from the data")
    args = p.parse_args(argv)
    if args.budget <= 0 or args.episodes < 2:
        p.error("--budget must be positive and --episodes at least 2")
    budget = 5.0 if args.quick else args.budget
    names = args.tasks or (list(QUICK_TASKS) if args.quick else [n for n, t in TASKS.items() if _available(t)])
    data = args.out / "data" / "memory.jsonl"
    records = read_records(data) if data.exists() else []
    header = next((r for r in records if r.get("kind") == "header"), None)
    if not args.report_only:
        if header is None or (header["budget"], header["episodes"], header["seed"]) != (
            budget,
            args.episodes,
            args.seed,
        ):
            # Other settings: the cells are those of another benchmark; start the data afresh.
            records = []
            data.parent.mkdir(parents=True, exist_ok=True)
            data.write_text("")
            header = {
                "kind": "header",
                "budget": budget,
                "episodes": args.episodes,
                "seed": args.seed,
                "machine": _machine_text(),
                "commit": source_commit(),
                "date": _dt.date.today().isoformat(),
            }
            append_record(data, header)
        done = {(r["task"], r["method"]) for r in records if "task" in r}
        for name in names:
            for method in args.methods or METHODS:
                if (name, method) in done:
                    continue
                record = run_cell(name, method, budget, args.episodes, args.seed)
                if record is None:
                    continue
                print(
                    f"{name:28} {method:16} {record['value']:9.3f} ± {record['std_error']:.3f}  "
                    f"{record['seconds']:6.1f} s",
                    flush=True,
                )
                append_record(data, record)
                records.append(record)
    write_text(args.out / "memory-benchmark.md", render(records, header))
    return 0


def _machine_text() -> str:
    m = machine_info()
    return f"{m['cores']} cores, {m['cpu']}"


if __name__ == "__main__":
    sys.exit(main())
