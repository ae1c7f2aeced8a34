"""Signals during long runs: Ctrl-C stops them within an iteration (or a slice of evaluation
episodes), and what the user's own signal handlers raise comes out unchanged."""

from __future__ import annotations

import signal
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager

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
