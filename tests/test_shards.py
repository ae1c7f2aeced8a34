"""What a worker elsewhere runs (issue 21's spine): a shard of an iteration's or an evaluation's
episodes gives their very rewards, and the elite's counts come from the episodes' numbers alone
(re-run from their streams), whatever the split."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from worlds import Corridor

import cehmm
from cehmm.outside import PythonWorld


@pytest.fixture(params=["engine", "python"])
def world_and_policy(request):
    if request.param == "engine":
        world = cehmm.TargetTracking(case=3)
        core = world._core
    else:
        world = Corridor()
        core = PythonWorld(world)._core
    return core, cehmm.Policy.random(world, [3, 2], seed=5)._core, world


def test_shards_of_an_evaluation_are_its_episodes(world_and_policy) -> None:
    core, policy, world = world_and_policy
    # A shard's answer ends with the world's steps its episodes took.
    whole, steps = np.split(policy.shard_rewards(core, 9, "evaluate", 0, 0, 300), [300])
    shards = [policy.shard_rewards(core, 9, "evaluate", 0, a, b - a) for a, b in [(0, 7), (7, 200), (200, 300)]]
    assert np.array_equal(whole, np.concatenate([s[:-1] for s in shards]))
    assert steps[0] == sum(s[-1] for s in shards) > 0
    e = cehmm.Policy(policy).evaluate(world, episodes=300, seed=9)
    assert (e.min, e.max, e.quantiles[0.5]) == (whole.min(), whole.max(), np.sort(whole)[149])
    assert e.mean == pytest.approx(whole.mean(), rel=1e-12)


def test_each_purpose_and_iteration_has_its_own_episodes() -> None:
    world = cehmm.TargetTracking(case=3)
    policy = cehmm.Policy.random(world, [3, 2], seed=5)._core
    runs = [
        policy.shard_rewards(world._core, 9, p, i, 0, 300)[:-1]
        for p, i in [("evaluate", 0), ("optimise", 0), ("optimise", 1)]
    ]
    assert all(r.std() > 0 for r in runs)
    assert not np.array_equal(runs[0], runs[1]) and not np.array_equal(runs[1], runs[2])


def test_the_elites_counts_do_not_depend_on_the_split(world_and_policy) -> None:
    core, policy, _ = world_and_policy
    elite = [5, 99, 0, 42, 17, 250, 3]
    whole = policy.rerun_counts(core, 1, 4, elite)
    assert whole.dtype == np.uint32 and whole.sum() > 0
    parts = policy.rerun_counts(core, 1, 4, elite[:2]) + policy.rerun_counts(core, 1, 4, elite[2:])
    assert np.array_equal(whole, parts)
    assert not np.array_equal(policy.rerun_counts(core, 1, 5, elite), whole)


def test_a_shard_names_a_bad_purpose() -> None:
    world = cehmm.TargetTracking(case=1)
    policy = cehmm.Policy.uniform(world, [2])._core
    with pytest.raises(
        cehmm.InvalidArgumentError, match=r"invalid purpose: \"train\" \(expected one of \[\"optimise\""
    ):
        policy.shard_rewards(world._core, 0, "train", 0, 0, 10)
    with pytest.raises(cehmm.InvalidArgumentError, match="episodes"):
        policy.shard_rewards(world._core, 0, "evaluate", 0, 0, 0)


def test_exact_values_of_a_shard_of_controllers() -> None:
    tiger = cehmm.PomdpWorld(Path(__file__).parents[1] / "data" / "pomdp" / "tiger.95.POMDP")
    # Listening forever (decision 0) is worth -1/(1 - γ); opening the left door first (decision
    # 1: -100 or +10, even odds), then listening forever, -45 + γ of that. A controller starts
    # at the node its entry `next[Y]` (of node 0) names.
    listen = {"act": [0], "next": [0, 0, 0]}
    opens = {"act": [1, 0], "next": [1, 1, 0, 1, 1, 1]}
    values = cehmm._core.controller_exact_values(tiger._core, json.dumps([listen, opens, listen]), 1e-9)
    assert values[0] == values[2] and values[0] == pytest.approx(-1 / (1 - 0.95), abs=1e-6)
    assert values[1] == pytest.approx((0.5 * -100 + 0.5 * 10) + 0.95 * values[0], abs=1e-6)
    with pytest.raises(cehmm.InvalidArgumentError, match="world: not tabular"):
        cehmm._core.controller_exact_values(cehmm.TargetTracking(case=1)._core, "[]", 1e-6)
    with pytest.raises(cehmm.InvalidArgumentError, match="tolerance: 0"):
        cehmm._core.controller_exact_values(tiger._core, "[]", 0.0)
    with pytest.raises(cehmm.InvalidArgumentError, match=r"controller: decision 5 \(expected below 3\)"):
        cehmm._core.controller_exact_values(tiger._core, json.dumps([{"act": [5], "next": [0, 0, 0]}]), 1e-6)
    with pytest.raises(cehmm.InvalidArgumentError, match="controllers: .*expected a JSON list of controllers"):
        cehmm._core.controller_exact_values(tiger._core, "{}", 1e-6)
