"""Worlds written in Python (cehmm.outside): both protocols optimised, evaluated and rolled out;
a non-additive score; the Python target-tracking worlds agree with the engine's; bad values,
exceptions (Ctrl-C: test_signals.py)."""

from __future__ import annotations

import math
import traceback

import numpy as np
import pytest
from worlds import Corridor

import cehmm
from cehmm.pyworlds import TrackingBatch, TrackingEpisodes


def reached_once(observations: np.ndarray, decisions: np.ndarray, rewards: np.ndarray) -> float:
    """Non-additive: 1 if the goal was reached at least once (staying there earns nothing more)."""
    assert len(observations) == len(decisions) == len(rewards)
    return float(rewards.max() > 0)


class Counter:
    """Batched: the observation is the step (mod 4); decision 1 wins a point; the episode ends
    after 3 points (early), or at the horizon."""

    batched = True
    n_observations, n_decisions, horizon = 4, 2, 12
    max_batch = 64

    def reset(self, n: int, seed: int) -> np.ndarray:
        self.t = 0
        self.points = np.zeros(n, dtype=np.int64)
        return np.zeros(n, dtype=np.int64)

    def step(self, decisions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        self.t += 1
        reward = (decisions == 1).astype(np.float64)
        self.points += decisions == 1
        return np.full(len(decisions), self.t % 4), reward, self.points >= 3


def test_a_python_world_with_a_non_additive_score_beats_a_random_policy_by_a_margin() -> None:
    world = cehmm.PythonWorld(Corridor(), score=reached_once)
    random_policy = cehmm.Policy.uniform(world, [1])
    baseline = random_policy.evaluate(world, episodes=4000).mean
    result = cehmm.optimize(
        world, levels=[2], samples=300, rho=0.1, smoothing=0.5, max_iterations=15, progress=False, eval_episodes=4000
    )
    # Always right reaches the goal within 10 steps with probability ≈ 0.93 (8 of 10 moves right
    # despite the wind); a random walk rarely does (≈ 0.17).
    assert baseline < 0.25
    assert result.evaluation.mean > baseline + 0.6, (baseline, result.evaluation)
    assert result.policy.world == {
        "name": "outside",
        "class": "worlds.Corridor",
        "observations": 6,
        "decisions": 2,
        "horizon": 10,
    }


def test_the_python_tracking_worlds_give_the_engines_mean_reward(case3: cehmm.TargetTracking) -> None:
    policy = cehmm.optimize(case3, levels=[16, 16], samples=300, max_iterations=6, seed=3, progress=False).policy
    rust = policy.evaluate(case3, episodes=4000, seed=1)
    for world, episodes in ((TrackingBatch(case=3), 4000), (TrackingEpisodes(case=3), 600)):
        python = policy.evaluate(world, episodes=episodes, seed=2)
        z = (python.mean - rust.mean) / math.hypot(python.std_error, rust.std_error)
        assert abs(z) < 4, (type(world).__name__, python, rust)


def test_runs_on_python_worlds_are_reproducible_whatever_the_threads() -> None:
    runs = [
        cehmm.optimize(Counter(), levels=[2, 2], samples=200, max_iterations=4, threads=t, progress=False, seed=5)
        for t in (1, 2, 2)
    ]
    for run in runs[1:]:
        assert np.array_equal(run.history["mean"], runs[0].history["mean"])
        assert run.policy.to_json() == runs[0].policy.to_json()


def test_episodes_end_early_and_rollouts_record_them() -> None:
    world = cehmm.PythonWorld(Counter())
    always = cehmm.Policy.from_tables(
        {"h0": np.array([[0.0, 1.0]]), "h1": np.ones((4, 1, 1)), "upper": []}, world=world
    )
    rollout = always.rollout(world, seed=0, episode=3)
    assert (len(rollout), rollout.reward) == (3, 3.0)
    assert list(rollout.d) == [1, 1, 1] and list(rollout.y) == [0, 1, 2]
    assert always.evaluate(world, episodes=100).mean == 3.0
    assert cehmm.PythonWorld(Counter(), discount=0.5).batch == 64
    assert always.evaluate(cehmm.PythonWorld(Counter(), discount=0.5), episodes=10).mean == 1.75


def test_policies_of_python_worlds_keep_the_world_they_were_made_for(tmp_path) -> None:
    result = cehmm.optimize(Counter(), levels=[2], samples=100, max_iterations=2, progress=False)
    path = tmp_path / "policy.json"
    result.policy.save(path)
    loaded = cehmm.Policy.load(path)
    assert loaded.world["class"] == "test_outside.Counter" and loaded.world["name"] == "outside"
    with pytest.raises(cehmm.InvalidArgumentError, match="outside the engine.*pass the world itself"):
        loaded.evaluate(episodes=10)
    assert loaded.evaluate(Counter(), episodes=200).mean == result.policy.evaluate(Counter(), episodes=200).mean


class Faulty:
    n_observations, n_decisions, horizon = 3, 2, 5

    def __init__(self, fault: str) -> None:
        self.fault = fault

    def reset(self, seed: int) -> object:
        self.t = 0
        return "a" if self.fault == "type" else 0

    def step(self, decision: int) -> tuple[object, float, bool]:
        self.t += 1
        if self.t == 3 and self.fault == "range":
            return 3, 0.0, False
        if self.t == 3 and self.fault == "nan":
            return 0, math.nan, False
        if self.t == 4 and self.fault == "raise":
            raise ZeroDivisionError("the world broke")
        return 0, 1.0, False


@pytest.mark.parametrize(
    ("fault", "message"),
    [
        # The third call of step returned the bad observation: "step 3", as for a bad reward.
        ("range", r"episode 0 \(iteration 0\), step 3: observation 3 \(expected 0\.\.3\)"),
        ("nan", r"episode 0 \(iteration 0\), step 3: reward NaN"),
        ("type", r"episode 0 \(iteration 0\), reset: reset returned observation 'a' \(expected an int\)"),
    ],
)
def test_bad_values_are_named_by_world_episode_and_step(fault: str, message: str) -> None:
    with pytest.raises(cehmm.WorldError, match=r"^world test_outside\.Faulty, " + message):
        cehmm.optimize(Faulty(fault), levels=[2], samples=20, max_iterations=1, progress=False)


def test_an_exception_inside_a_python_world_propagates_with_its_traceback() -> None:
    with pytest.raises(ZeroDivisionError, match="the world broke") as raised:
        cehmm.Policy.uniform(cehmm.PythonWorld(Faulty("raise")), [2]).evaluate(Faulty("raise"), episodes=10)
    frames = [frame.name for frame in traceback.extract_tb(raised.value.__traceback__)]
    assert "step" in frames
    assert any("episode 0 (evaluate), step 4: raised" in note for note in getattr(raised.value, "__notes__", []))


def test_worlds_that_are_not_worlds_are_refused() -> None:
    with pytest.raises(TypeError, match="expected a cehmm world, an object with reset"):
        cehmm.optimize(object(), progress=False)

    class NoHorizon:
        n_observations, n_decisions = 2, 2

        def reset(self, seed: int) -> int:
            return 0

        def step(self, decision: int) -> tuple[int, float, bool]:
            return 0, 0.0, False

    with pytest.raises(TypeError, match=r"NoHorizon has no attribute 'horizon' \(pass horizon=...\)"):
        cehmm.PythonWorld(NoHorizon())
    assert cehmm.PythonWorld(NoHorizon(), horizon=4).horizon == 4
    with pytest.raises(cehmm.InvalidArgumentError, match=r"discount: 1.5 \(expected 0 <= discount <= 1\)"):
        cehmm.PythonWorld(Corridor(), discount=1.5)
    # As in .pomdp files: a discount of 0 counts the first reward only.
    assert (
        cehmm.Policy.uniform(Corridor(), [1]).evaluate(cehmm.PythonWorld(Corridor(), discount=0), episodes=20).max <= 1
    )
    with pytest.raises(cehmm.InvalidArgumentError, match="tiny observations: 0 "):
        cehmm.PythonWorld(type("Empty", (NoHorizon,), {"n_observations": 0})(), horizon=4, name="tiny")
    with pytest.raises(TypeError, match="apply to worlds written in Python"):
        cehmm.optimize(cehmm.TargetTracking(case=1), score=reached_once, progress=False)


class Short(Counter):
    """Returns one observation too few, or floats, from a batched step."""

    def __init__(self, fault: str) -> None:
        self.fault = fault

    def step(self, decisions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        observations, rewards, done = super().step(decisions)
        if self.fault == "short":
            return observations[1:], rewards, done
        return observations + 0.5, rewards, done


@pytest.mark.parametrize(
    ("fault", "message"),
    [
        ("short", r"episodes 0\.\.20 \(evaluate\), step 1: step returned observation: 19 values \(expected 20, "),
        ("float", r"episodes 0\.\.20 \(evaluate\), step 1: step returned observation array\(\[1\.5.*expected ints"),
    ],
)
def test_a_batched_world_returning_the_wrong_shape_or_type_is_named(fault: str, message: str) -> None:
    policy = cehmm.Policy.uniform(cehmm.PythonWorld(Counter()), [2])
    with pytest.raises(cehmm.WorldError, match=r"^world test_outside\.Short, " + message):
        policy.evaluate(Short(fault), episodes=20)


def test_episodes_worth_1e308_keep_a_finite_mean_and_their_checkpoint(tmp_path) -> None:
    # The plain sum of the episodes' values overflowed: mean inf, and the checkpoint refused it.
    huge = dict(score=lambda o, d, r: 1e308 * (1.0 - 0.5 * (d[0] == 0)), horizon=3)
    path = tmp_path / "run.ckpt"
    result = cehmm.optimize(
        Corridor(), levels=[2], samples=50, max_iterations=3, eval_episodes=50, progress=False, checkpoint=path, **huge
    )
    assert np.all(np.isfinite(result.history["mean"])) and np.all(result.history["mean"] >= 0.5e308)
    assert math.isfinite(result.evaluation.mean) and math.isfinite(result.evaluation.std)
    assert path.exists()
    controller = cehmm.optimize_controller(
        Corridor(),
        nodes=2,
        samples=20,
        episodes=5,
        select_episodes=10,
        eval_episodes=20,
        max_iterations=2,
        progress=False,
        **huge,
        search="ce",
    )
    assert math.isfinite(controller.value) and np.all(np.isfinite(controller.history["mean"]))


class FlagWorld:
    """Corridor's shape; `step` returns `flag` as its done (episode protocol)."""

    n_observations, n_decisions, horizon = 6, 2, 4

    def __init__(self, flag: object) -> None:
        self.flag = flag

    def reset(self, seed: int) -> int:
        return 0

    def step(self, decision: int) -> tuple[int, float, object]:
        return 0, 0.0, self.flag


class FlagBatch:
    """The same, batched: `flags(n)` is the done column."""

    batched = True
    n_observations, n_decisions, horizon = 6, 2, 4

    def __init__(self, flags: object) -> None:
        self.flags = flags

    def reset(self, n: int, seed: int) -> np.ndarray:
        self.n = n
        return np.zeros(n, dtype=np.int64)

    def step(self, decisions: np.ndarray) -> tuple[np.ndarray, np.ndarray, object]:
        return np.zeros(self.n, dtype=np.int64), np.zeros(self.n), self.flags(self.n)  # type: ignore[operator]


def test_done_flags_are_bools_not_truthiness() -> None:
    policy = cehmm.Policy.uniform(FlagWorld(False), [1])
    for good in [False, np.bool_(True), 0, 1]:
        policy.evaluate(FlagWorld(good), episodes=3, seed=0)
    for bad in ["False", float("nan"), 0.5, 2, (x for x in []), None]:
        with pytest.raises(cehmm.WorldError, match="done"):
            policy.evaluate(FlagWorld(bad), episodes=3, seed=0)
    for good in [lambda n: np.zeros(n, dtype=bool), lambda n: np.ones(n, dtype=np.int64)]:
        policy.evaluate(FlagBatch(good), episodes=3, seed=0)
    for bad in [lambda n: np.full(n, 0.5), lambda n: np.full(n, 2), lambda n: np.array(["False"] * n)]:
        with pytest.raises(cehmm.WorldError, match="done"):
            policy.evaluate(FlagBatch(bad), episodes=3, seed=0)


DEEP_WORLD = """
import sys, cehmm
sys.setrecursionlimit(100000)

def deep(n):  # each level goes through C (sum, map): it takes the thread's own stack
    return 0 if n == 0 else sum(map(deep, [n - 1]))

class Deep:
    n_observations, n_decisions, horizon = 2, 2, 3
    def reset(self, seed):
        return 0
    def step(self, decision):
        return deep(6000), 1.0, False

print(cehmm.Policy.uniform(Deep(), [1]).evaluate(Deep(), episodes=4, seed=0).mean)
"""


def test_a_world_that_recurses_deeply_runs_on_the_engine_threads() -> None:
    # It segfaulted on a worker's 2 MiB stack where a threading.Thread runs it fine.
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-c", DEEP_WORLD], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == "3.0"


class Values:
    """Returns the given observation and reward from every step (episode protocol)."""

    n_observations, n_decisions, horizon = 3, 2, 4

    def __init__(self, observation: object = 1, reward: object = 0.0) -> None:
        self.observation, self.reward = observation, reward

    def reset(self, seed: int) -> int:
        return 0

    def step(self, decision: int) -> tuple[object, object, bool]:
        return self.observation, self.reward, False


class BatchValues:
    """Returns `observations(n)` and `rewards(n)` from every step (batched protocol)."""

    batched = True
    n_observations, n_decisions, horizon = 3, 2, 4
    max_batch = 8

    def __init__(self, observations: object = None, rewards: object = None) -> None:
        self.observations = observations or (lambda n: np.ones(n, dtype=np.int64))
        self.rewards = rewards or (lambda n: np.zeros(n))

    def reset(self, n: int, seed: int) -> np.ndarray:
        self.n = n
        return np.zeros(n, dtype=np.int64)

    def step(self, decisions: np.ndarray) -> tuple[object, object, np.ndarray]:
        return self.observations(self.n), self.rewards(self.n), np.zeros(self.n, dtype=bool)  # type: ignore[operator]


def test_both_protocols_take_and_refuse_the_same_values() -> None:
    # One rule for both: observations are ints (not bools, floats or strings), rewards real
    # numbers (bools count as 0 and 1; a complex is refused, even with no imaginary part).
    policy = cehmm.Policy.uniform(Values(), [1])
    evaluate = lambda world: policy.evaluate(world, episodes=8, seed=0)  # noqa: E731
    for reward in [1, 1.5, np.float32(2), np.int8(3), True]:
        assert evaluate(Values(reward=reward)).mean == 4 * float(reward)
        assert evaluate(BatchValues(rewards=lambda n, r=reward: np.full(n, r))).mean == 4 * float(reward)
    for reward in [1 + 0j, np.complex128(1), "1"]:
        with pytest.raises(cehmm.WorldError, match="reward"):
            evaluate(Values(reward=reward))
        with pytest.raises(cehmm.WorldError, match="reward"):
            evaluate(BatchValues(rewards=lambda n, r=reward: np.full(n, r)))
    for observation in [True, np.bool_(True), 1.0, "1"]:
        with pytest.raises(cehmm.WorldError, match="observation"):
            evaluate(Values(observation=observation))
        with pytest.raises(cehmm.WorldError, match="observation"):
            evaluate(BatchValues(observations=lambda n, o=observation: np.full(n, o)))


def test_a_batch_may_be_a_column_of_a_larger_array() -> None:
    # Valid values whatever their strides: a column of a 2-D array is not contiguous.
    policy = cehmm.Policy.random(BatchValues(), [2], seed=1)
    columns = BatchValues(
        observations=lambda n: np.tile(np.arange(n) % 3, (2, 1)).T[:, 1],
        rewards=lambda n: np.tile(np.arange(n, dtype=float), (3, 1)).T[:, 2],
    )
    contiguous = BatchValues(observations=lambda n: np.arange(n) % 3, rewards=lambda n: np.arange(n, dtype=float))
    assert policy.evaluate(columns, episodes=20, seed=3) == policy.evaluate(contiguous, episodes=20, seed=3)
