"""Shared fixtures: small worlds and settings that keep the suite fast on two cores."""

from __future__ import annotations

import pytest

import cehmm

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
