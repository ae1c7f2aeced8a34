"""Property tests of the Python API's arguments (Hypothesis): whatever values and types are passed,
``optimize``, ``optimize_controller``, ``Policy.evaluate``, ``World`` and ``PythonWorld`` either work or raise
``TypeError`` or :class:`cehmm.CehmmError`, naming the argument; never a panic, a crash, or another
exception. The example count is kept small for CI; ``HYPOTHESIS_PROFILE=long`` runs many more (profiles:
conftest.py)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from hypothesis import given
from hypothesis import strategies as st

import cehmm

TIGER = Path(__file__).resolve().parents[1] / "data" / "pomdp" / "tiger.95.POMDP"

#: Values of every kind, small enough that a valid one runs quickly.
ANY = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-3, max_value=40),
    st.integers(min_value=2**62, max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.text(max_size=4),
    st.lists(st.integers(min_value=-2, max_value=5), max_size=3),
)


def _named(e: BaseException, names: set[str]) -> None:
    assert any(n in str(e) for n in names), f"{type(e).__name__}: {e} names none of {names}"


@given(st.dictionaries(st.sampled_from(["samples", "rho", "smoothing", "patience", "seed", "levels"]), ANY, max_size=3))
def test_optimize_arguments(arguments: dict[str, Any]) -> None:
    world = cehmm.TargetTracking(case=1, horizon=10)
    try:
        cehmm.optimize(world, **{"max_iterations": 1, "eval_episodes": 5, "progress": False, **arguments})
    except (TypeError, cehmm.CehmmError) as e:
        assert not isinstance(e, cehmm.InternalError), e
        _named(e, set(arguments))


CONTROLLER_KEYS = ["nodes", "samples", "rho", "smoothing", "tolerance", "restarts"]
WORLD_KEYS = ["case", "width", "height", "horizon", "reward_radius", "start_b"]


@given(st.dictionaries(st.sampled_from(CONTROLLER_KEYS), ANY, max_size=3))
def test_optimize_controller_arguments(arguments: dict[str, Any]) -> None:
    world = cehmm.PomdpWorld.from_file(TIGER, horizon=10)
    try:
        cehmm.optimize_controller(world, **{"max_iterations": 1, "progress": False, **arguments})
    except (TypeError, cehmm.CehmmError) as e:
        assert not isinstance(e, cehmm.InternalError), e
        _named(e, set(arguments))


@given(episodes=ANY, seed=ANY, threads=ANY)
def test_evaluate_arguments(episodes: Any, seed: Any, threads: Any) -> None:
    world = cehmm.TargetTracking(case=1, horizon=10)
    policy = cehmm.Policy.uniform(world, [2])
    try:
        policy.evaluate(world, episodes=episodes, seed=seed, threads=threads)
    except (TypeError, cehmm.CehmmError) as e:
        assert not isinstance(e, cehmm.InternalError), e
        _named(e, {"episodes", "seed", "threads"})


@given(st.dictionaries(st.sampled_from(WORLD_KEYS), ANY, max_size=3))
def test_world_parameters(parameters: dict[str, Any]) -> None:
    try:
        cehmm.TargetTracking(**parameters)
    except (TypeError, cehmm.CehmmError) as e:
        assert not isinstance(e, cehmm.InternalError), e
        # A smaller grid can put a default position off it: the error then names that position.
        _named(e, set(parameters) | {"start_b", "start_c", "target_cell", "target_rows"})


class _Tiny:
    """A world written in Python whose sizes Hypothesis sets."""

    def __init__(self, sizes: dict[str, Any]) -> None:
        self.n_observations, self.n_decisions, self.horizon = 2, 2, 3
        self.__dict__.update(sizes)

    def reset(self, seed: int) -> int:
        return 0

    def step(self, decision: int) -> tuple[int, float, bool]:
        return 1, 1.0, False


@given(
    st.dictionaries(st.sampled_from(["n_observations", "n_decisions", "horizon"]), ANY, max_size=2),
    st.dictionaries(st.sampled_from(["discount", "horizon", "name"]), ANY, max_size=2),
)
def test_python_world_arguments(sizes: dict[str, Any], options: dict[str, Any]) -> None:
    try:
        world = cehmm.PythonWorld(_Tiny(sizes), **options)
        cehmm.Policy.uniform(world, [2]).evaluate(world, episodes=3)
    except (TypeError, cehmm.CehmmError) as e:
        assert not isinstance(e, cehmm.InternalError), e
        _named(e, set(sizes) | set(options) | {"observations", "decisions", "horizon", "world", "policy"})
