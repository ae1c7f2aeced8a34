"""How a run closes and what it leaves (issue 29): Ctrl-C during the final evaluation returns the
result with a shorter evaluation, as Ctrl-C during the iterations does, and its resume closes it
whole; a checkpoint written before digests were required resumes with a warning; a result is
saved over an existing file only when asked."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import pytest
from test_signals import alarm
from worlds import Slow

import cehmm

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="SIGALRM timers are POSIX")

#: One iteration of 40 episodes (about 0.4 s at 10 ms an episode), then 300 evaluation episodes
#: (about 3 s): an alarm at 1.5 s comes during the final evaluation.
CLOSING = dict(levels=[2], samples=40, max_iterations=1, eval_episodes=300, seed=4, progress=False)


def _tables(policy: cehmm.Policy) -> dict:
    """The policy's levels and tables (not its world nor its provenance)."""
    return {k: v for k, v in json.loads(policy.to_json()).items() if k not in ("world", "provenance")}


def test_ctrl_c_during_the_final_evaluation_returns_the_result_and_its_resume_closes_it(tmp_path: Path) -> None:
    checkpoint = tmp_path / "closing.ckpt"
    with alarm(1.5, KeyboardInterrupt) as times:
        cut = cehmm.optimize(Slow(), checkpoint=checkpoint, resume=True, **CLOSING)
    assert times, "the alarm came after the run"
    assert time.monotonic() - times[0] < 2.0
    # The optimisation was over: its result stands, evaluated on the episodes done.
    assert cut.iterations == 1 and cut.interrupted
    assert 0 < cut.evaluation.episodes < CLOSING["eval_episodes"], cut.evaluation
    whole = cehmm.optimize(Slow(), **CLOSING)
    assert _tables(cut.policy) == _tables(whole.policy)
    resumed = cehmm.optimize(Slow(), checkpoint=checkpoint, resume=True, **CLOSING)
    assert not resumed.interrupted and resumed.evaluation == whole.evaluation


def test_ctrl_c_during_a_controller_searchs_final_evaluation_returns_the_result() -> None:
    settings = dict(nodes=2, samples=8, episodes=2, select_episodes=4, max_iterations=1, eval_episodes=300)
    with alarm(1.5, KeyboardInterrupt) as times:
        cut = cehmm.optimize_controller(Slow(), progress=False, **settings, search="ce")
    assert times and time.monotonic() - times[0] < 2.0
    assert cut.interrupted and cut.evaluation is not None
    assert 0 < cut.evaluation.episodes < 300, cut.evaluation


def test_a_checkpoint_without_its_digest_is_refused_and_an_old_one_resumes_with_a_warning(tmp_path: Path) -> None:
    world = cehmm.TargetTracking(case=1)
    settings = dict(levels=[3], samples=100, eval_episodes=100, seed=2, progress=False)
    checkpoint = tmp_path / "run.ckpt"
    cehmm.optimize(world, max_iterations=2, checkpoint=checkpoint, **settings)
    whole = cehmm.optimize(world, max_iterations=4, **settings)
    doc = json.loads(checkpoint.read_text())
    del doc["digest"]
    checkpoint.write_text(json.dumps(doc))
    with pytest.raises(cehmm.CehmmError, match='has no "digest"'):
        cehmm.optimize(world, max_iterations=4, checkpoint=checkpoint, resume=True, **settings)
    doc["version"] = 1  # the version before digests were required
    checkpoint.write_text(json.dumps(doc))
    with pytest.warns(RuntimeWarning, match="version 1.*unverified"):
        resumed = cehmm.optimize(world, max_iterations=4, checkpoint=checkpoint, resume=True, **settings)
    assert resumed.policy.to_json() == whole.policy.to_json()


def test_a_result_replaces_an_existing_file_only_when_asked(tmp_path: Path) -> None:
    world = cehmm.TargetTracking(case=1)
    path = tmp_path / "policy.json"
    first, second = cehmm.Policy.uniform(world, [2]), cehmm.Policy.uniform(world, [3])
    first.save(path)
    with pytest.raises(cehmm.InvalidArgumentError, match="policy.json exists.*overwrite=True"):
        second.save(path)
    assert cehmm.Policy.load(path).levels == [2]
    second.save(path, overwrite=True)
    assert cehmm.Policy.load(path).levels == [3]


def test_exact_values_refuse_a_tolerance_that_bounds_every_value() -> None:
    tiger = cehmm.PomdpWorld(Path(__file__).parents[1] / "data" / "pomdp" / "tiger.95.POMDP")
    policy = cehmm.Policy.uniform(tiger, [2])
    with pytest.raises(cehmm.InvalidArgumentError, match="tolerance: 18000000000000000000 .expected less than"):
        policy.evaluate_exact(infinite=True, tolerance=1.8e19)
    assert policy.evaluate_exact(infinite=True, tolerance=1e-3).tail_bound < 1e-3


def test_a_tiny_model_file_of_huge_tables_is_refused_before_they_are_built(tmp_path: Path) -> None:
    model = tmp_path / "huge.pomdp"
    model.write_text("states: 16384\nactions: 1\nobservations: 16384\nT: * uniform\nO: * uniform\n")
    with pytest.raises(cehmm.ModelFormatError, match="67108864 entries"):
        cehmm.PomdpWorld(model)
