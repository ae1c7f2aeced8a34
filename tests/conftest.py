"""Shared fixtures: small worlds and settings that keep the suite fast on two cores."""

from __future__ import annotations

import os
import secrets
import shutil
import signal
import tempfile

# Every Ray a test starts (ray.init, `ray start`, the README's example; this process's and its
# children's), set before anything imports Ray: on loopback only (Ray 2.54 and later bind every
# interface, whatever the node's address, unless told the machine is the whole cluster), behind
# token authentication with a token of this session's (none written to ~/.ray), its files (the
# `ray_current_cluster` that `ray start` writes, which `address="auto"` reads and which makes
# every later `ray.init(num_cpus=...)` join a dead cluster) in a temporary directory of the
# suite's own, removed at its end (tests/test_ray.py checks all three).
RAY_TMPDIR = tempfile.mkdtemp(prefix="cehmm-tests-ray-")
os.environ.update(
    RAY_TMPDIR=RAY_TMPDIR,
    RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER="0",
    RAY_AUTH_MODE="token",
    RAY_AUTH_TOKEN=secrets.token_hex(32),
)

import pytest  # noqa: E402
from hypothesis import HealthCheck, settings  # noqa: E402

import cehmm  # noqa: E402

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


def pytest_configure(config: pytest.Config) -> None:
    # The tests' environments end their own episodes: the default horizon's warning (a user's
    # news, not a failure here) is checked where it is made, in tests/test_gym_in.py.
    config.addinivalue_line("filterwarnings", "ignore::cehmm.gym_adapt.HorizonWarning")


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    """Ray's files of the session go with it (its clusters were shut down with their tests)."""
    shutil.rmtree(RAY_TMPDIR, ignore_errors=True)
