"""Shared fixtures: small worlds and settings that keep the suite fast on two cores."""

from __future__ import annotations

import os
import signal

import pytest
from hypothesis import HealthCheck, settings

import cehmm

# Hypothesis' example counts: small in CI, many with HYPOTHESIS_PROFILE=long (docs/testing.md).
settings.register_profile("ci", max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("long", max_examples=5000, deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

# A suite started with SIGINT ignored (under nohup, or as a background job of a shell, where
# Python leaves it ignored) runs as one started from a terminal: SIGINT raises KeyboardInterrupt
# here, and the processes the tests start get its default (an ignored signal stays ignored across
# exec, a handler does not), so the tests that send it neither hang nor fail.
if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

#: Settings of a short optimisation (about a millisecond per iteration).
SMALL = dict(samples=200, max_iterations=8, eval_episodes=200, progress=False)


@pytest.fixture
def small() -> dict:
    """A fresh copy of :data:`SMALL`."""
    return dict(SMALL)


@pytest.fixture(scope="session")
def case1() -> cehmm.TargetTracking:
    return cehmm.TargetTracking(case=1)


@pytest.fixture(scope="session")
def case2() -> cehmm.TargetTracking:
    return cehmm.TargetTracking(case=2)


@pytest.fixture(scope="session")
def case3() -> cehmm.TargetTracking:
    return cehmm.TargetTracking(case=3)


@pytest.fixture(scope="session")
def trained(case1: cehmm.TargetTracking) -> cehmm.OptimizeResult:
    """A short case-1 optimisation with two levels (non-uniform tables, known provenance)."""
    return cehmm.optimize(
        case1, levels=[4, 3], seed=7, samples=200, max_iterations=8, eval_episodes=200, progress=False
    )
