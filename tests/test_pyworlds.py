"""The Python reference implementations of the target-tracking world (``cehmm.pyworlds``) against
the engine's own world stepped through ``cehmm._core.Session``: exactly in case 1 (deterministic
given the decisions), in distribution in cases 2 and 3, and the target's move law against the
rule of model §4 written out here."""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import pytest

import cehmm
from cehmm import _core
from cehmm.pyworlds import TrackingBatch, TrackingEpisodes

#: Two-sample z-tests pass when |z| < Z_MAX.
Z_MAX = 4.0
#: Steps (1-based) whose states and observations are compared.
TIMES = (1, 2, 10, 50)
#: A small grid with the target's start rows covering it, so that it meets every edge.
SMALL_GRID = dict(width=5, height=4, horizon=30, start_b=[0, 3], start_c=[4, 3], target_cell=[2, 1], target_rows=[0, 3])


def _decision(y: Any, t: int, noise: Any) -> Any:
    """The decision rule of every comparison (Python ints or arrays), from the observation, the
    step and a noise in 0..64: at steps 1 and 2 B turns right and C left (both end facing up);
    then each mobile moves forward when it sees the target ahead, else as its 3 bits of noise
    say (0..3: that move, 4..7: forward)."""
    if t <= 2:
        return (4 * 1 + 0) + 0 * y
    moves = []
    for v, ahead in ((noise >> 3, y & 1), (noise & 7, (y >> 2) & 1)):
        a = v - (v >= 4) * (v - 2)
        moves.append(a + ahead * (2 - a))
    return 4 * moves[0] + moves[1]


def _loop(
    start: Callable[[int], Any], n: int, horizon: int, noise: np.ndarray, times: Sequence[int]
) -> tuple[np.ndarray, np.ndarray, dict[int, np.ndarray]]:
    """Runs ``n`` episodes one at a time: ``start(k)`` gives an object with ``observation``,
    ``step(d)`` and ``describe()``. Returns the observations ``(n, horizon + 1)``, the step rewards
    ``(n, horizon)`` and the states before the steps ``times`` (``(n, 8)`` each)."""
    observations = np.empty((n, horizon + 1), dtype=np.int64)
    rewards = np.empty((n, horizon))
    states = {t: np.empty((n, 8), dtype=np.int64) for t in times if t <= horizon}
    for k in range(n):
        episode = start(k)
        y = episode.observation
        observations[k, 0] = y
        row = noise[k]
        for t in range(1, horizon + 1):
            if t in states:
                states[t][k] = episode.describe()
            y, r, _ = episode.step(int(_decision(y, t, row[t - 1])))
            observations[k, t] = y
            rewards[k, t - 1] = r
    return observations, rewards, states


class _Episode:
    """A :class:`TrackingEpisodes` episode seen as a Session (``observation`` attribute)."""

    def __init__(self, world: TrackingEpisodes, seed: int) -> None:
        self.observation = world.reset(seed)
        self.step = world.step
        self.describe = world.describe


def run_engine(params: dict, n: int, seed: int, noise: np.ndarray, times: Sequence[int] = TIMES):
    """The engine's world through ``cehmm._core.Session``, episode ``k`` of ``seed``."""
    core = cehmm.TargetTracking(**params)._core
    return _loop(lambda k: _core.Session(core, seed, k), n, core.horizon, noise, times)


def run_episodes(params: dict, n: int, seed: int, noise: np.ndarray, times: Sequence[int] = TIMES):
    world = TrackingEpisodes(**params)
    return _loop(lambda k: _Episode(world, 1_000_003 * seed + k), n, world.horizon, noise, times)


def run_batch(params: dict, n: int, seed: int, noise: np.ndarray, times: Sequence[int] = TIMES):
    world = TrackingBatch(**params)
    observations = np.empty((n, world.horizon + 1), dtype=np.int64)
    rewards = np.empty((n, world.horizon))
    states: dict[int, np.ndarray] = {}
    y = observations[:, 0] = world.reset(n, seed)
    for t in range(1, world.horizon + 1):
        if t in times:
            states[t] = world.describe()
        y, r, done = world.step(_decision(y, t, noise[:, t - 1]))
        assert not done.any()
        observations[:, t] = y
        rewards[:, t - 1] = r
    return observations, rewards, states


def z_score(a: np.ndarray, b: np.ndarray) -> float:
    """The two-sample z of the means of ``a`` and ``b`` (0 when both are constant and equal)."""
    se = math.sqrt(a.var(ddof=1) / len(a) + b.var(ddof=1) / len(b))
    difference = float(a.mean() - b.mean())
    return difference / se if se > 0 else (0.0 if difference == 0 else math.inf)


def chi2_limit(dof: int, z: float = Z_MAX) -> float:
    """The chi-square quantile of upper tail ``P(N(0,1) > z)`` (about 3e-5), Wilson–Hilferty."""
    c = 2 / (9 * dof)
    return dof * (1 - c + z * math.sqrt(c)) ** 3


def homogeneity(a: np.ndarray, b: np.ndarray, values: int) -> tuple[float, float]:
    """Chi-square of two samples of ``0..values`` having one law (sparse values pooled):
    ``(statistic, limit)``."""
    counts_a, counts_b = np.bincount(a, minlength=values), np.bincount(b, minlength=values)
    order = np.argsort(counts_a + counts_b)
    # Pool the rarest values until the pooled bin holds at least 20 draws.
    before = np.cumsum((counts_a + counts_b)[order]) - (counts_a + counts_b)[order]
    pooled = before < 20
    bins_a = [counts_a[order[pooled]].sum(), *counts_a[order[~pooled]]]
    bins_b = [counts_b[order[pooled]].sum(), *counts_b[order[~pooled]]]
    bins = [(int(x), int(y)) for x, y in zip(bins_a, bins_b) if x + y > 0]
    n_a, n_b = len(a), len(b)
    statistic = sum((n_b * x - n_a * y) ** 2 / (n_a * n_b * (x + y)) for x, y in bins)
    return statistic, (chi2_limit(len(bins) - 1) if len(bins) > 1 else math.inf)


@pytest.mark.parametrize("params", [{}, SMALL_GRID], ids=["default", "small-grid"])
def test_case_1_is_the_engines_world_exactly(params: dict) -> None:
    params = dict(params, case=1)
    n = 200
    horizon = TrackingEpisodes(**params).horizon
    noise = np.random.default_rng(11).integers(0, 64, size=(n, horizon))
    engine = run_engine(params, n, seed=3, noise=noise)
    # The target is fixed: any seed gives the same episodes for the same decisions.
    for run in (run_episodes, run_batch):
        observations, rewards, states = run(params, n, 5, noise)
        np.testing.assert_array_equal(observations, engine[0])
        np.testing.assert_array_equal(rewards, engine[1])
        for t, state in states.items():
            np.testing.assert_array_equal(state, engine[2][t])
    assert engine[1].sum(axis=1).max() > 0  # some episodes are rewarded: the comparison has teeth


def test_the_case_1_plan_scores_the_optimum() -> None:
    optimum = cehmm.TargetTracking(case=1).optimum()
    # C (B still): right (facing left), 6 forward, right (facing up), 6 forward: 14 moves to
    # (13, 13), at d∞ = 3 from the target (10, 10); rewarded from step 15 on.
    moves = [4 * 3 + 1] + [4 * 3 + 2] * 6 + [4 * 3 + 1] + [4 * 3 + 2] * 6
    moves += [4 * 3 + 3] * (100 - len(moves))
    world = TrackingEpisodes(case=1)
    world.reset(0)
    assert sum(world.step(d)[1] for d in moves) == optimum == 86
    batch = TrackingBatch(case=1)
    batch.reset(3, 0)
    assert (sum(batch.step(np.full(3, d))[1] for d in moves) == optimum).all()


@pytest.mark.parametrize("case", [2, 3])
def test_cases_2_and_3_follow_the_engines_world_in_distribution(case: int) -> None:
    params = dict(case=case)
    n, n_batch = 2000, 20000
    noise = np.random.default_rng(case).integers(0, 64, size=(n_batch, 100))
    engine = run_engine(params, n, seed=17, noise=noise)
    values = engine[1].sum(axis=1)
    assert 5 < values.mean() < 95 and values.std() > 1  # neither trivial nor constant
    for run, size in ((run_episodes, n), (run_batch, n_batch)):
        observations, rewards, states = run(params, size, 29, noise[:size])
        assert set(np.unique(rewards)) <= {0.0, 1.0}
        # The episode value V (sum of the step rewards): two-sample z-test, |z| < 4.
        z = z_score(rewards.sum(axis=1), values)
        assert abs(z) < Z_MAX, (run.__name__, "V", z)
        # The observation's law at a few steps: chi-square homogeneity, p about 3e-5.
        for t in TIMES:
            if case == 2:
                assert (observations[:, t - 1] == 0).all()
                continue
            statistic, limit = homogeneity(observations[:, t - 1], engine[0][:, t - 1], 16)
            assert statistic < limit, (run.__name__, "y", t, statistic, limit)
            z = z_score(observations[:, t - 1].astype(float), engine[0][:, t - 1].astype(float))
            assert abs(z) < Z_MAX, (run.__name__, "mean y", t, z)
        # The target's position (start law at t = 1, then its moves): z-tests on each coordinate.
        for t in TIMES:
            for column, name in ((6, "target_i"), (7, "target_j")):
                z = z_score(states[t][:, column].astype(float), engine[2][t][:, column].astype(float))
                assert abs(z) < Z_MAX, (run.__name__, name, t, z)
        start = states[1][:, 6:]
        assert start[:, 0].min() == 0 and start[:, 0].max() == 19
        assert start[:, 1].min() == 0 and start[:, 1].max() == 9


def _move_law(states: np.ndarray, width: int, height: int) -> np.ndarray:
    """Model §4's law of the target's displacement ``k = 3·(dj + 1) + (di + 1)`` from each of
    the ``states`` (``(m, 8)``, as ``describe`` gives them): ``(m, 9)`` probabilities, written
    out here from the rule."""
    b, c, target = states[:, 0:2], states[:, 3:5], states[:, 6:8]
    weights = np.zeros((len(states), 9))
    for k in range(9):
        cell = target + [k % 3 - 1, k // 3 - 1]
        inside = (cell[:, 0] >= 0) & (cell[:, 0] < width) & (cell[:, 1] >= 0) & (cell[:, 1] < height)
        weights[:, k] = np.where(inside, ((cell - b) ** 2).sum(axis=1) + ((cell - c) ** 2).sum(axis=1), 0)
    return weights / weights.sum(axis=1, keepdims=True)


#: The displacement ``(di, dj)`` of each ``k = 3·(dj + 1) + (di + 1)``.
_DI, _DJ = np.tile([-1, 0, 1], 3), np.repeat([-1, 0, 1], 3)


def _score_z(law: np.ndarray, feature: np.ndarray, observed: np.ndarray) -> float:
    """The z of ``Σ_s feature(s, k_s) − E_law[feature(s, ·)]`` over the samples ``s``: 0 in
    mean, ``N(0, 1)`` in law when ``k_s`` are drawn from ``law`` (each ``(m, 9)``)."""
    mean = (law * feature).sum(axis=1)
    variance = (law * feature**2).sum(axis=1) - mean**2
    return float((feature[np.arange(len(observed)), observed] - mean).sum() / math.sqrt(variance.sum()))


@pytest.mark.parametrize("params", [{}, SMALL_GRID], ids=["default", "small-grid"])
def test_the_target_moves_by_the_rule(params: dict) -> None:
    """Every implementation, the engine's included, against the rule: the target's displacement
    at each step of episodes of the decision rule, given the state before the step (the mobiles
    before they move), pooled over the steps. Its histogram: chi-square goodness of fit, p about
    3e-5. Conditional on the state (a histogram alone misses a law computed from the wrong
    positions): z-tests, |z| < 4, of the mean displacement along i, along j, away from the
    mobiles, and along the mobiles' own moves of the step (which must not matter)."""
    params = dict(params, case=3)
    world = TrackingEpisodes(**params)
    horizon = world.horizon
    times = range(1, horizon + 1)
    noise = np.random.default_rng(41).integers(0, 64, size=(6000, horizon))
    for run, n in ((run_engine, 600), (run_episodes, 600), (run_batch, 6000)):
        _, _, states = run(params, n, 43, noise[:n], times)
        before = np.concatenate([states[t] for t in times[:-1]])
        after = np.concatenate([states[t + 1] for t in times[:-1]])
        moved = after[:, 6:8] - before[:, 6:8]
        assert (np.abs(moved) <= 1).all(), run.__name__
        observed = 3 * (moved[:, 1] + 1) + (moved[:, 0] + 1)
        law = _move_law(before, world.width, world.height)
        counts = np.bincount(observed, minlength=9)
        expected = law.sum(axis=0)
        statistic = ((counts - expected) ** 2 / expected).sum()
        assert statistic < chi2_limit(8), (run.__name__, counts, expected.round(1))
        away = 2 * before[:, 6:8] - before[:, 0:2] - before[:, 3:5]  # (R − B) + (R − C)
        steps = after[:, 0:2] - before[:, 0:2] + after[:, 3:5] - before[:, 3:5]  # the mobiles' moves
        features = {
            "di": np.broadcast_to(_DI, law.shape),
            "dj": np.broadcast_to(_DJ, law.shape),
            "away": away[:, :1] * _DI + away[:, 1:] * _DJ,
            "mobiles' moves": steps[:, :1] * _DI + steps[:, 1:] * _DJ,
        }
        for name, feature in features.items():
            z = _score_z(law, feature, observed)
            assert abs(z) < Z_MAX, (run.__name__, name, z)
        # The start law: every column and the rows target_rows, inclusive.
        start = states[1][:, 6:8]
        (first, last), width = world.target_rows, world.width
        assert set(start[:, 0]) == set(range(width)) and set(start[:, 1]) == set(range(first, last + 1))


def test_batched_episodes_are_reproducible_and_independent() -> None:
    world = TrackingBatch(case=3)
    assert TrackingBatch.batched is True
    assert (world.n_observations, world.n_decisions, world.horizon) == (16, 16, 100)
    decisions = np.random.default_rng(0).integers(0, 16, size=(100, 4000))

    def run(seed: int) -> tuple[np.ndarray, np.ndarray]:
        y = world.reset(4000, seed)
        assert y.dtype == np.int64 and y.shape == (4000,)
        observations, rewards = [y], []
        for d in decisions:
            y, r, done = world.step(d)
            assert y.dtype == np.int64 and r.dtype == np.float64 and done.dtype == np.bool_
            assert y.shape == r.shape == done.shape == (4000,) and not done.any()
            observations.append(y)
            rewards.append(r)
        return np.array(observations), np.array(rewards)

    observations, rewards = run(8)
    again = run(8)
    np.testing.assert_array_equal(observations, again[0])
    np.testing.assert_array_equal(rewards, again[1])
    assert not np.array_equal(observations, run(9)[0])
    assert observations.min() >= 0 and observations.max() < 16
    assert set(np.unique(rewards)) == {0.0, 1.0}
    # Independent episodes: neighbouring episodes' values are uncorrelated (|r|·√n < 4).
    values = rewards.sum(axis=0)
    correlation = np.corrcoef(values[:-1], values[1:])[0, 1]
    assert abs(correlation) * math.sqrt(len(values) - 1) < Z_MAX
    # Case 2: one observation, always 0.
    hidden = TrackingBatch(case=2)
    assert hidden.n_observations == 1
    assert (hidden.reset(10, 0) == 0).all() and (hidden.step(np.arange(10))[0] == 0).all()


def test_the_episode_protocol() -> None:
    world = TrackingEpisodes(case=3)
    assert (world.n_observations, world.n_decisions, world.horizon) == (16, 16, 100)
    assert TrackingEpisodes(case=2).n_observations == 1

    def run(seed: int) -> list:
        trace = [world.reset(seed)]
        for t in range(world.horizon):
            step = world.step((5 * t) % 16)
            assert type(step[0]) is int and type(step[1]) is float and step[2] is False
            assert 0 <= step[0] < 16 and step[1] in (0.0, 1.0)
            trace.append(step)
        return trace

    assert run(4) == run(4)
    assert run(4) != run(5)
    with pytest.raises(ValueError, match="decision: 16"):
        world.step(16)


@pytest.mark.parametrize("world", [TrackingEpisodes, TrackingBatch])
@pytest.mark.parametrize("case", [0, 4, "3", 2.5])
def test_a_bad_case_is_refused(world: type, case: Any) -> None:
    with pytest.raises(ValueError, match=re.escape(f"invalid case: {case!r}")):
        world(case=case)


def test_a_one_cell_grid() -> None:
    params = dict(case=3, width=1, height=1, start_b=[0, 0], start_c=[0, 0], target_cell=[0, 0], target_rows=[0, 0])
    engine = run_engine(params, 3, 0, np.zeros((3, 100), dtype=np.int64))
    for run in (run_episodes, run_batch):
        observations, rewards, _ = run(params, 3, 0, np.zeros((3, 100), dtype=np.int64))
        np.testing.assert_array_equal(observations, engine[0])
        np.testing.assert_array_equal(rewards, engine[1])
