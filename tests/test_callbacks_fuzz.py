"""Property tests of callbacks and their files (Hypothesis, issue 45): lists of callbacks that go on,
stop, raise, answer nonsense or fail in ``on_result``/``close``, ``SaveBest`` and ``tensorboard_log=``
given paths of every kind (new, shared, the checkpoint or a link to it, a series whose names take
the checkpoint's, a directory, a FIFO, ``/dev/null``, a missing folder, a path under a file), with
restarts and a checkpoint or none, on the three optimisers that have a policy. Whatever is drawn:

* a bad set of outputs is refused before the first iteration (no callback called, nothing
  written), by an error that names the output and what was expected, exactly when an oracle
  written apart from the package's rule says the outputs collide or cannot be written;
* a run that starts either returns its result, with every hook's failure a ``RuntimeWarning``,
  or raises the callback's own exception, with the failures of ``close()`` as notes on it;
* every :class:`~cehmm.callbacks.Callback` is given the result once (when there is one) and closed
  once; a ``SaveBest`` file holds the result's policy, a series never writes one name twice, the
  checkpoint is still a checkpoint, ``stop_reason`` is ``"callback"`` when a callback said stop.

Example counts: conftest.py's profiles (``HYPOTHESIS_PROFILE=long`` for the long run of
docs/testing.md)."""

from __future__ import annotations

import glob
import json
import os
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import event, given
from hypothesis import strategies as st

import cehmm
from cehmm.callbacks import Callback, Iteration, SaveBest, StopOnNoImprovement

pytest.importorskip("tensorboardX")

TIGER = Path(__file__).resolve().parents[1] / "data" / "pomdp" / "tiger.95.POMDP"

#: SaveBest's paths by kind: the oracle's key (two outputs with one key are one file; ``None``: a
#: file of its own), and whether the path can be written as a policy file.
FILE_KINDS: dict[str, tuple[str | None, bool]] = {
    "new": (None, True),
    "shared": ("shared", True),
    "checkpoint": ("checkpoint", True),
    "link-to-checkpoint": ("checkpoint", True),
    "board": ("board", True),
    "existing-file": ("a-file", True),
    "series-iteration": (None, True),
    "series-run": (None, True),
    "series-checkpoint": ("series of the checkpoint", True),
    "directory": (None, False),
    "fifo": (None, False),
    "devnull": (None, False),
    "missing-folder": (None, False),
    "under-a-file": (None, False),
}
#: tensorboard_log's paths by kind, as FILE_KINDS.
BOARD_KINDS: dict[str, tuple[str | None, bool]] = {
    "new": ("board", True),
    "existing-folder": (None, True),
    "missing-parents": (None, True),
    "shared": ("shared", True),
    "checkpoint": ("checkpoint", True),
    "a-file": ("a-file", False),
    "fifo": (None, False),
    "devnull": (None, False),
    "under-a-file": (None, False),
}

ANSWERS = st.sampled_from([None, True, False, "raise", "nonsense"])
SCRIPTED = st.builds(
    lambda answers, fail_result, fail_close: ("scripted", answers, fail_result, fail_close),
    st.lists(st.one_of(st.just(None), ANSWERS), min_size=1, max_size=4),
    st.booleans(),
    st.booleans(),
)
CALLBACKS = st.lists(
    st.one_of(
        SCRIPTED,
        st.tuples(st.just("save"), st.sampled_from(sorted(FILE_KINDS)), st.integers(1, 3)),
        st.tuples(st.just("patience"), st.integers(1, 3)),
        st.just(("plain",)),
    ),
    max_size=4,
)


class Boom(Exception):
    """What a scripted callback raises."""


class Scripted(Callback):
    """Answers its script, one entry per call (the last repeated); ``"raise"`` raises :class:`Boom`,
    ``"nonsense"`` answers a string. Its ``on_result`` and ``close`` fail when told to."""

    def __init__(self, answers: list[Any], fail_result: bool, fail_close: bool) -> None:
        self.answers, self.fail_result, self.fail_close = answers, fail_result, fail_close
        self.calls = self.results = self.closed = 0
        self.stopped = False

    def __call__(self, iteration: Iteration) -> Any:
        answer = self.answers[min(self.calls, len(self.answers) - 1)]
        self.calls += 1
        if answer == "raise":
            raise Boom(f"scripted at iteration {iteration['iteration']}")
        self.stopped |= answer is False
        return "yes" if answer == "nonsense" else answer

    def on_result(self, result: Any) -> None:
        self.results += 1
        if self.fail_result:
            raise OSError("on_result fails")

    def close(self) -> None:
        self.closed += 1
        if self.fail_close:
            raise OSError("close fails")


def _place(folder: Path) -> dict[str, Path]:
    """The files the kinds name, made in ``folder``."""
    (folder / "a-file").write_text("not a policy")
    os.mkfifo(folder / "fifo")
    return {
        "checkpoint": folder / "ck-1.json",
        "shared": folder / "shared.json",
        "board": folder / "board",
        "a-file": folder / "a-file",
        "fifo": folder / "fifo",
    }


def _save_path(kind: str, n: int, folder: Path, places: dict[str, Path]) -> str:
    if kind == "link-to-checkpoint":
        link = folder / f"link{n}.json"
        link.symlink_to(places["checkpoint"].name)
        return str(link)
    return str(
        {
            "new": folder / f"new{n}.json",
            "shared": places["shared"],
            "checkpoint": places["checkpoint"],
            "board": places["board"],
            "existing-file": places["a-file"],
            "series-iteration": folder / f"s{n}-{{iteration}}.json",
            "series-run": folder / f"r{n}-{{run}}-{{iteration}}.json",
            "series-checkpoint": folder / "ck-{iteration}.json",
            "directory": folder,
            "fifo": places["fifo"],
            "devnull": "/dev/null",
            "missing-folder": folder / "missing" / "x.json",
            "under-a-file": places["a-file"] / "x.json",
        }[kind]
    )


def _board_path(kind: str, folder: Path, places: dict[str, Path]) -> str:
    return str(
        {
            "new": places["board"],
            "existing-folder": folder,
            "missing-parents": folder / "made" / "in" / "board",
            "shared": places["shared"],
            "checkpoint": places["checkpoint"],
            "a-file": places["a-file"],
            "fifo": places["fifo"],
            "devnull": "/dev/null",
            "under-a-file": places["a-file"] / "board",
        }[kind]
    )


def _expect_refusal(saves: list[str], board: str | None, checkpointed: bool) -> bool:
    """The oracle: whether the outputs collide or one cannot be written (from the kinds alone)."""
    kinds = [FILE_KINDS[k] for k in saves] + ([] if board is None else [BOARD_KINDS[board]])
    if not all(writable for _, writable in kinds):
        return True
    keys = [key for key, _ in kinds if key is not None] + (["checkpoint"] if checkpointed else [])
    # A series takes the checkpoint's name among its own (ck-{iteration}.json and ck-1.json).
    return len(keys) != len(set(keys)) or {"series of the checkpoint", "checkpoint"} <= set(keys)


def _same(a: Any, b: Any) -> bool:
    """Tables equal bit for bit, nested in dicts and lists as :attr:`cehmm.Policy.tables` are."""
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    return bool(np.array_equal(a, b))


def _optimiser(name: str, restarts: int) -> Any:
    tiger = cehmm.PomdpWorld.from_file(TIGER, horizon=20)
    if name == "optimize":
        world = cehmm.TargetTracking(case=1)
        settings = dict(levels=[4], samples=100, max_iterations=3, eval_episodes=50, restarts=restarts)
        return lambda **kw: cehmm.optimize(world, progress=False, **settings, **kw)
    if name == "optimize_controller":
        return lambda **kw: cehmm.optimize_controller(
            tiger, nodes=2, samples=100, max_iterations=2, restarts=restarts, progress=False, **kw
        )
    return lambda **kw: cehmm.run("random-search", tiger, samples=20, max_iterations=3, progress=False, **kw)


@given(
    optimiser=st.sampled_from(["optimize", "optimize_controller", "run"]),
    restarts=st.integers(1, 3),
    drawn=CALLBACKS,
    board=st.one_of(st.none(), st.sampled_from(sorted(BOARD_KINDS))),
    checkpointed=st.booleans(),
)
def test_callbacks_and_their_files(
    optimiser: str, restarts: int, drawn: list[tuple[Any, ...]], board: str | None, checkpointed: bool
) -> None:
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        places = _place(folder)
        calls: list[Iteration] = []
        callbacks: list[Any] = []
        for n, spec in enumerate(drawn):
            if spec[0] == "scripted":
                callbacks.append(Scripted(*spec[1:]))
            elif spec[0] == "save":
                callbacks.append(SaveBest(_save_path(spec[1], n, folder, places), every=spec[2]))
            elif spec[0] == "patience":
                callbacks.append(StopOnNoImprovement(patience=spec[1]))
            else:
                callbacks.append(lambda it: None)
        made = sorted(os.listdir(folder))
        callbacks.append(calls.append)
        saves = [spec[1] for spec in drawn if spec[0] == "save"]
        checkpoint = places["checkpoint"] if checkpointed else None
        log = None if board is None else _board_path(board, folder, places)
        scripted = [c for c in callbacks if isinstance(c, Scripted)]
        refused = _expect_refusal(saves, board, checkpointed)
        with warnings.catch_warnings(record=True) as warned:
            warnings.simplefilter("always")
            try:
                result = _optimiser(optimiser, restarts)(callback=callbacks, tensorboard_log=log, checkpoint=checkpoint)
            except (cehmm.InvalidArgumentError, OSError) as e:
                assert refused, f"refused, though the oracle says the outputs are fine: {e}"
                assert not calls, "refused only after the first iteration"
                message = str(e)
                assert "invalid" in message and "expected" in message, message
                assert any(n in message for n in ("SaveBest path", "tensorboard_log", "checkpoint")), message
                assert sorted(os.listdir(folder)) == made, "nothing written"
                assert not any(c.closed or c.results for c in scripted)
                event("refused before the run")
                return
            except (Boom, TypeError) as e:
                assert not refused, f"not refused: {saves}, {board}, {checkpointed}"
                assert isinstance(e, Boom) or "invalid answer of callback" in str(e), e
                notes = getattr(e, "__notes__", [])
                assert len(notes) == sum(c.fail_close for c in scripted), notes
                assert all(c.closed == 1 and c.results == 0 for c in scripted)
                assert not [w for w in warned if issubclass(w.category, RuntimeWarning)]
                event("the callback's error, closes noted" if notes else "the callback's error")
                return
        assert not refused, f"not refused: {saves}, {board}, {checkpointed}"
        runtime = [str(w.message) for w in warned if issubclass(w.category, RuntimeWarning)]
        assert len(runtime) == sum(c.fail_result + c.fail_close for c in scripted), runtime
        assert all("the run's result is returned" in w for w in runtime), runtime
        event(f"a result, {'with warnings' if runtime else 'no warning'}, stop {result.stop_reason}")
        assert all(c.closed == 1 and c.results == 1 for c in scripted)
        if any(c.stopped for c in scripted):
            assert result.stop_reason == "callback"
        elif result.stop_reason == "callback":
            assert any(isinstance(c, StopOnNoImprovement) for c in callbacks)
        for save in (c for c in callbacks if isinstance(c, SaveBest)):
            if "{" in save.path:
                assert len(set(save.saved)) == len(save.saved), save.saved
                assert all(cehmm.Policy.load(path) for path in save.saved)
            else:
                assert _same(cehmm.Policy.load(save.path).tables, result.policy.tables), save.path
        if checkpoint is not None:
            assert json.loads(checkpoint.read_text())["format"].endswith("-checkpoint")
        if log is not None:
            assert glob.glob(os.path.join(log, "events.out.tfevents.*"))
