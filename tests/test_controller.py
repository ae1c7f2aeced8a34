"""The cross-entropy search over deterministic controllers (model §8) from Python: it reaches
tiger's optimum, its value is the exact value of the policy it returns, it is deterministic
whatever the threads, and it refuses what it cannot search."""

from __future__ import annotations

from pathlib import Path

import pytest

import cehmm

DATA = Path(__file__).resolve().parents[1] / "data" / "pomdp"


@pytest.fixture(scope="module")
def tiger() -> cehmm.PomdpWorld:
    return cehmm.PomdpWorld.from_file(DATA / "tiger.95.POMDP", horizon=100)


def test_tiger_reaches_the_sarsop_value_with_an_exact_value(tiger: cehmm.PomdpWorld) -> None:
    result = cehmm.optimize_controller(tiger, nodes=5, progress=False)
    # SARSOP's bounds are [19.3713, 19.3714] (data/pomdp/SOURCES.md).
    assert result.value > 19.37
    assert result.policy.levels == [5, 5]
    exact = result.policy.evaluate_exact(tiger, infinite=True, tolerance=1e-9)
    assert exact.value == pytest.approx(result.value, abs=2e-6)
    assert result.policy.provenance["method"] == "controller-ce"
    h = result.history
    assert set(h) == {
        "restart",
        "iteration",
        "mean",
        "elite_min",
        "max",
        "best",
        "concentration",
        "evaluated",
        "seconds",
    }
    assert len(h["best"]) == len(h["mean"]) and h["best"][-1] == result.value
    assert result.stop_reason == "patience" and not result.interrupted


def test_results_do_not_depend_on_threads_and_restarts_keep_the_best(tiger: cehmm.PomdpWorld) -> None:
    settings = dict(nodes=3, samples=200, max_iterations=4, restarts=2, progress=False)
    one = cehmm.optimize_controller(tiger, threads=1, **settings)
    two = cehmm.optimize_controller(tiger, threads=2, **settings)
    assert one.value == two.value and one.run_values == two.run_values
    assert one.policy.graph(tiger, "json") == two.policy.graph(tiger, "json")
    assert one.value == max(one.run_values) == one.run_values[one.restart]


def test_what_cannot_be_searched_is_refused(tiger: cehmm.PomdpWorld) -> None:
    with pytest.raises(TypeError, match="PomdpWorld"):
        cehmm.optimize_controller(cehmm.TargetTracking(case=1), progress=False)  # type: ignore[arg-type]
    with pytest.raises(cehmm.InvalidArgumentError, match="rho: 2"):
        cehmm.optimize_controller(tiger, rho=2.0, progress=False)
    with pytest.raises(TypeError, match="nodes"):
        cehmm.optimize_controller(tiger, nodes="3", progress=False)  # type: ignore[arg-type]
    with pytest.raises(cehmm.InvalidArgumentError, match="nodes: 0"):
        cehmm.optimize_controller(tiger, nodes=0, progress=False)
