"""Property tests of what worlds outside the engine return (Hypothesis): random finite Gymnasium
spaces with values in them and beside them, and values of every kind from both protocols. A value
in its space (an int observation, a real reward, a bool flag) is taken; anything else raises
:class:`cehmm.WorldError` naming what was wrong; never another exception, a panic or a value
silently cast. Example counts: conftest.py's profiles (``HYPOTHESIS_PROFILE=long``)."""

from __future__ import annotations

import warnings
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces
from hypothesis import given
from hypothesis import strategies as st
from worlds import Shows

import cehmm
from cehmm.gym_adapt import flat

#: Finite spaces, nested up to two Tuples deep, of at most a few thousand values.
LEAVES = st.one_of(
    st.builds(spaces.Discrete, st.integers(1, 6), start=st.integers(-3, 3)),
    st.builds(spaces.MultiDiscrete, st.lists(st.integers(1, 4), min_size=1, max_size=3)),
    st.builds(spaces.MultiBinary, st.integers(1, 4)),
)
SPACES = st.recursive(
    LEAVES, lambda inner: st.lists(inner, max_size=3).map(lambda s: spaces.Tuple(tuple(s))), max_leaves=4
)

#: Values that may or may not belong to a space.
JUNK = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-5, 8),
    st.floats(allow_nan=True, allow_infinity=True),
    st.complex_numbers(max_magnitude=3),
    st.text(max_size=3),
    st.lists(st.integers(-2, 5), max_size=4).map(np.array),
    st.lists(st.floats(-2, 5), max_size=4).map(np.array),
    st.tuples(st.integers(-1, 3), st.integers(-1, 3)),
)


@given(SPACES, st.data())
def test_values_in_and_beside_a_space(space: gym.Space, data: st.DataObject) -> None:
    space.seed(data.draw(st.integers(0, 2**32 - 1)))
    value = data.draw(st.one_of(st.just(space.sample()), JUNK))
    f = flat(space)
    world = cehmm.PythonWorld(Shows(space, value), horizon=2)
    # More values than MAX_FLAT are hashed into cells by default (cehmm.spaces.Hashed).
    hashed = f.size > cehmm.spaces.MAX_FLAT
    assert world.n_observations == (cehmm.spaces.HASHED_CELLS if hashed else f.size)
    try:
        evaluation = cehmm.Policy.uniform(world, [1]).evaluate(world, episodes=2)
    except cehmm.WorldError as e:
        assert not space.contains(value), (space, value, e)
        assert "is not in the space" in str(e), e
        return
    assert space.contains(value), (space, value)
    assert evaluation.mean == 1.0
    assert 0 <= f.index(value) < f.size


def test_a_space_of_more_values_than_max_flat_is_hashed() -> None:
    # 73,728 values (the fuzz test above drew it once): more than the engine's records hold, so
    # hashed into cells, and a value out of the space still refused.
    space = spaces.Tuple(
        (spaces.MultiDiscrete([2, 2, 3]), spaces.Tuple((spaces.MultiBinary(4), spaces.MultiDiscrete([2, 3, 4]))))
        + (spaces.MultiBinary(4),)
    )
    assert flat(space).size == 73_728
    space.seed(0)
    world = cehmm.PythonWorld(Shows(space, space.sample()), horizon=2)
    assert world.n_observations == cehmm.spaces.HASHED_CELLS
    assert cehmm.Policy.uniform(world, [1]).evaluate(world, episodes=2).mean == 1.0
    junk = cehmm.PythonWorld(Shows(space, 3), horizon=2)
    with pytest.raises(cehmm.WorldError, match="is not in the space"):
        cehmm.Policy.uniform(junk, [1]).evaluate(junk, episodes=2)


#: What one step may return in the episode protocol: observation, reward, done.
SCALARS = st.one_of(JUNK, st.integers(0, 2), st.floats(-10, 10), st.just(np.int64(1)), st.just(np.float32(0.5)))


class Returns:
    """The episode protocol, returning `step` from every step (observations 0..3)."""

    n_observations, n_decisions, horizon = 3, 2, 3

    def __init__(self, step: tuple[Any, Any, Any]) -> None:
        self.returned = step

    def reset(self, seed: int) -> int:
        return 0

    def step(self, decision: int) -> tuple[Any, Any, Any]:
        return self.returned


def _valid_observation(value: Any) -> bool:
    integer = isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))
    return integer and 0 <= int(value) < 3


def _valid_reward(value: Any) -> bool:
    real = isinstance(value, (int, float, np.integer, np.floating, np.bool_)) and not isinstance(value, complex)
    return real and bool(np.isfinite(float(value)))


def _valid_flag(value: Any) -> bool:
    if isinstance(value, (bool, np.bool_)):
        return True
    return isinstance(value, (int, np.integer)) and int(value) in (0, 1)


@given(SCALARS, SCALARS, SCALARS)
def test_what_one_step_returns(observation: Any, reward: Any, done: Any) -> None:
    world = Returns((observation, reward, done))
    # The observation that comes with the end of an episode is checked too (unused, but a value
    # out of range is the world's bug).
    valid = _valid_observation(observation) and _valid_reward(reward) and _valid_flag(done)
    try:
        cehmm.Policy.uniform(world, [1]).evaluate(world, episodes=2)
    except cehmm.WorldError as e:
        assert not valid, (observation, reward, done, e)
        assert any(w in str(e) for w in ("observation", "reward", "done")), e
        return
    assert valid, (observation, reward, done)


class BatchReturns:
    """The batched protocol, returning `make(n)` from every step."""

    batched = True
    n_observations, n_decisions, horizon = 3, 2, 3
    max_batch = 4

    def __init__(self, make: Any) -> None:
        self.make = make

    def reset(self, n: int, seed: int) -> np.ndarray:
        self.n = n
        return np.zeros(n, dtype=np.int64)

    def step(self, decisions: np.ndarray) -> tuple[Any, Any, Any]:
        return self.make(self.n)


#: A column of one dtype: (fill value, dtype), or None for a Python list of that value.
COLUMNS = st.tuples(
    SCALARS.filter(lambda v: not isinstance(v, (tuple, np.ndarray))),
    st.sampled_from([None, np.int64, np.int8, np.float64, np.bool_, np.complex128, object]),
)


def _column(fill: Any, dtype: Any, n: int) -> Any:
    if dtype is None:
        return [fill] * n
    # numpy's own casts (NaN to int, complex to real) are the test's business, not the world's.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return np.full(n, fill, dtype=dtype)
        except (TypeError, ValueError, OverflowError):
            return np.full(n, fill, dtype=object)


@given(COLUMNS, COLUMNS, COLUMNS)
def test_what_one_batched_step_returns(observation: Any, reward: Any, done: Any) -> None:
    world = BatchReturns(lambda n: tuple(_column(*c, n) for c in (observation, reward, done)))
    try:
        cehmm.Policy.uniform(world, [1]).evaluate(world, episodes=4)
    except cehmm.WorldError as e:
        assert any(w in str(e) for w in ("observation", "reward", "done")), e
        return
    # Taken: the same values one at a time are taken too (one rule for both protocols).
    first = tuple(_column(*c, 1)[0] for c in (observation, reward, done))
    cehmm.Policy.uniform(Returns(first), [1]).evaluate(Returns(first), episodes=2)
