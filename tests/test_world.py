"""The target-tracking world as seen from Python (model §4)."""

from __future__ import annotations

import pickle

import pytest

import cehmm

PARAMETERS = {
    "case",
    "width",
    "height",
    "horizon",
    "start_b",
    "start_c",
    "start_heading",
    "reward_radius",
    "observe_radius",
    "target_cell",
    "target_rows",
}


def test_defaults_follow_the_spec(case3: cehmm.TargetTracking) -> None:
    assert case3.case == 3
    assert (case3.n_observations, case3.n_decisions, case3.horizon) == (16, 16, 100)
    params = case3.params
    assert set(params) == PARAMETERS
    assert params["width"] == params["height"] == 20
    assert params["start_b"] == [0, 19] and params["start_c"] == [19, 19]
    assert params["target_cell"] == [10, 10] and params["target_rows"] == [0, 9]
    assert cehmm.TargetTracking().params == params


def test_case_2_has_a_single_observation(case2: cehmm.TargetTracking) -> None:
    assert case2.n_observations == 1
    assert case2.n_decisions == 16


def test_parameters_are_applied_and_shown() -> None:
    world = cehmm.TargetTracking(case=1, horizon=50, target_cell=(5, 6))
    assert world.horizon == 50
    assert world.params["target_cell"] == [5, 6]
    assert repr(world) == "TargetTracking(case=1, horizon=50, target_cell=[5, 6])"
    assert world.to_dict() == {"name": "target-tracking", **world.params}


def test_case_1_optimum_is_86(case1: cehmm.TargetTracking) -> None:
    assert case1.optimum() == 86
    # The nearer mobile needs 14 moves whatever the horizon.
    assert cehmm.TargetTracking(case=1, horizon=50).optimum() == 36


def test_optimum_is_refused_outside_case_1(case3: cehmm.TargetTracking) -> None:
    with pytest.raises(cehmm.InvalidArgumentError, match="case 1 only"):
        case3.optimum()


@pytest.mark.parametrize("case", [0, 4, -1, 256])
def test_bad_case_is_refused(case: int) -> None:
    with pytest.raises(cehmm.InvalidArgumentError, match=rf"case: {case}\b"):
        cehmm.TargetTracking(case=case)


def test_unknown_parameter_is_named_with_the_valid_ones() -> None:
    with pytest.raises(cehmm.InvalidArgumentError, match="bogus") as error:
        cehmm.TargetTracking(bogus=1)
    for name in PARAMETERS:
        assert name in str(error.value)


@pytest.mark.parametrize(
    ("params", "named", "error"),
    [
        ({"horizon": 0}, "horizon: 0", cehmm.InvalidArgumentError),
        ({"horizon": -3}, "horizon: -3", cehmm.InvalidArgumentError),
        ({"horizon": 1.5}, r"horizon: 1\.5 is a float \(expected an int\)", TypeError),
        ({"width": True}, r"width: true is a bool \(expected an int\)", TypeError),
        ({"start_b": [25, 0]}, "start_b", cehmm.InvalidArgumentError),
        ({"start_b": [1]}, "start_b", cehmm.InvalidArgumentError),
        ({"start_b": "ab"}, r"start_b: \"ab\" is a string \(expected a list of ints\)", TypeError),
        ({"start_b": [1, "a"]}, "start_b", TypeError),
        ({"target_rows": [9, 0]}, "target_rows", cehmm.InvalidArgumentError),
        ({"start_heading": 4}, "start_heading", cehmm.InvalidArgumentError),
        ({"case": "3"}, "case", TypeError),
        ({"case": object()}, "case", TypeError),
    ],
)
def test_bad_parameter_values_are_named(params: dict, named: str, error: type) -> None:
    with pytest.raises(error, match=named) as raised:
        cehmm.TargetTracking(**params)
    assert isinstance(raised.value, cehmm.CehmmError) == (error is not TypeError)


def test_worlds_compare_hash_and_pickle_by_parameters() -> None:
    a = cehmm.TargetTracking(case=2, horizon=30)
    b = cehmm.TargetTracking.from_dict(a.to_dict())
    assert a == b and hash(a) == hash(b)
    assert a != cehmm.TargetTracking(case=2)
    assert pickle.loads(pickle.dumps(a)) == a


def test_from_dict_checks_the_name() -> None:
    with pytest.raises(cehmm.InvalidArgumentError, match="world.name"):
        cehmm.TargetTracking.from_dict({"name": "cart-pole", "case": 1})
    with pytest.raises(cehmm.InvalidArgumentError, match="world.name: 3 is not a string"):
        cehmm.World.from_dict({"name": 3})
    with pytest.raises(cehmm.InvalidArgumentError, match="world.name: missing"):
        cehmm.World.from_dict({"case": 1})
