"""Which search `optimize_controller` runs (`search`, `ceworld::run::Search`): the CE over
controllers on exact values, the model search of every step (model §10) on sampled values unless
told, each with its own defaults, the settings of one refused by name by the other."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import cehmm
from cehmm.memory_tasks import TMaze

TIGER = Path(__file__).parents[1] / "data" / "pomdp" / "tiger.95.POMDP"
SMALL = dict(samples=4, episodes=2, max_iterations=2, eval_episodes=50, progress=False)


def _same_tables(a: cehmm.Policy, b: cehmm.Policy) -> bool:
    return len(a.tables) == len(b.tables) and all(np.array_equal(x, y) for x, y in zip(a.tables, b.tables))


def test_on_sampled_values_it_is_the_model_search_as_cehmm_run_gives_it() -> None:
    found = cehmm.optimize_controller(TMaze(corridor=4), nodes=4, **SMALL)
    ran = cehmm.run("model-search", TMaze(corridor=4), nodes=4, **SMALL)
    assert found.kind == "sampled" and found.policy.provenance["method"] == "model-search"
    assert found.evaluation == ran.evaluation and found.value == ran.evaluation.mean
    assert _same_tables(found.policy, ran.policy)
    assert set(found.history) == set(ran.history)
    assert found.run_values == [ran.history["best"][-1]] and found.restart == 0
    assert found.history["successful"][found.best_iteration]
    assert (found.env_steps, found.stop_reason) == (ran.env_steps, "max_iterations")


def test_its_best_so_far_is_drawn_as_every_search_s() -> None:
    # The model search's `best` is its best so far (not the best episode of an iteration): it
    # is the history's `best_so_far` too, which the learning curve draws as the best so far.
    found = cehmm.optimize_controller(TMaze(corridor=4), nodes=4, **SMALL)
    assert np.array_equal(found.history["best_so_far"], found.history["best"])
    lines = {line.get_label(): line for line in found.plot().axes[0].get_lines()}
    drawn = lines["controller: best so far"].get_ydata()
    assert np.array_equal(drawn, found.history["best"])


def test_search_ce_is_the_cross_entropy_method_over_controllers_on_sampled_values() -> None:
    found = cehmm.optimize_controller(TMaze(corridor=4), search="ce", nodes=2, **SMALL)
    assert found.policy.provenance["method"] == "controller-ce"
    assert "best_so_far" in found.history and found.kind == "sampled"


def test_exact_values_are_the_ce_s_and_the_model_search_is_refused_there() -> None:
    tiger = cehmm.PomdpWorld(TIGER, horizon=20)
    found = cehmm.optimize_controller(tiger, nodes=2, max_iterations=1, samples=20, progress=False)
    assert (found.kind, found.policy.provenance["method"]) == ("exact", "controller-ce")
    with pytest.raises(cehmm.InvalidArgumentError, match=r'search: "model" on exact values'):
        cehmm.optimize_controller(tiger, search="model", progress=False)
    with pytest.raises(cehmm.InvalidArgumentError, match=r'"dice" \(expected "ce" or "model"\)'):
        cehmm.optimize_controller(tiger, search="dice", progress=False)


@pytest.mark.parametrize(
    ("setting", "value"), [("injection", 0.5), ("restarts", 2), ("memory", "clock"), ("tolerance", 1e-3)]
)
def test_a_setting_of_the_ce_alone_is_refused_by_the_model_search_by_its_name(setting: str, value: object) -> None:
    with pytest.raises(cehmm.InvalidArgumentError, match=rf'{setting}: .*a setting of search="ce"'):
        cehmm.optimize_controller(TMaze(corridor=4), nodes=4, **{setting: value, **SMALL})


def test_a_model_search_stops_at_its_target_and_nodes_must_be_a_power_of_its_registers() -> None:
    found = cehmm.optimize_controller(TMaze(corridor=4), target=1.0, progress=False)
    assert (found.value, found.stop_reason) == (1.0, "target")
    with pytest.raises(cehmm.InvalidArgumentError, match=r"nodes: 8 .*e\.g\. 4, 9, 16; or registers=0"):
        cehmm.optimize_controller(TMaze(corridor=4), nodes=8, progress=False)
    flat = cehmm.optimize_controller(TMaze(corridor=4), nodes=8, registers=0, **SMALL)
    assert flat.policy.provenance["registers"] == 0


def test_a_model_search_resumes_from_its_checkpoint_bit_for_bit(tmp_path: Path) -> None:
    settings = dict(SMALL, max_iterations=3)
    whole = cehmm.optimize_controller(TMaze(corridor=4), nodes=4, **settings)
    path = tmp_path / "search.ckpt"
    cut = cehmm.optimize_controller(
        TMaze(corridor=4), nodes=4, checkpoint=path, callback=lambda it: it["iteration"] < 0, **settings
    )
    assert (cut.stop_reason, len(cut.history["iteration"])) == ("callback", 1)
    resumed = cehmm.optimize_controller(TMaze(corridor=4), nodes=4, checkpoint=path, resume=True, **settings)
    assert _same_tables(resumed.policy, whole.policy) and resumed.evaluation == whole.evaluation
    assert list(resumed.history["best"]) == list(whole.history["best"])


def test_a_world_scored_as_a_whole_keeps_the_ce_and_refuses_the_model_search() -> None:
    # Target tracking's value is not a sum of its steps' rewards, nor is a Python world's with a
    # score of its own: the model search has nothing to learn from there.
    tracking = cehmm.TargetTracking(1)
    found = cehmm.optimize_controller(tracking, nodes=2, samples=10, episodes=2, max_iterations=1, progress=False)
    assert found.policy.provenance["method"] == "controller-ce"
    with pytest.raises(cehmm.InvalidArgumentError, match=r'search: "model" on a world whose value is not'):
        cehmm.optimize_controller(tracking, search="model", progress=False)
    scored = cehmm.optimize_controller(
        TMaze(corridor=4), nodes=2, score=lambda o, d, r: float(r.max()), **{**SMALL, "samples": 10}
    )
    assert scored.policy.provenance["method"] == "controller-ce"
