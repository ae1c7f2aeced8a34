"""Bad arguments raise the documented exceptions, naming the argument and its value."""

from __future__ import annotations

import pytest

import cehmm

FAST = dict(samples=20, max_iterations=1, eval_episodes=10, progress=False)


def test_hierarchy() -> None:
    for error in [cehmm.InvalidArgumentError, cehmm.PolicyFormatError, cehmm.PolicyMismatchError]:
        assert issubclass(error, cehmm.CehmmError)
    assert issubclass(cehmm.CehmmError, ValueError)
    assert cehmm.CehmmError.__module__ == "cehmm"


@pytest.mark.parametrize(
    ("arguments", "named"),
    [
        ({"rho": 0}, r"rho: 0\b"),
        ({"rho": 1}, r"rho: 1\b"),
        ({"rho": 1.5}, r"rho: 1\.5"),
        ({"rho": float("nan")}, r"rho: NaN"),
        ({"rho": "half"}, r"rho: 'half'"),
        ({"samples": 0}, r"samples: 0\b"),
        ({"samples": -5}, r"samples: -5\b"),
        ({"samples": 2.5}, r"samples: 2\.5"),
        ({"levels": [16, 0]}, r"levels: \[16, 0\]"),
        ({"levels": []}, r"levels: \[\]"),
        ({"levels": [16, -1]}, r"levels: \[16, -1\]"),
        ({"levels": [16, 2.0]}, r"levels: \[16, 2\.0\]"),
        ({"levels": 16}, r"levels: 16\b"),
        ({"levels": "16"}, r"levels: '16'"),
        ({"levels": [70000]}, r"levels: \[70000\]"),
        ({"smoothing": 0}, r"smoothing: 0\b"),
        ({"smoothing": 1.01}, r"smoothing: 1\.01"),
        ({"threads": 0}, r"threads: 0\b"),
        ({"threads": -1}, r"threads: -1\b"),
        ({"patience": 0}, r"patience: 0\b"),
        ({"max_iterations": 0}, r"max_iterations: 0\b"),
        ({"time_limit": 0}, r"time_limit: 0\b"),
        ({"time_limit": -1.0}, r"time_limit: -1\b"),
        ({"eval_episodes": 0}, r"eval_episodes: 0\b"),
        ({"seed": -1}, r"seed: -1\b"),
        ({"seed": 2**64}, r"seed: 18446744073709551616"),
        ({"init": "zeros"}, r"init: 'zeros'"),
        ({"progress": "yes"}, r"progress: 'yes'"),
    ],
)
def test_bad_optimize_arguments(case1: cehmm.TargetTracking, arguments: dict, named: str) -> None:
    settings = {**FAST, **arguments}
    with pytest.raises(cehmm.InvalidArgumentError, match=named):
        cehmm.optimize(case1, **settings)


def test_world_must_be_a_world() -> None:
    with pytest.raises(cehmm.InvalidArgumentError, match="world"):
        cehmm.optimize("case 1", **FAST)  # type: ignore[arg-type]
    with pytest.raises(cehmm.InvalidArgumentError, match="world"):
        cehmm.Policy.uniform(None, [4])  # type: ignore[arg-type]


@pytest.mark.parametrize("episodes", [0, -1, 1.5])
def test_bad_evaluation_arguments(case1: cehmm.TargetTracking, episodes: object) -> None:
    policy = cehmm.Policy.uniform(case1, [4])
    with pytest.raises(cehmm.InvalidArgumentError, match="episodes"):
        policy.evaluate(case1, episodes=episodes)  # type: ignore[arg-type]
    with pytest.raises(cehmm.InvalidArgumentError, match="threads: 0"):
        policy.evaluate(case1, episodes=10, threads=0)


def test_policy_without_world_needs_one(case1: cehmm.TargetTracking) -> None:
    policy = cehmm.Policy.from_tables(cehmm.Policy.uniform(case1, [4]).tables)
    with pytest.raises(cehmm.InvalidArgumentError, match="no stored world"):
        policy.evaluate(episodes=10)
    assert policy.evaluate(case1, episodes=10).episodes == 10


def test_policies_are_made_by_factories() -> None:
    with pytest.raises(TypeError, match="Policy.uniform"):
        cehmm.Policy(object())  # type: ignore[arg-type]


def test_exported_names() -> None:
    for name in cehmm.__all__:
        assert hasattr(cehmm, name), name
    assert cehmm.__version__ == "0.1.0"
