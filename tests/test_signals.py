"""Signals during long runs: Ctrl-C stops them within an iteration (or a slice of evaluation
episodes), and what the user's own signal handlers raise comes out unchanged."""

from __future__ import annotations

import json
import signal
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

import cehmm

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="SIGALRM timers are POSIX")


class Deadline(Exception):
    """What a user's alarm handler raises."""


@contextmanager
def alarm(seconds: float, exception: type[BaseException]) -> Iterator[None]:
    def handler(signum: int, frame: object) -> None:
        raise exception()

    previous = signal.signal(signal.SIGALRM, handler)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def test_an_exception_from_a_users_handler_propagates_out_of_optimize(case3: cehmm.TargetTracking) -> None:
    start = time.monotonic()
    with alarm(0.3, Deadline), pytest.raises(Deadline):
        cehmm.optimize(case3, levels=[8], samples=500, patience=10**6, max_iterations=10**6, progress=False)
    assert time.monotonic() - start < 20


def test_keyboard_interrupt_in_optimize_returns_the_run_so_far(case3: cehmm.TargetTracking) -> None:
    with alarm(0.3, KeyboardInterrupt):
        result = cehmm.optimize(case3, levels=[8], samples=500, patience=10**6, max_iterations=10**6, progress=False)
    assert result.interrupted and result.stop_reason == "interrupted" and result.iterations >= 1


def test_keyboard_interrupt_stops_a_long_evaluation(case3: cehmm.TargetTracking) -> None:
    policy = cehmm.Policy.uniform(case3, [2])
    start = time.monotonic()
    with alarm(0.3, KeyboardInterrupt), pytest.raises(KeyboardInterrupt):
        policy.evaluate(case3, episodes=50_000_000)
    assert time.monotonic() - start < 30
    # Slices change nothing: the same episodes as one call.
    a = policy.evaluate(case3, episodes=250_000, seed=4)
    assert a.episodes == 250_000 and a == policy.evaluate(case3, episodes=250_000, seed=4, threads=1)


def test_an_exception_from_a_users_handler_propagates_out_of_qlearning() -> None:
    world = cehmm.TargetTracking(
        case=3, width=5, height=5, start_b=[0, 4], start_c=[4, 4], target_rows=[0, 2], target_cell=[2, 2]
    )
    with alarm(0.3, Deadline), pytest.raises(Deadline):
        cehmm.qlearning(world, iterations=10**10, progress=False)


def test_keyboard_interrupt_in_a_controller_search_returns_the_best_so_far() -> None:
    path = Path(__file__).resolve().parents[1] / "data" / "pomdp" / "4x3.95.POMDP"
    world = cehmm.PomdpWorld.from_file(path, horizon=60)
    with alarm(0.3, KeyboardInterrupt):
        result = cehmm.optimize_controller(world, nodes=8, patience=10**6, progress=False)
    assert result.interrupted and result.stop_reason == "interrupted"
    assert result.value == result.history["best_so_far"][-1]
    with alarm(0.3, Deadline), pytest.raises(Deadline):
        cehmm.optimize_controller(world, nodes=8, patience=10**6, progress=False)


def _tables(result: cehmm.OptimizeResult) -> dict:
    """The policy file without its provenance (the tables, levels and world)."""
    return {k: v for k, v in json.loads(result.policy.to_json()).items() if k != "provenance"}


def test_ctrl_c_then_resume_gives_the_uninterrupted_policy(case3: cehmm.TargetTracking, tmp_path: Path) -> None:
    # About half a second on two cores: the alarm comes in the middle.
    settings = dict(levels=[16, 16], samples=2000, rho=0.1, max_iterations=60, eval_episodes=200, progress=False)
    reference = cehmm.optimize(case3, **settings)
    checkpoint = tmp_path / "run.ckpt"
    with alarm(0.1, KeyboardInterrupt):
        first = cehmm.optimize(case3, checkpoint=checkpoint, resume=True, **settings)
    assert first.interrupted and 1 <= first.iterations < 60 and checkpoint.exists()
    resumed = cehmm.optimize(case3, checkpoint=checkpoint, resume=True, **settings)
    assert not resumed.interrupted and resumed.iterations == 60
    assert _tables(resumed) == _tables(reference)
    assert resumed.evaluation == reference.evaluation
    assert list(resumed.history["mean"]) == list(reference.history["mean"])
    with pytest.raises(cehmm.PolicyMismatchError, match="seed"):
        cehmm.optimize(case3, checkpoint=checkpoint, resume=True, **{**settings, "seed": 5})
    with pytest.raises(cehmm.InvalidArgumentError, match="resume"):
        cehmm.optimize(case3, resume=True, **settings)
    with pytest.raises(cehmm.InvalidArgumentError, match="checkpoint_every"):
        cehmm.optimize(case3, checkpoint=checkpoint, checkpoint_every=0.0, **settings)
    checkpoint.write_text("{}")
    with pytest.raises(cehmm.PolicyFormatError, match="not a checkpoint"):
        cehmm.optimize(case3, checkpoint=checkpoint, resume=True, **settings)


SIGTERM_SCRIPT = """
import sys, cehmm
world = cehmm.TargetTracking(case=3)
print("started", flush=True)
cehmm.optimize(world, levels=[16, 16], samples=2000, rho=0.1, max_iterations=60, eval_episodes=200,
               progress=False, checkpoint=sys.argv[1], resume=True)
print("finished", flush=True)
"""


def test_sigterm_saves_the_checkpoint_and_ends_the_process(case3: cehmm.TargetTracking, tmp_path: Path) -> None:
    import subprocess

    checkpoint = tmp_path / "term.ckpt"
    child = subprocess.Popen([sys.executable, "-c", SIGTERM_SCRIPT, str(checkpoint)], stdout=subprocess.PIPE, text=True)
    assert child.stdout is not None
    assert child.stdout.readline() == "started\n"
    time.sleep(0.1)
    child.terminate()
    out, _ = child.communicate(timeout=60)
    assert child.returncode == -signal.SIGTERM, (child.returncode, out)
    assert "finished" not in out and checkpoint.exists()
    settings = dict(levels=[16, 16], samples=2000, rho=0.1, max_iterations=60, eval_episodes=200, progress=False)
    resumed = cehmm.optimize(case3, checkpoint=checkpoint, resume=True, **settings)
    assert _tables(resumed) == _tables(cehmm.optimize(case3, **settings))
