"""Callbacks and logs, Stable-Baselines3's way (issue 32): ``callback=`` of every optimiser stops a
run as a stopping rule does (the same tables, bit for bit, as ``max_iterations``; stop reason
``"callback"``; its checkpoint resumes), an exception in it propagates (the checkpoint still
consistent), the built-ins of ``cehmm.callbacks`` do what they say, and ``tensorboard_log=``
writes the history's scalars to an event file read back here. Issue 45: ``SaveBest`` keeps the best
of the whole call across restarts and never writes a name twice; a callback's files are held to
the one rule of a run's outputs and refused before the first iteration when they cannot be
written; a failing ``close()`` loses neither the result nor the callback's own error."""

from __future__ import annotations

import doctest
import glob
import os
import shutil
import struct
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import cehmm
import cehmm.callbacks
from cehmm.callbacks import (
    Callback,
    CallbackList,
    EvalOnEnv,
    Iteration,
    SaveBest,
    StopOnNoImprovement,
    TensorBoard,
)

ROOT = Path(__file__).resolve().parents[1]
TIGER = ROOT / "data" / "pomdp" / "tiger.95.POMDP"
SHUTTLE = ROOT / "data" / "pomdp" / "shuttle.95.POMDP"
#: A short case-1 optimisation (about a millisecond per iteration).
CE = dict(levels=[4], samples=200, eval_episodes=200, seed=3, progress=False)
#: A short exact controller search on tiger.
CONTROLLER = dict(nodes=3, samples=200, progress=False)
#: The 5 x 5 grid's Q-learning (its table: 160 000 x 16).
SMALL_GRID = dict(case=3, width=5, height=5, start_b=[0, 4], start_c=[4, 4], target_rows=[0, 2], target_cell=[2, 2])


def stop_after(k: int) -> Any:
    """A callback that stops the run after its iteration ``k`` (counted from 0)."""
    return lambda it: it["iteration"] < k


def same(a: Any, b: Any) -> bool:
    """Tables equal bit for bit, nested in dicts and lists as :attr:`cehmm.Policy.tables` are."""
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    return bool(np.array_equal(a, b))


def same_tables(a: cehmm.Policy, b: cehmm.Policy) -> bool:
    return a.levels == b.levels and same(a.tables, b.tables)


def same_history(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> bool:
    keys = set(a) - {"seconds", "episodes"}
    return keys == set(b) - {"seconds", "episodes"} and all(np.array_equal(a[k], b[k]) for k in keys)


@pytest.fixture(scope="module")
def tiger() -> cehmm.PomdpWorld:
    return cehmm.PomdpWorld.from_file(TIGER, horizon=100)


# -- the stop ----------------------------------------------------------------------------------


def test_a_callback_stop_at_iteration_k_is_max_iterations_k(case1: cehmm.TargetTracking) -> None:
    whole = cehmm.optimize(case1, max_iterations=4, **CE)
    cut = cehmm.optimize(case1, callback=stop_after(3), **CE)
    assert (whole.stop_reason, cut.stop_reason, cut.interrupted) == ("max_iterations", "callback", False)
    assert cut.iterations == 4
    assert same_tables(cut.policy, whole.policy) and same_tables(cut.last_policy, whole.last_policy)
    assert same_history(cut.history, whole.history)
    assert cut.evaluation == whole.evaluation, "evaluated in full, as after a stopping rule"
    assert cut.policy.provenance["stop"] == "callback" and cut.policy.provenance["interrupted"] is False


def test_the_controller_search_stops_where_its_callback_says(tiger: cehmm.PomdpWorld) -> None:
    whole = cehmm.optimize_controller(tiger, max_iterations=3, **CONTROLLER)
    cut = cehmm.optimize_controller(tiger, callback=stop_after(2), **CONTROLLER)
    assert (whole.stop_reason, cut.stop_reason, cut.interrupted) == ("max_iterations", "callback", False)
    assert same_tables(cut.policy, whole.policy) and cut.value == whole.value
    assert same_history(cut.history, whole.history)
    # With restarts, no later run starts.
    runs = cehmm.optimize_controller(tiger, restarts=3, max_iterations=4, callback=stop_after(1), **CONTROLLER)
    assert runs.stop_reason == "callback" and runs.run_values == [cut.history["best_so_far"][1]]


def test_a_stepped_optimiser_and_restarts_stop_where_the_callback_says(case1: cehmm.TargetTracking) -> None:
    tiger20 = cehmm.PomdpWorld.from_file(TIGER, horizon=20)
    whole = cehmm.run("random-search", tiger20, samples=20, max_iterations=3, progress=False)
    cut = cehmm.run("random-search", tiger20, samples=20, progress=False, callback=stop_after(2))
    assert (cut.stop_reason, cut.interrupted) == ("callback", False)
    assert same_tables(cut.policy, whole.policy) and same_history(cut.history, whole.history)
    seen: list[int] = []
    restarts = cehmm.optimize(
        case1,
        restarts=3,
        max_iterations=5,
        callback=lambda it: seen.append(it["iteration"]) or it["iteration"] < 1,
        **CE,
    )
    assert (restarts.stop_reason, restarts.iterations, seen) == ("callback", 2, [0, 1])


def test_q_learning_stops_after_the_chunk_its_callback_stops() -> None:
    world = cehmm.TargetTracking(**SMALL_GRID)
    records: list[Iteration] = []
    cut = cehmm.qlearning(world, iterations=3 * 2**20, progress=False, callback=lambda it: records.append(it) or False)
    assert (cut.stop_reason, cut.interrupted, cut.updates) == ("callback", False, 2**20)
    (record,) = records
    assert (record["iteration"], record["updates"], record.best_policy()) == (0, 2**20, None)
    assert {"epsilon", "reward_per_100", "mean_reward_per_100", "seconds"} <= set(record)
    whole = cehmm.qlearning(world, iterations=2**20, progress=False)
    assert whole.stop_reason == "iterations"
    assert np.array_equal(cut.table, whole.table)


def test_a_python_world_is_called_back_too() -> None:
    from worlds import Corridor

    whole = cehmm.optimize(Corridor(), levels=[2], samples=100, max_iterations=3, progress=False)
    cut = cehmm.optimize(Corridor(), levels=[2], samples=100, progress=False, callback=stop_after(2))
    assert cut.stop_reason == "callback" and same_tables(cut.policy, whole.policy)


# -- checkpoints and exceptions ----------------------------------------------------------------


def test_a_run_stopped_by_its_callback_resumes_bit_for_bit(case1: cehmm.TargetTracking, tmp_path: Path) -> None:
    path = tmp_path / "run.ckpt"
    whole = cehmm.optimize(case1, max_iterations=7, **CE)
    first = cehmm.optimize(case1, checkpoint=path, callback=stop_after(2), **CE)
    assert first.stop_reason == "callback" and path.exists()
    rest = cehmm.optimize(case1, checkpoint=path, resume=True, max_iterations=7, **CE)
    assert rest.stop_reason == "max_iterations"
    assert same_tables(rest.policy, whole.policy) and same_history(rest.history, whole.history)
    assert rest.evaluation == whole.evaluation


def test_a_controller_search_stopped_by_its_callback_resumes(tiger: cehmm.PomdpWorld, tmp_path: Path) -> None:
    path = tmp_path / "search.ckpt"
    whole = cehmm.optimize_controller(tiger, max_iterations=5, **CONTROLLER)
    first = cehmm.optimize_controller(tiger, checkpoint=path, callback=stop_after(1), **CONTROLLER)
    assert first.stop_reason == "callback"
    rest = cehmm.optimize_controller(tiger, checkpoint=path, resume=True, max_iterations=5, **CONTROLLER)
    assert same_tables(rest.policy, whole.policy) and same_history(rest.history, whole.history)


def test_an_exception_in_a_callback_propagates_and_leaves_a_consistent_checkpoint(
    case1: cehmm.TargetTracking, tmp_path: Path
) -> None:
    class Boom(Exception):
        pass

    def boom(it: Iteration) -> None:
        if it["iteration"] == 2:
            raise Boom("at iteration 2")

    path = tmp_path / "run.ckpt"
    with pytest.raises(Boom, match="at iteration 2"):
        cehmm.optimize(case1, checkpoint=path, callback=boom, **CE)
    # The checkpoint holds the run after the iteration the callback saw: it resumes bit for bit.
    rest = cehmm.optimize(case1, checkpoint=path, resume=True, max_iterations=6, **CE)
    whole = cehmm.optimize(case1, max_iterations=6, **CE)
    assert same_tables(rest.policy, whole.policy) and same_history(rest.history, whole.history)
    with pytest.raises(Boom):
        cehmm.optimize_controller(cehmm.PomdpWorld.from_file(TIGER, horizon=100), callback=boom, **CONTROLLER)
    with pytest.raises(Boom):
        cehmm.qlearning(
            cehmm.TargetTracking(**SMALL_GRID),
            iterations=2**20,
            progress=False,
            callback=lambda it: boom({"iteration": 2}),
        )


def test_every_callback_is_closed_however_the_run_ends(case1: cehmm.TargetTracking) -> None:
    class Closing(Callback):
        def __init__(self, answer: Any) -> None:
            self.answer, self.calls, self.closed = answer, 0, 0

        def __call__(self, iteration: Iteration) -> Any:
            self.calls += 1
            if isinstance(self.answer, Exception):
                raise self.answer
            return self.answer

        def close(self) -> None:
            self.closed += 1

    going, stopping = Closing(None), Closing(False)
    result = cehmm.optimize(case1, max_iterations=5, callback=[going, stopping, lambda it: True], **CE)
    assert result.stop_reason == "callback" and result.iterations == 1
    assert (going.calls, stopping.calls, going.closed, stopping.closed) == (1, 1, 1, 1), "every one called and closed"
    raising = Closing(RuntimeError("inside"))
    with pytest.raises(RuntimeError, match="inside"):
        cehmm.optimize(case1, max_iterations=5, callback=raising, **CE)
    assert raising.closed == 1


# -- the built-ins -----------------------------------------------------------------------------


def test_stop_on_no_improvement_fires_where_the_engines_patience_would(case1: cehmm.TargetTracking) -> None:
    by_rule = cehmm.optimize(case1, patience=3, **CE)
    by_callback = cehmm.optimize(case1, patience=1000, callback=StopOnNoImprovement(patience=3), **CE)
    assert (by_rule.stop_reason, by_callback.stop_reason) == ("patience", "callback")
    assert by_callback.iterations == by_rule.iterations
    assert same_tables(by_callback.policy, by_rule.policy)


def test_stop_on_no_improvement_counts_from_the_best_so_far() -> None:
    stop = StopOnNoImprovement(patience=2, key="mean", min_delta=0.5)
    means = [1.0, 2.0, 2.4, 3.0, 2.0, 3.5, 1.0]  # 2.4 and 3.5 gain no more than 0.5
    answers = [stop(Iteration({"iteration": k, "mean": m})) for k, m in enumerate(means)]
    assert answers == [True, True, True, True, True, False, False]
    with pytest.raises(KeyError, match="no 'score'.*iteration, mean"):
        StopOnNoImprovement(patience=1)(Iteration({"iteration": 0, "mean": 1.0}))


def test_save_best_writes_a_policy_file_that_loads(case1: cehmm.TargetTracking, tmp_path: Path) -> None:
    last = SaveBest(tmp_path / "best.json")
    each = SaveBest(str(tmp_path / "best-{iteration}.json"), every=2)
    result = cehmm.optimize(case1, max_iterations=5, callback=[last, each], **CE)
    saved = cehmm.Policy.load(tmp_path / "best.json")
    assert same_tables(saved, result.policy), "the best so far at the end is the result's policy"
    assert saved.provenance == result.policy.provenance and saved.world == case1.to_dict(), "the result's own"
    assert each.saved == [str(tmp_path / "best-1.json"), str(tmp_path / "best-3.json")]
    series = cehmm.Policy.load(each.saved[0])
    assert series.levels == [4] and series.provenance["policy"] == "best so far"
    tiger_best = SaveBest(tmp_path / "controller.json")
    found = cehmm.optimize_controller(
        cehmm.PomdpWorld.from_file(TIGER, horizon=100), max_iterations=3, callback=tiger_best, **CONTROLLER
    )
    assert same_tables(cehmm.Policy.load(tmp_path / "controller.json"), found.policy)


def test_eval_on_env_records_the_best_policy_on_another_world(case1: cehmm.TargetTracking) -> None:
    other = cehmm.TargetTracking(case=1)
    check = EvalOnEnv(other, every=2, episodes=300, seed=5)
    seen: list[Iteration] = []
    result = cehmm.optimize(case1, max_iterations=4, callback=[check, seen.append], **CE)
    assert check.history["iteration"] == [1, 3]
    assert check.evaluations[-1] == result.policy.evaluate(other, episodes=300, seed=5)
    assert check.history["mean"][-1] == check.evaluations[-1].mean
    assert "eval_mean" not in seen[0] and seen[1]["eval_mean"] == check.history["mean"][0]
    with pytest.raises(cehmm.InvalidArgumentError, match="EvalOnEnv on a run that has no policy"):
        cehmm.qlearning(cehmm.TargetTracking(**SMALL_GRID), iterations=2**20, progress=False, callback=EvalOnEnv(other))


def test_bad_callbacks_are_refused_by_name(case1: cehmm.TargetTracking, tmp_path: Path) -> None:
    with pytest.raises(TypeError, match=r"invalid callback: 3 \(expected a callable"):
        cehmm.optimize(case1, callback=3, **CE)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"invalid callbacks\[1\]: 'x'"):
        cehmm.optimize_controller(case1, callback=[print, "x"], **CONTROLLER)  # type: ignore[list-item]
    with pytest.raises(TypeError, match=r"invalid answer of callback .*: 'yes' \(expected True or None"):
        cehmm.optimize(case1, callback=lambda it: "yes", **CE)
    with pytest.raises(cehmm.InvalidArgumentError, match=r"invalid patience: 0 \(expected an integer >= 1\)"):
        StopOnNoImprovement(patience=0)
    with pytest.raises(TypeError, match="invalid patience: '3'"):
        StopOnNoImprovement(patience="3")  # type: ignore[arg-type]
    with pytest.raises(cehmm.InvalidArgumentError, match="invalid min_delta: -1"):
        StopOnNoImprovement(patience=3, min_delta=-1)
    with pytest.raises(TypeError, match="invalid path: 7"):
        SaveBest(7)  # type: ignore[arg-type]
    with pytest.raises(cehmm.InvalidArgumentError, match="invalid every: 0"):
        SaveBest(tmp_path / "p.json", every=0)
    with pytest.raises(cehmm.InvalidArgumentError, match="invalid episodes: 0"):
        EvalOnEnv(case1, episodes=0)
    with pytest.raises(TypeError, match="invalid callbacks: 'ab'"):
        CallbackList("ab")  # type: ignore[arg-type]
    assert StopOnNoImprovement(np.int64(2)).patience == 2


# -- restarts: SaveBest keeps the best of the whole call (issue 45, item 1) ---------------------


def test_save_best_holds_the_best_of_the_whole_call_and_names_never_collide(tmp_path: Path) -> None:
    # Sampled values on a short horizon: the runs end apart, the last one below the first.
    shuttle = cehmm.PomdpWorld.from_file(SHUTTLE, horizon=20)
    best, each, per_run = (
        SaveBest(tmp_path / "best.json"),
        SaveBest(tmp_path / "best_{iteration}.json"),
        SaveBest(tmp_path / "run{run}.json"),
    )
    saved_scores: list[float | None] = []
    result = cehmm.optimize_controller(
        shuttle,
        value="sampled",
        restarts=4,
        seed=1,
        progress=False,
        callback=[best, each, per_run, lambda it: saved_scores.append(best.best_score)],
        search="ce",
    )
    assert result.run_values[-1] < max(result.run_values), "the case: a later run ends worse"
    assert same_tables(cehmm.Policy.load(tmp_path / "best.json"), result.policy), "the file holds the result"
    scores = [s for s in saved_scores if s is not None]
    assert scores == sorted(scores), "a worse run never writes over the file"
    # {iteration} counts on across the runs (TensorBoard's step): one file per iteration.
    iterations = len(saved_scores)
    assert each.saved == [str(tmp_path / f"best_{k}.json") for k in range(iterations)]
    assert per_run.saved[-1] == str(tmp_path / "run3.json") and len(set(per_run.saved)) == 4
    assert sorted(os.listdir(tmp_path)) == sorted(
        ["best.json", *(f"best_{k}.json" for k in range(iterations)), *(f"run{r}.json" for r in range(4))]
    )


def test_save_best_with_restarts_of_the_episode_ce(case1: cehmm.TargetTracking, tmp_path: Path) -> None:
    best, each = SaveBest(tmp_path / "best.json"), SaveBest(tmp_path / "{run}-{iteration}.json", every=2)
    result = cehmm.optimize(case1, restarts=3, max_iterations=3, callback=[best, each], **CE)
    assert same_tables(cehmm.Policy.load(tmp_path / "best.json"), result.policy)
    assert each.saved == [str(tmp_path / name) for name in ["0-1.json", "1-3.json", "1-5.json", "2-7.json"]]
    board = TensorBoard(tmp_path)
    records = [Iteration({"iteration": k, "run": r}) for r, k in [(0, 0), (0, 1), (1, 0), (1, 1), (2, 0)]]
    assert [board.step(it) for it in records] == [0, 1, 2, 3, 4]


def test_save_best_refuses_a_placeholder_in_its_folder(tmp_path: Path) -> None:
    with pytest.raises(cehmm.InvalidArgumentError, match=r"invalid path: .*run\{run\}.*\(expected"):
        SaveBest(tmp_path / "run{run}" / "best.json")


# -- a callback's files: the one rule of outputs, before the first iteration (items 2 and 11) ----


def optimisers(tmp_path: Path) -> dict[str, Any]:
    """Each optimiser as ``f(callback=..., tensorboard_log=..., checkpoint=...)``, short."""
    tiger = cehmm.PomdpWorld.from_file(TIGER, horizon=20)
    return {
        "optimize": lambda **kw: cehmm.optimize(cehmm.TargetTracking(case=1), max_iterations=3, **CE, **kw),
        "optimize_controller": lambda **kw: cehmm.optimize_controller(tiger, max_iterations=2, **CONTROLLER, **kw),
        "run": lambda **kw: cehmm.run("random-search", tiger, samples=20, max_iterations=2, progress=False, **kw),
        "qlearning": lambda **kw: cehmm.QLearner.new(cehmm.TargetTracking(**SMALL_GRID)).train(
            2**20, progress=False, **kw
        ),
    }


@pytest.fixture
def unwritable_folder(tmp_path: Path) -> Path:
    """A folder this process cannot create files in (root writes anywhere but in /sys)."""
    if os.geteuid() != 0:
        folder = tmp_path / "read-only"
        folder.mkdir()
        folder.chmod(0o500)
        return folder
    if not os.path.isdir("/sys") or os.access("/sys", os.W_OK) and _creatable(Path("/sys")):
        pytest.skip("no folder that root cannot write")
    return Path("/sys")


def _creatable(folder: Path) -> bool:
    try:
        (folder / ".cehmm-probe").open("x").close()
    except OSError:
        return False
    (folder / ".cehmm-probe").unlink()
    return True


def test_a_callbacks_files_may_not_be_the_runs_checkpoint(tmp_path: Path) -> None:
    pytest.importorskip("tensorboardX")
    checkpoint = tmp_path / "run.ckpt"
    for name, optimiser in optimisers(tmp_path).items():
        for given in [
            dict(callback=SaveBest(checkpoint)),
            dict(callback=SaveBest(tmp_path / "r{iteration}.ckpt"), checkpoint=tmp_path / "r12.ckpt"),
            dict(tensorboard_log=checkpoint),
            dict(callback=[SaveBest(tmp_path / "a.json"), SaveBest(str(tmp_path / "a.json"))]),
            dict(callback=SaveBest(tmp_path / "b.json"), tensorboard_log=tmp_path / "b.json"),
        ]:
            calls: list[Iteration] = []
            callbacks = given.get("callback", [])
            given = {"checkpoint": checkpoint, **given, "callback": [*np.atleast_1d(callbacks), calls.append]}
            with pytest.raises(cehmm.InvalidArgumentError, match=r"is the file that .* names") as refused:
                optimiser(**given)
            assert not calls, (name, given)
            assert "SaveBest" in str(refused.value) or "tensorboard_log" in str(refused.value), refused.value
            assert os.listdir(tmp_path) == [], (name, given, os.listdir(tmp_path))


def test_outputs_that_cannot_be_written_are_refused_before_the_first_iteration(
    tmp_path: Path, unwritable_folder: Path
) -> None:
    pytest.importorskip("tensorboardX")
    a_file, fifo = tmp_path / "a-file", tmp_path / "fifo"
    a_file.write_text("x")
    os.mkfifo(fifo)
    boards = [a_file, fifo, "/dev/null", a_file / "under-a-file", unwritable_folder / "runs"]
    policies = [tmp_path, fifo, "/dev/null", tmp_path / "missing" / "best.json", unwritable_folder / "best.json"]
    policies += [tmp_path / "{iteration}" / "x.json", unwritable_folder / "best-{iteration}.json"]
    for name, optimiser in optimisers(tmp_path).items():
        for given in [dict(tensorboard_log=b) for b in boards] + [dict(callback=SaveBest(p)) for p in policies[:5]]:
            calls: list[Iteration] = []
            given = {**given, "callback": [given.get("callback", lambda it: None), calls.append]}
            with pytest.raises((cehmm.InvalidArgumentError, OSError), match="tensorboard_log|SaveBest") as refused:
                optimiser(**given)
            assert not calls, (name, given, refused.value)
            assert "invalid" in str(refused.value) and "expected" in str(refused.value), refused.value
    for template in policies[5:]:
        with pytest.raises((cehmm.InvalidArgumentError, OSError), match="SaveBest|path"):
            cehmm.optimize(cehmm.TargetTracking(case=1), max_iterations=3, callback=SaveBest(template), **CE)
    assert sorted(os.listdir(tmp_path)) == ["a-file", "fifo"]


# -- close() and on_result() never lose a result nor an error (item 5) --------------------------


class Failing(Callback):
    """A callback whose call raises ``calling`` (when given) and whose close raises ``closing``."""

    def __init__(self, calling: Exception | None, closing: Exception) -> None:
        self.calling, self.closing, self.closed = calling, closing, 0

    def __call__(self, iteration: Iteration) -> None:
        if self.calling is not None:
            raise self.calling

    def close(self) -> None:
        self.closed += 1
        raise self.closing


def test_a_close_that_raises_loses_neither_the_result_nor_the_callbacks_error(tmp_path: Path) -> None:
    for name, optimiser in optimisers(tmp_path).items():
        failing = Failing(None, OSError("cannot close"))
        with pytest.warns(
            RuntimeWarning, match=r"Failing raised OSError when closed: cannot close.*result is returned"
        ):
            result = optimiser(callback=failing)
        assert result.stop_reason in ("max_iterations", "iterations"), name
        raising, after = Failing(ValueError("inside"), OSError("cannot close")), Failing(None, KeyError("also"))
        with pytest.raises(ValueError, match="inside") as raised:
            optimiser(callback=[raising, after])
        notes = getattr(raised.value, "__notes__", [])
        assert any("cannot close" in n for n in notes) and any("also" in n for n in notes), (name, notes)
        assert (raising.closed, after.closed) == (1, 1)
        assert raised.value.__context__ is None or "cannot close" not in str(raised.value.__context__)


# -- TensorBoard -------------------------------------------------------------------------------


def read_scalars(log_dir: Path) -> dict[str, list[tuple[int, float]]]:
    """Every scalar of the event files in ``log_dir``: tag -> [(step, value)], read from the
    TFRecord framing (length, its CRC, the ``Event`` protobuf, its CRC) with tensorboardX's
    protobuf classes."""
    from tensorboardX.proto.event_pb2 import Event

    scalars: dict[str, list[tuple[int, float]]] = {}
    for path in sorted(glob.glob(str(log_dir / "events.out.tfevents.*"))):
        data = Path(path).read_bytes()
        at = 0
        while at < len(data):
            (length,) = struct.unpack("<Q", data[at : at + 8])
            event = Event.FromString(data[at + 12 : at + 12 + length])
            at += 12 + length + 4
            for value in event.summary.value:
                scalars.setdefault(value.tag, []).append((event.step, value.simple_value))
    return scalars


def test_tensorboard_log_writes_the_history(case1: cehmm.TargetTracking, tmp_path: Path) -> None:
    pytest.importorskip("tensorboardX")
    result = cehmm.optimize(case1, max_iterations=4, tensorboard_log=tmp_path / "ce", **CE)
    scalars = read_scalars(tmp_path / "ce")
    shared = {"mean", "best", "elite_threshold", "elite_mean", "seconds", "successful", "env_steps"}
    assert set(scalars) == shared | {"score", "run"}
    for tag in ["mean", "best", "elite_threshold", "elite_mean", "seconds", "successful"]:
        steps, values = zip(*scalars[tag])
        assert list(steps) == list(result.history["iteration"])
        assert np.array_equal(np.float32(values), np.float32(result.history[tag])), tag
    # The controller search's own fields, and the steps counted on across its restarts.
    tiger = cehmm.PomdpWorld.from_file(TIGER, horizon=100)
    found = cehmm.optimize_controller(tiger, restarts=2, max_iterations=3, tensorboard_log=tmp_path / "c", **CONTROLLER)
    scalars = read_scalars(tmp_path / "c")
    steps, values = zip(*scalars["best_so_far"])
    assert list(steps) == list(range(6)) and np.array_equal(
        np.float32(values), np.float32(found.history["best_so_far"])
    )
    assert [v for _, v in scalars["restart"]] == [0, 0, 0, 1, 1, 1]


def test_tensorboard_logs_what_the_callbacks_before_it_add(case1: cehmm.TargetTracking, tmp_path: Path) -> None:
    pytest.importorskip("tensorboardX")
    check = EvalOnEnv(case1, every=2, episodes=100)
    cehmm.optimize(case1, max_iterations=4, callback=check, tensorboard_log=tmp_path, **CE)
    steps, values = zip(*read_scalars(tmp_path)["eval_mean"])
    assert list(steps) == [1, 3] and np.array_equal(np.float32(values), np.float32(check.history["mean"]))
    board = TensorBoard(tmp_path / "q")
    cehmm.qlearning(cehmm.TargetTracking(**SMALL_GRID), iterations=2**21, progress=False, callback=board)
    assert [s for s, _ in read_scalars(tmp_path / "q")["epsilon"]] == [2**20, 2**21]


def test_tensorboard_without_its_dependency_says_how_to_install_it(
    case1: cehmm.TargetTracking, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "tensorboardX", None)
    with pytest.raises(ImportError, match=r"pip install 'cehmm\[tensorboard\]'"):
        cehmm.optimize(case1, max_iterations=100_000, tensorboard_log=tmp_path, **CE)
    with pytest.raises(ImportError, match=r"pip install 'cehmm\[tensorboard\]'"):
        TensorBoard(tmp_path)
    assert not os.listdir(tmp_path), "refused before the run"


# -- the docs ----------------------------------------------------------------------------------


def test_the_examples_of_the_module_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    shutil.copytree(ROOT / "data", tmp_path / "data")
    globs = {"cehmm": cehmm, **{name: getattr(cehmm.callbacks, name) for name in cehmm.callbacks.__all__}}
    for module in (cehmm.callbacks, cehmm.optimizer, cehmm.controller, cehmm.stepped):
        names = {"PomdpWorld": cehmm.PomdpWorld, "TargetTracking": cehmm.TargetTracking, "run": cehmm.run}
        failed, tried = doctest.testmod(module, extraglobs={**globs, **names}, optionflags=doctest.ELLIPSIS)
        assert tried and not failed, module.__name__
