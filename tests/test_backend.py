"""The backend is a typed protocol (issue 30): ``cehmm.backend``'s ``Backend``, ``Sampler`` and
``Pending`` name what the engine asks (``_core.BACKEND_METHODS``, ``_core.PENDING_METHODS``);
the Ray backend is one; any object that is one (here an in-process backend written in the
test) runs every optimiser and gives the local result, bit for bit."""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import Any

import numpy as np
from worlds import Corridor

import cehmm
from cehmm import _core
from cehmm.backend import Backend, Pending, Sampler
from cehmm.ray_backend import RayBackend, RayPending, RaySampler
from cehmm.world import core_world


def _methods(protocol: type) -> list[str]:
    return [name for name, value in vars(protocol).items() if inspect.isfunction(value) and not name.startswith("_")]


def test_the_protocols_name_what_the_engine_asks():
    assert _methods(Sampler) == list(_core.BACKEND_METHODS)
    assert _methods(Pending) == list(_core.PENDING_METHODS)
    assert _methods(Backend) == ["bind"]


def test_the_ray_backend_is_one():
    assert isinstance(RayBackend(workers=1), Backend)
    for protocol, implementation in ((Sampler, RaySampler), (Pending, RayPending), (Backend, RayBackend)):
        for name in _methods(protocol):
            wanted = list(inspect.signature(getattr(protocol, name)).parameters)
            assert list(inspect.signature(getattr(implementation, name)).parameters) == wanted, name


class Done:
    """An answer already there."""

    def __init__(self, value: np.ndarray) -> None:
        self.value = value

    def wait(self, timeout: float) -> bool:
        return True

    def result(self) -> np.ndarray:
        return self.value

    def cancel(self) -> None:
        pass


class InProcess:
    """A backend that samples in this process, through the engine's worker functions."""

    def __init__(self) -> None:
        self.asked: list[str] = []

    def bind(self, world: Any, options: dict[str, Any]) -> InProcess:
        self.engine = core_world(world, **options)
        return self

    def rewards(self, policy: str, seed: int, purpose: str, iteration: int, first: int, n: int) -> Done:
        self.asked.append("rewards")
        table = _core.Policy.from_json(policy)
        return Done(table.shard_rewards(self.engine, seed, purpose, iteration, first, n, 1))

    def counts(self, policy: str, seed: int, iteration: int, episodes: np.ndarray) -> Done:
        self.asked.append("counts")
        table = _core.Policy.from_json(policy)
        return Done(table.rerun_counts(self.engine, seed, iteration, episodes.tolist(), 1))

    def controller_values(self, controllers: str, seed: int, purpose: str, iteration: int, episodes: int) -> Done:
        self.asked.append("controller_values")
        return Done(_core.controller_values(self.engine, controllers, seed, purpose, iteration, episodes, 1))

    def controller_credit(self, controllers: str, seed: int, purpose: str, iteration: int, episodes: int) -> Done:
        self.asked.append("controller_credit")
        return Done(_core.controller_credit(self.engine, controllers, seed, purpose, iteration, episodes, 1))

    def controller_steps(self, controllers: str, seed: int, purpose: str, iteration: int, episodes: int) -> Done:
        self.asked.append("controller_steps")
        return Done(_core.controller_steps(self.engine, controllers, seed, purpose, iteration, episodes, 1))

    def exact_values(self, controllers: str, tolerance: float) -> Done:
        self.asked.append("exact_values")
        return Done(_core.controller_exact_values(self.engine, controllers, tolerance, 1))


def test_any_backend_runs_every_optimiser_as_here():
    assert isinstance(InProcess(), Backend) and isinstance(InProcess(), Sampler)
    assert isinstance(Done(np.zeros(1)), Pending)
    ce = dict(levels=[2], samples=60, rho=0.2, max_iterations=3, eval_episodes=100, progress=False)
    backend = InProcess()
    here, there = cehmm.optimize(Corridor(), **ce), cehmm.optimize(Corridor(), backend=backend, **ce)
    assert there.policy.to_json() == here.policy.to_json()
    assert {"rewards", "counts"} <= set(backend.asked)

    search = dict(nodes=2, samples=20, episodes=5, max_iterations=2, eval_episodes=100, progress=False)
    backend = InProcess()
    here = cehmm.optimize_controller(Corridor(), **search, search="ce")
    there = cehmm.optimize_controller(Corridor(), backend=backend, **search, search="ce")
    assert there.policy.to_json() == here.policy.to_json()
    assert {"controller_credit", "controller_values"} <= set(backend.asked)

    settings = dict(nodes=2, samples=20, episodes=5, max_iterations=2, eval_episodes=100, progress=False)
    here_run = cehmm.run("random-search", Corridor(), **settings)
    there_run = cehmm.run("random-search", Corridor(), backend=InProcess(), **settings)
    assert there_run.policy.to_json() == here_run.policy.to_json()

    # Memory from every step: the workers send every step back.
    settings = dict(samples=4, episodes=3, memories=20, rounds=2, max_iterations=2, eval_episodes=50)
    backend = InProcess()
    here_run = cehmm.run("model-search", Corridor(), **settings)
    there_run = cehmm.run("model-search", Corridor(), backend=backend, **settings)
    assert there_run.policy.to_json() == here_run.policy.to_json()
    same = ("env_steps", "best", "mean")
    assert [list(there_run.history[k]) for k in same] == [list(here_run.history[k]) for k in same]
    # The explorers' steps and the selection episodes' (kept too): no episode sends only its value.
    assert "controller_steps" in backend.asked and "controller_values" not in backend.asked


def test_exact_values_go_through_the_backend_too():
    tiger = cehmm.PomdpWorld(Path(__file__).parents[1] / "data" / "pomdp" / "tiger.95.POMDP", horizon=100)
    backend = InProcess()
    settings = dict(nodes=2, samples=20, max_iterations=2, progress=False)
    here = cehmm.optimize_controller(tiger, value="exact", **settings)
    there = cehmm.optimize_controller(tiger, value="exact", backend=backend, **settings)
    assert there.policy.to_json() == here.policy.to_json()
    assert "exact_values" in backend.asked
