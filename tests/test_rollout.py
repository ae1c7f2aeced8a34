"""Rollouts: one recorded episode, checked against the world's rules (model §4)."""

from __future__ import annotations

import numpy as np
import pytest

import cehmm

LABELS = ["b_i", "b_j", "b_heading", "c_i", "c_j", "c_heading", "target_i", "target_j"]
STEP = {0: (0, -1), 1: (1, 0), 2: (0, 1), 3: (-1, 0)}  # heading -> (di, dj)


def chebyshev(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.max(np.abs(a - b), axis=-1)


def move(i: int, j: int, heading: int, action: int) -> tuple[int, int, int]:
    """model §4: 0 turn left, 1 turn right, 2 forward (stay if off the grid), 3 no move."""
    if action == 0:
        return i, j, (heading - 1) % 4
    if action == 1:
        return i, j, (heading + 1) % 4
    if action == 2:
        di, dj = STEP[heading]
        if 0 <= i + di < 20 and 0 <= j + dj < 20:
            return i + di, j + dj, heading
    return i, j, heading


def observe(i: int, j: int, heading: int, ti: int, tj: int) -> int:
    ahead = {0: tj < j, 1: ti > i, 2: tj > j, 3: ti < i}[heading]
    return int(ahead) | (int(max(abs(ti - i), abs(tj - j)) < 3) << 1)


@pytest.fixture(scope="module")
def policy(case3: cehmm.TargetTracking) -> cehmm.Policy:
    return cehmm.Policy.random(case3, [8, 3], seed=5)


def test_shapes_and_types(policy: cehmm.Policy, case3: cehmm.TargetTracking) -> None:
    r = policy.rollout(case3, seed=1)
    assert isinstance(r, cehmm.Rollout) and len(r) == 100
    assert r.x.shape == (100, 8) and r.y.shape == (100,) and r.d.shape == (100,) and r.memory.shape == (100, 2)
    assert r.x.dtype == r.y.dtype == r.d.dtype == r.memory.dtype == np.int64
    assert r.x_labels == LABELS == case3.state_labels
    assert isinstance(r.reward, float)
    assert np.all((0 <= r.y) & (r.y < 16)) and np.all((0 <= r.d) & (r.d < 16))
    assert np.all(r.memory[:, 0] < 8) and np.all(r.memory[:, 1] < 3)
    assert np.array_equal(r.column("target_i"), r.x[:, 6])


def test_reward_counts_steps_near_the_target(policy: cehmm.Policy, case3: cehmm.TargetTracking) -> None:
    rewards = []
    for seed in range(12):
        r = policy.rollout(case3, seed=seed)
        b, c, target = r.x[:, 0:2], r.x[:, 3:5], r.x[:, 6:8]
        near = (chebyshev(b, target) <= 3) | (chebyshev(c, target) <= 3)
        assert r.reward == near.sum()
        rewards.append(r.reward)
    assert max(rewards) > 0


def test_states_follow_decisions_and_observations(policy: cehmm.Policy, case3: cehmm.TargetTracking) -> None:
    r = policy.rollout(case3, seed=3)
    x = r.x
    assert tuple(x[0, :6]) == (0, 19, 2, 19, 19, 2)
    assert 0 <= x[0, 7] <= 9
    for t in range(len(r) - 1):
        bi, bj, bh, ci, cj, ch, ti, tj = (int(v) for v in x[t])
        d = int(r.d[t])
        assert tuple(x[t + 1, 0:3]) == move(bi, bj, bh, d // 4)
        assert tuple(x[t + 1, 3:6]) == move(ci, cj, ch, d % 4)
        assert max(abs(x[t + 1, 6] - ti), abs(x[t + 1, 7] - tj)) <= 1  # the target moves to a neighbour
        assert r.y[t] == observe(bi, bj, bh, ti, tj) + 4 * observe(ci, cj, ch, ti, tj)


def test_case_1_target_is_fixed_and_case_2_unobserved(case1: cehmm.TargetTracking, case2: cehmm.TargetTracking) -> None:
    r = cehmm.Policy.uniform(case1, [4]).rollout(case1)
    assert np.all(r.x[:, 6:8] == [10, 10])
    r = cehmm.Policy.uniform(case2, [4]).rollout(case2)
    assert np.all(r.y == 0)


def test_rollouts_replay_the_evaluation_episodes(policy: cehmm.Policy, case3: cehmm.TargetTracking) -> None:
    rewards = [policy.rollout(case3, seed=9, episode=k).reward for k in range(40)]
    assert sum(rewards) / 40 == policy.evaluate(case3, episodes=40, seed=9).mean
    again = policy.rollout(case3, seed=9, episode=3)
    assert np.array_equal(again.x, policy.rollout(case3, seed=9, episode=3).x)


def test_single_level_memory(case3: cehmm.TargetTracking) -> None:
    r = cehmm.Policy.uniform(case3, [16]).rollout(case3, seed=0)
    assert r.memory.shape == (100, 1)
