"""The Ray backend: an optimisation's episodes and controllers sampled on a Ray cluster.

The optimisers run on the driver, unchanged (selection, refits, stopping rules, history and
checkpoints); each iteration they ask this backend for the rewards of episodes
``first..first + n`` (or the values of a batch of controllers), which it cuts into one shard
per worker, each a Ray task running the Rust engine on the world sent once to the cluster. The
elite's counts come back the same way: each task re-runs its share of the elite from the
episodes' random streams and counts them there (model §9). Only tables (as policy documents),
controllers, episode numbers, rewards, values and counts cross the network; episode ``k``
draws from the same stream wherever it runs, so the result is the local backend's, bit for bit,
whatever the number of workers.

Workers run the user's world code: anyone who can submit to the cluster can run code on it
(README, "Running on a cluster").
"""

from __future__ import annotations

import json
import uuid
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from . import _core
from .world import core_world

BACKENDS = ("local", "ray")

#: How often a task killed with its worker process is run again (a task is a pure function of
#: its arguments: a retry gives the same answer).
RETRIES = 3


def _ray() -> Any:
    try:
        import ray
    except ImportError as e:
        raise ImportError("backend='ray' needs Ray: pip install 'cehmm[ray]'") from e
    return ray


def sampled_world(
    local: Any,
    world: Any,
    options: dict[str, Any],
    backend: str | RayBackend = "local",
    workers: int | None = None,
    address: str | None = None,
) -> Any:
    """Where the episodes of ``local`` (``core_world(world, **options)``) are sampled: ``local``
    itself for the local backend, ``world`` sampled on Ray (a ``_core.RemoteWorld``) for
    ``backend="ray"`` or a :class:`RayBackend`."""
    if backend == "local":
        for name, value in (("workers", workers), ("address", address)):
            if value is not None:
                raise _core.InvalidArgumentError(
                    f"invalid {name}: {value!r} with backend='local' (expected backend='ray')"
                )
        return local
    if backend == "ray":
        backend = RayBackend(workers=workers, address=address)
    elif not isinstance(backend, RayBackend):
        raise _core.InvalidArgumentError(
            f"invalid backend: {backend!r} (expected one of {list(BACKENDS)} or a RayBackend)"
        )
    elif workers is not None or address is not None:
        raise _core.InvalidArgumentError(
            "invalid workers/address: given with a RayBackend (expected them in RayBackend(...))"
        )
    return _core.RemoteWorld(backend.bind(world, options), local)


class RayBackend:
    """Where the episodes run: a Ray cluster, joined (or started on this machine) on first use.

    Args:
        workers: shards per batch of episodes or controllers (default: the cluster's CPUs
            divided by ``threads``).
        address: the cluster to join (``"auto"``, ``"ray://host:10001"``); ``None``: the Ray
            this process already joined, else a new local one of ``workers`` CPUs, bound to
            loopback, without a dashboard.
        threads: engine threads (and Ray CPUs) per task.
        retries: runs of a task again after its worker process died.
    """

    def __init__(
        self, workers: int | None = None, address: str | None = None, threads: int = 1, retries: int = RETRIES
    ) -> None:
        for name, value, least in (("workers", workers, 1), ("threads", threads, 1), ("retries", retries, 0)):
            if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < least):
                raise _core.InvalidArgumentError(f"invalid {name}: {value!r} (expected an int >= {least})")
        self.address, self.threads, self.retries = address, threads, retries
        self._workers = workers

    @property
    def workers(self) -> int:
        """Shards per batch: ``workers``, else the cluster's CPUs over ``threads`` (joining it)."""
        if self._workers is None:
            ray = self.ray()
            self._workers = max(1, int(ray.cluster_resources().get("CPU", 1)) // self.threads)
        return self._workers

    def ray(self) -> Any:
        """The ``ray`` module, this process joined to the cluster."""
        ray = _ray()
        if not ray.is_initialized():
            if self.address is None:
                ray.init(
                    address="local",
                    num_cpus=self._workers * self.threads if self._workers else None,
                    include_dashboard=False,
                    _node_ip_address="127.0.0.1",
                )
            else:
                ray.init(address=self.address)
        return ray

    def bind(self, world: Any, options: dict[str, Any]) -> Sampler:
        """The sampler of ``world`` (sent to the cluster once, with ``options``)."""
        return Sampler(self, world, options)


class Sampler:
    """The backend of one world: what ``_core.RemoteWorld`` asks (see crates/cehmm-py/src/remote.rs)."""

    def __init__(self, backend: RayBackend, world: Any, options: dict[str, Any]) -> None:
        ray = backend.ray()
        self.backend = backend
        # Nested in a list, the reference travels as itself: a worker fetches the world once.
        self._world = [ray.put((world, options))]
        self._key = uuid.uuid4().hex
        self._task = ray.remote(_shard).options(num_cpus=backend.threads, max_retries=backend.retries)

    def _submit(self, kind: str, policy: str, shards: Sequence[tuple[Any, ...]], combine: Combine) -> Pending:
        ray = self.backend.ray()
        # Put once, read by every shard (controllers travel in their shards instead).
        text = ray.put(policy) if policy else policy
        threads = self.backend.threads
        refs = [self._task.remote(self._key, self._world, kind, text, threads, *shard) for shard in shards]
        return Pending(ray, refs, combine)

    def rewards(self, policy: str, seed: int, purpose: str, iteration: int, first: int, n: int) -> Pending:
        """Rewards of episodes ``first..first + n`` of ``(seed, purpose, iteration)`` under ``policy``."""
        shards = [(seed, purpose, iteration, first + a, b - a) for a, b in _cuts(n, self.backend.workers)]
        return self._submit("rewards", policy, shards, np.concatenate)

    def counts(self, policy: str, seed: int, iteration: int, episodes: npt.NDArray[np.uint64]) -> Pending:
        """The sampled counts of ``episodes`` of iteration ``iteration`` under ``policy``."""
        shards = [(seed, iteration, episodes[a:b].tolist()) for a, b in _cuts(len(episodes), self.backend.workers)]
        return self._submit("counts", policy, shards, _sum_counts)

    def controller_values(self, controllers: str, seed: int, purpose: str, iteration: int, episodes: int) -> Pending:
        """Values of episodes ``0..episodes`` of each controller, controller by controller."""
        laws = json.loads(controllers)
        shards = [
            (json.dumps(laws[a:b]), seed, purpose, iteration, episodes)
            for a, b in _cuts(len(laws), self.backend.workers)
        ]
        return self._submit("controllers", "", shards, np.concatenate)

    def exact_values(self, controllers: str, tolerance: float) -> Pending:
        """Exact values of each controller (a tabular world), to ``tolerance``."""
        laws = json.loads(controllers)
        shards = [(json.dumps(laws[a:b]), tolerance) for a, b in _cuts(len(laws), self.backend.workers)]
        return self._submit("exact", "", shards, np.concatenate)


Combine = Callable[[list[Any]], Any]


class Pending:
    """The answers of a batch of tasks, waited for in slices; ``cancel`` leaves none running."""

    def __init__(self, ray: Any, refs: list[Any], combine: Combine) -> None:
        self._ray, self._refs, self._combine = ray, refs, combine

    def wait(self, timeout: float) -> bool:
        """Whether every task has answered (or one failed), after at most ``timeout`` seconds."""
        ready, _ = self._ray.wait(self._refs, num_returns=len(self._refs), timeout=timeout, fetch_local=False)
        return len(ready) == len(self._refs)

    def result(self) -> Any:
        """The combined answers; a task's exception raised as itself, with the worker's traceback."""
        try:
            return self._combine(self._ray.get(self._refs))
        except BaseException:
            self.cancel()
            raise

    def cancel(self) -> None:
        """Stops every task still running (their worker processes are ended)."""
        for ref in self._refs:
            self._ray.cancel(ref, force=True)


def _cuts(n: int, parts: int) -> list[tuple[int, int]]:
    """``0..n`` cut into at most ``parts`` contiguous ranges of sizes differing by at most 1."""
    parts = max(1, min(parts, n))
    size, extra = divmod(n, parts)
    bounds = [k * size + min(k, extra) for k in range(parts + 1)]
    return [(a, b) for a, b in zip(bounds, bounds[1:]) if b > a]


def _sum_counts(parts: list[npt.NDArray[np.uint32]]) -> npt.NDArray[np.uint32]:
    # Integer sums: exact in any order (the engine checked that they fit in 32 bits).
    return np.sum(parts, axis=0, dtype=np.uint64).astype(np.uint32)


#: The engine worlds of this worker process, by sampler.
_WORLDS: dict[str, Any] = {}


def _shard(key: str, world: list[Any], kind: str, policy: str, threads: int, *args: Any) -> Any:
    """One task on a worker: a shard of rewards, counts, or controllers' sampled or exact values."""
    engine = _WORLDS.get(key)
    if engine is None:
        import ray

        user_world, options = ray.get(world[0])
        engine = _WORLDS[key] = core_world(user_world, **options)
        if len(_WORLDS) > 8:
            _WORLDS.pop(next(iter(_WORLDS)))
    if kind == "controllers":
        controllers, seed, purpose, iteration, episodes = args
        return _core.controller_values(engine, controllers, seed, purpose, iteration, episodes, threads)
    if kind == "exact":
        controllers, tolerance = args
        return _core.controller_exact_values(engine, controllers, tolerance, threads)
    table = _core.Policy.from_json(policy)
    if kind == "rewards":
        seed, purpose, iteration, first, n = args
        return table.shard_rewards(engine, seed, purpose, iteration, first, n, threads)
    seed, iteration, episodes = args
    return table.rerun_counts(engine, seed, iteration, episodes, threads)
