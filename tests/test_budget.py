"""The budget in the world's steps (issue 46): ``max_env_steps=`` on every optimiser that samples
a world, counted by the engine (worlds in Python and Gymnasium's included), the final
evaluation's steps apart, the same for any thread count, resumed bit for bit, refused on exact
values."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from worlds import Corridor

import cehmm

TIGER = Path(__file__).resolve().parents[1] / "data" / "pomdp" / "tiger.95.POMDP"


class Counted(Corridor):
    """The corridor, ended where it reaches cell 5, counting every step it is asked for."""

    steps = 0

    def step(self, decision: int) -> tuple[int, float, bool]:
        Counted.steps += 1
        cell, reward, _ = super().step(decision)
        return cell, reward, cell == 5


class CountedEnv(gym.Wrapper):
    """A Gymnasium environment counting the steps it is asked for."""

    steps = 0

    def step(self, action: Any) -> Any:
        CountedEnv.steps += 1
        return super().step(action)


def test_every_step_a_python_world_takes_is_counted_and_the_evaluation_apart() -> None:
    Counted.steps = 0
    r = cehmm.optimize(
        Counted(), levels=[2, 2], samples=300, rho=0.2, max_env_steps=2000, eval_episodes=100, progress=False
    )
    assert r.stop_reason == "max_env_steps"
    assert r.env_steps + r.eval_env_steps == Counted.steps
    assert r.env_steps >= 2000 and r.env_steps == r.history["env_steps"][-1]
    assert np.all(np.diff(r.history["env_steps"]) > 0)
    # The iteration that reaches the budget is cut after a batch of 256 episodes: its count
    # passes the budget by at most that batch (episodes of at most 10 steps).
    assert r.env_steps - 2000 < 256 * 10


def test_a_gymnasium_environment_s_steps_are_counted() -> None:
    # Finite observations: no warm-up fits an encoding (``cehmm.spaces.Bins`` takes its 2000
    # observations before learning starts: they are not learning's steps).
    CountedEnv.steps = 0
    env = CountedEnv(gym.make("FrozenLake-v1", max_episode_steps=30))
    r = cehmm.optimize_controller(
        env,
        nodes=2,
        samples=20,
        episodes=5,
        select_episodes=10,
        eval_episodes=20,
        max_env_steps=3000,
        progress=False,
        search="ce",
    )
    # It stops where the steps left no longer cover a selection (4 candidates of 10 episodes,
    # as their mean length foresees them), and passes the budget by one controller's episodes
    # (5 of at most 30 steps) at most.
    assert r.stop_reason == "max_env_steps"
    assert 3000 - 4 * 10 * 30 <= r.env_steps <= 3000 + 5 * 30, r.env_steps
    assert r.env_steps + r.eval_env_steps == CountedEnv.steps
    assert r.history["env_steps"][-1] == r.env_steps


@pytest.mark.parametrize("threads", [1, 2])
def test_the_count_and_the_result_do_not_depend_on_the_thread_count(threads: int) -> None:
    world = cehmm.TargetTracking(case=1)
    settings = dict(levels=[3], samples=300, max_env_steps=100_000, eval_episodes=200, progress=False)
    one = cehmm.optimize(world, threads=1, **settings)
    other = cehmm.optimize(world, threads=threads, **settings)
    assert one.policy.to_json() == other.policy.to_json()
    assert one.env_steps == other.env_steps and list(one.history["env_steps"]) == list(other.history["env_steps"])
    searched = dict(nodes=2, samples=30, episodes=10, max_env_steps=50_000, eval_episodes=100, progress=False)
    a = cehmm.optimize_controller(world, threads=1, **searched, search="ce")
    b = cehmm.optimize_controller(world, threads=threads, **searched, search="ce")
    assert (a.policy.to_json(), a.env_steps) == (b.policy.to_json(), b.env_steps)
    assert a.stop_reason == "max_env_steps"


def test_a_stepped_optimiser_takes_the_budget_too() -> None:
    r = cehmm.run("random-search", Corridor(), samples=30, episodes=10, max_env_steps=5000, progress=False)
    assert r.stop_reason == "max_env_steps" and 5000 <= r.env_steps
    assert r.eval_env_steps == 10_000 * 10


def test_a_run_under_a_budget_resumes_bit_for_bit(tmp_path: Path) -> None:
    world = cehmm.TargetTracking(case=1)
    settings = dict(levels=[3], samples=300, rho=0.1, max_env_steps=200_000, eval_episodes=200, progress=False)
    whole = cehmm.optimize(world, **settings)
    checkpoint = tmp_path / "run.json"
    cut = cehmm.optimize(world, checkpoint=checkpoint, callback=lambda it: it["iteration"] < 2, **settings)
    assert cut.stop_reason == "callback"
    resumed = cehmm.optimize(world, checkpoint=checkpoint, resume=True, **settings)
    assert resumed.policy.to_json() == whole.policy.to_json()
    assert resumed.env_steps == whole.env_steps and resumed.stop_reason == whole.stop_reason == "max_env_steps"
    assert list(resumed.history["env_steps"]) == list(whole.history["env_steps"])
    # The budget may change between sessions, as the time limit may.
    more = cehmm.optimize(world, checkpoint=checkpoint, resume=True, **{**settings, "max_env_steps": 300_000})
    assert more.env_steps >= 300_000 and more.history["env_steps"][len(whole.history["env_steps"]) - 1] > 0


def test_a_budget_out_of_its_domain_or_on_exact_values_is_refused_by_name() -> None:
    tiger = cehmm.PomdpWorld(TIGER)
    with pytest.raises(cehmm.InvalidArgumentError, match=r"max_env_steps.*exact values"):
        cehmm.optimize_controller(tiger, nodes=2, max_env_steps=1000, progress=False)
    with pytest.raises(cehmm.InvalidArgumentError, match=r"max_env_steps: 0 \(expected at least 1"):
        cehmm.optimize(cehmm.TargetTracking(case=1), max_env_steps=0, progress=False)
    with pytest.raises(cehmm.InvalidArgumentError, match="max_env_steps"):
        cehmm.optimize(cehmm.TargetTracking(case=1), max_env_steps=-5, progress=False)


def test_the_policy_file_records_the_steps(tmp_path: Path) -> None:
    r = cehmm.optimize(cehmm.TargetTracking(case=1), levels=[3], samples=200, max_iterations=2, progress=False)
    assert r.policy.provenance["env_steps"] == r.env_steps == 2 * 200 * 100
    assert r.eval_env_steps == 10_000 * 100


def test_runs_are_drawn_against_the_world_s_steps() -> None:
    plots = pytest.importorskip("cehmm.plots")
    r = cehmm.optimize(cehmm.TargetTracking(case=1), levels=[3], samples=200, max_iterations=3, progress=False)
    rival = {"mean": [1.0, 2.0], "env_steps": [30_000, 60_000]}
    ax = plots.learning_curve(r, rival, x="env_steps").axes[0]
    assert ax.get_xlabel() == "steps of the world"
    assert list(ax.get_lines()[0].get_xdata()) == [20_000, 40_000, 60_000]
    with pytest.raises(cehmm.InvalidArgumentError, match="'env_steps'"):
        plots.learning_curve(r, x="steps")


def test_the_command_line_takes_the_budget(tmp_path: Path) -> None:
    import subprocess
    import sys

    args = ["optimize", "--case", "1", "--levels", "4", "--samples", "200", "--max-env-steps", "50000", "--quiet"]
    done = subprocess.run(
        [sys.executable, "-m", "cehmm.cli", *args, "--out", "p.json"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    # Two iterations of 20,000 steps, then the 100 episodes the 10,000 steps left cover.
    assert done.stdout.startswith("max_env_steps: 3 iterations (50000 steps of the world)"), done.stdout
    provenance = cehmm.Policy.load(tmp_path / "p.json").provenance
    assert (provenance["max_env_steps"], provenance["env_steps"]) == (50000, 50000)


def test_a_popgym_environment_s_steps_are_counted() -> None:
    # A third-party environment keeps its state its own way: every step it is asked for is
    # learning's or the final evaluation's, nothing else.
    pytest.importorskip("popgym")
    CountedEnv.steps = 0
    env = CountedEnv(gym.make("popgym-RepeatPreviousEasy-v0"))
    settings = dict(nodes=4, samples=50, episodes=5, select_episodes=20, eval_episodes=50, progress=False)
    r = cehmm.optimize_controller(env, horizon=110, max_env_steps=50_000, **settings)
    # Within a selection's steps (4 candidates of 20 episodes) below the budget, and one
    # controller's episodes above it.
    assert r.stop_reason == "max_env_steps"
    assert 50_000 - 4 * 20 * 110 <= r.env_steps <= 50_000 + 5 * 110, r.env_steps
    assert r.env_steps + r.eval_env_steps == CountedEnv.steps
