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

The world travels as pickled bytes, unpickled by each worker (once per run): what it unpickles
is its own, numpy arrays included (an object Ray stores itself comes back with read-only arrays,
which an environment that resets its state in place cannot write). Joining a cluster given by
``address`` first checks that its port answers within :data:`CONNECT_TIMEOUT` seconds, and a
run asking more CPUs per task (``threads``) than any node has is refused before it is sent.
A task's exception is raised on the driver as itself, the worker's traceback (without Ray's
colour codes) its ``__cause__``.

Workers run the user's world code: anyone who can submit to the cluster can run code on it
(README, "Running on a cluster").
"""

from __future__ import annotations

import json
import os
import pickle
import re
import socket
import threading
import uuid
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from . import _core
from .backend import Backend
from .world import core_world

BACKENDS = ("local", "ray")

#: How often a task killed with its worker process is run again (a task is a pure function of
#: its arguments: a retry gives the same answer).
RETRIES = 3

#: The most runs again of a task Ray takes (its ``max_retries`` is a C ``int``).
MAX_RETRIES = 2**31 - 1

#: How long the port of a cluster given by ``address`` may take to answer (seconds): an
#: unreachable cluster is refused within this time instead of Ray's own minutes of retries.
CONNECT_TIMEOUT = 5.0

#: The shapes of ``address`` (Ray's own defaults: the head's GCS on 6379, the Ray client on 10001).
ADDRESS_FORMS = "'auto', 'local', 'HOST:PORT' (a head's GCS) or 'ray://HOST[:PORT]' (Ray client, port 10001)"

#: Ray's client port, where ``ray://HOST`` names none.
CLIENT_PORT = 10001

# A host name or IPv4 address, or an IPv6 address in brackets; then a port of 1 to 5 digits.
_ENDPOINT = re.compile(
    r"(?:\[(?P<ipv6>[0-9A-Fa-f:.]+)\]|(?P<host>[A-Za-z0-9](?:[A-Za-z0-9._-]*[A-Za-z0-9])?))(?::(?P<port>[0-9]{1,5}))?"
)

# Ray's colour codes in its exceptions' texts (colorama's: ESC [ ... m).
_ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


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
    backend: str | Backend = "local",
    workers: int | None = None,
    address: str | None = None,
) -> Any:
    """Where the episodes of ``local`` (``core_world(world, **options)``) are sampled: ``local``
    itself for the local backend, ``world`` sampled on Ray (a ``_core.RemoteWorld``) for
    ``backend="ray"``, or by ``backend`` itself (a :class:`RayBackend` or any
    :class:`cehmm.backend.Backend`)."""

    def refuse_given(why: str) -> None:
        for name, value in (("workers", workers), ("address", address)):
            if value is not None:
                raise _core.InvalidArgumentError(f"invalid {name}: {value!r} {why}")

    if isinstance(backend, Backend):
        refuse_given(f"with a {type(backend).__name__} (expected it in the backend's own settings)")
        return _core.RemoteWorld(backend.bind(world, options), local)
    if not isinstance(backend, str):
        raise TypeError(
            f"invalid backend: {backend!r} (expected one of {list(BACKENDS)}, a RayBackend or a cehmm.backend.Backend)"
        )
    if backend == "local":
        refuse_given("with backend='local' (expected backend='ray')")
        return local
    if backend != "ray":
        raise _core.InvalidArgumentError(
            f"invalid backend: {backend!r} (expected one of {list(BACKENDS)} or a RayBackend)"
        )
    backend = RayBackend(workers=workers, address=address)
    return _core.RemoteWorld(backend.bind(world, options), local)


class RayBackend:
    """Where the episodes run: a Ray cluster, joined (or started on this machine) on first use.

    Args:
        workers: shards per batch of episodes or controllers (default: the cluster's CPUs
            divided by ``threads``).
        address: the cluster to join (``"auto"``, ``"HOST:PORT"`` of its head,
            ``"ray://HOST:10001"``, or ``"local"`` for a new one on this machine); ``None``: the
            Ray this process already joined, else a new local one of ``workers × threads`` CPUs
            (at most this machine's), bound to loopback (Ray < 2.54; Ray 2.59 and later listen
            on every interface behind token authentication: README), without a dashboard.
        threads: engine threads (and Ray CPUs) per task: at most the CPUs of the cluster's
            largest node.
        retries: runs of a task again after its worker process died.

    Raises:
        TypeError: an argument of the wrong type (numpy integers are taken for ints).
        InvalidArgumentError: an argument out of its domain, an ``address`` of none of the
            shapes above; on first use, a cluster that does not answer within
            :data:`CONNECT_TIMEOUT` seconds, or ``threads`` more than any of its nodes has.

    Example:
        Nothing is started until a run uses it (``pip install 'cehmm[ray]'``):

        >>> backend = RayBackend(workers=4, threads=1)
        >>> backend.workers, backend.retries
        (4, 3)
        >>> world = cehmm.TargetTracking(case=1)
        >>> result = cehmm.optimize(world, levels=[4], backend=backend)  # doctest: +SKIP
        >>> RayBackend(address="ray://")
        Traceback (most recent call last):
        ...
        cehmm.InvalidArgumentError: invalid address: 'ray://' (expected 'auto', 'local', ...)
    """

    def __init__(
        self, workers: int | None = None, address: str | None = None, threads: int = 1, retries: int = RETRIES
    ) -> None:
        self._workers = None if workers is None else _count("workers", workers, 1)
        self.threads = _count("threads", threads, 1)
        self.retries = _count("retries", retries, 0, MAX_RETRIES)
        _endpoint(address)
        self.address = address

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
                # At most this machine's CPUs (more would only start more worker processes than
                # it can run: shards beyond them wait their turn, with the same answers).
                cpus = _machine_cpus()
                ray.init(
                    address="local",
                    num_cpus=min(self._workers * self.threads, cpus) if self._workers else None,
                    include_dashboard=False,
                    _node_ip_address="127.0.0.1",
                )
            else:
                _check_answers(self.address)
                try:
                    ray.init(address=self.address)
                except (ConnectionError, TimeoutError, ValueError) as e:
                    raise _core.InvalidArgumentError(
                        f"invalid address: {self.address!r} (Ray could not join it: {_plain(str(e))})"
                    ) from e
        return ray

    def bind(self, world: Any, options: dict[str, Any]) -> RaySampler:
        """The sampler of ``world`` (sent to the cluster once, with ``options``)."""
        return RaySampler(self, world, options)

    def check_fits(self, ray: Any) -> None:
        """Refuses ``threads`` more than the CPUs of the cluster's largest node: Ray would hold
        such a task for ever, waiting for a node that can run it."""
        nodes = [node for node in ray.nodes() if node.get("Alive", True)]
        largest = max((float(node.get("Resources", {}).get("CPU", 0.0)) for node in nodes), default=0.0)
        if self.threads > largest:
            where = f"the Ray cluster at {self.address!r}" if self.address else "this process's Ray cluster"
            raise _core.InvalidArgumentError(
                f"invalid threads: {self.threads} (a task takes {self.threads} CPUs on one node, and the largest "
                f"node of {where} has {largest:g} CPUs: expected threads <= {largest:g})"
            )


def _count(name: str, value: Any, least: int, most: int | None = None) -> int:
    """``value`` as an int from ``least`` (to ``most``), or the error naming it."""
    expected = f"an int >= {least}" if most is None else f"an int from {least} to {most}"
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"invalid {name}: {value!r} (expected {expected})")
    if value < least or (most is not None and value > most):
        raise _core.InvalidArgumentError(f"invalid {name}: {value!r} (expected {expected})")
    return int(value)


def _machine_cpus() -> int:
    """The CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def _endpoint(address: Any) -> tuple[str, int] | None:
    """The host and port ``address`` names (``None`` for ``None``, ``"auto"`` and ``"local"``),
    or the error naming it."""
    if address is None:
        return None
    if not isinstance(address, str):
        raise TypeError(f"invalid address: {address!r} (expected a str: {ADDRESS_FORMS}, or None)")
    if address in ("auto", "local"):
        return None
    client = address.startswith("ray://")
    found = _ENDPOINT.fullmatch(address[len("ray://") :] if client else address)
    port = int(found["port"]) if found and found["port"] else (CLIENT_PORT if client else None)
    if not found or port is None or not 1 <= port <= 65535:
        raise _core.InvalidArgumentError(f"invalid address: {address!r} (expected {ADDRESS_FORMS})")
    return found["ipv6"] or found["host"], port


def _dialled(address: str) -> tuple[str, int] | None:
    """Where Ray connects for ``address``: the client's host and port as given; a head's GCS
    as Ray resolves it ("auto" from the environment, loopback names to this node's address);
    ``None`` for a new local cluster."""
    if address == "local" or address.startswith("ray://"):
        return _endpoint(address)
    try:
        from ray._private.services import canonicalize_bootstrap_address
    except ImportError:  # pragma: no cover - Ray's internals moved: the address as given
        return _endpoint(address)
    try:
        resolved = canonicalize_bootstrap_address(address)
    except (ConnectionError, ValueError) as e:  # "auto" without a cluster to find
        raise _core.InvalidArgumentError(f"invalid address: {address!r} ({_plain(str(e))})") from e
    if resolved is None:
        return None
    host, _, port = resolved.rpartition(":")
    return host.strip("[]"), int(port)


def _check_answers(address: str, timeout: float = CONNECT_TIMEOUT) -> None:
    """Refuses ``address`` unless a TCP connection to the port Ray would use opens within
    ``timeout`` seconds (name lookup included): Ray itself retries for minutes."""
    endpoint = _dialled(address)
    if endpoint is None:
        return
    host, port = endpoint
    failed: list[str] = []

    def connect() -> None:
        try:
            socket.create_connection((host, port), timeout=timeout).close()
        except OSError as e:
            failed.append(e.strerror or str(e) or type(e).__name__)
        else:
            failed.append("")

    # A thread of its own: a name lookup has no timeout of its own.
    attempt = threading.Thread(target=connect, name="cehmm-connect", daemon=True)
    attempt.start()
    attempt.join(timeout)
    why = failed[0] if failed else f"no answer within {timeout:g} s"
    if why:
        shown = f"[{host}]" if ":" in host else host
        raise _core.InvalidArgumentError(
            f"invalid address: {address!r} (nothing answers at {shown}:{port}, where Ray connects for it: {why}; "
            f"expected the address of a running Ray cluster: {ADDRESS_FORMS})"
        )


def _plain(text: str) -> str:
    """``text`` without terminal colour codes."""
    return _ANSI.sub("", text)


class RaySampler:
    """The episodes of one world on Ray: a :class:`cehmm.backend.Sampler`."""

    def __init__(self, backend: RayBackend, world: Any, options: dict[str, Any]) -> None:
        ray = backend.ray()
        backend.check_fits(ray)
        self.backend = backend
        # Pickled here (cloudpickle: a class of the driver's script travels by value), unpickled
        # by each worker into arrays of its own; nested in a list, the reference travels as
        # itself: a worker fetches the world once.
        self._world = [ray.put(ray.cloudpickle.dumps((world, options)))]
        self._key = uuid.uuid4().hex
        self._task = ray.remote(_shard).options(num_cpus=backend.threads, max_retries=backend.retries)

    def _submit(self, kind: str, policy: str, shards: Sequence[tuple[Any, ...]], combine: Combine) -> RayPending:
        ray = self.backend.ray()
        # Put once, read by every shard (controllers travel in their shards instead).
        text = ray.put(policy) if policy else policy
        threads = self.backend.threads
        refs = [self._task.remote(self._key, self._world, kind, text, threads, *shard) for shard in shards]
        return RayPending(ray, refs, combine)

    def rewards(self, policy: str, seed: int, purpose: str, iteration: int, first: int, n: int) -> RayPending:
        """Rewards of episodes ``first..first + n`` of ``(seed, purpose, iteration)`` under ``policy``."""
        shards = [(seed, purpose, iteration, first + a, b - a) for a, b in _cuts(n, self.backend.workers)]
        return self._submit("rewards", policy, shards, _with_steps)

    def counts(self, policy: str, seed: int, iteration: int, episodes: npt.NDArray[np.uint64]) -> RayPending:
        """The sampled counts of ``episodes`` of iteration ``iteration`` under ``policy``."""
        shards = [(seed, iteration, episodes[a:b].tolist()) for a, b in _cuts(len(episodes), self.backend.workers)]
        return self._submit("counts", policy, shards, _sum_counts)

    def controller_values(self, controllers: str, seed: int, purpose: str, iteration: int, episodes: int) -> RayPending:
        """Values of episodes ``0..episodes`` of each controller, controller by controller."""
        return self._controllers("controllers", controllers, seed, purpose, iteration, episodes)

    def controller_credit(self, controllers: str, seed: int, purpose: str, iteration: int, episodes: int) -> RayPending:
        """Values and credit within episodes of each controller, controller by controller."""
        return self._controllers("credit", controllers, seed, purpose, iteration, episodes)

    def controller_steps(self, controllers: str, seed: int, purpose: str, iteration: int, episodes: int) -> RayPending:
        """Values and every step of each episode, episode by episode (records of any length,
        concatenated in order)."""
        return self._controllers("steps", controllers, seed, purpose, iteration, episodes)

    def _controllers(
        self, kind: str, controllers: str, seed: int, purpose: str, iteration: int, episodes: int
    ) -> RayPending:
        """Shards of contiguous controllers, their answers concatenated in order (their steps
        summed)."""
        laws = json.loads(controllers)
        shards = [
            (json.dumps(laws[a:b]), seed, purpose, iteration, episodes)
            for a, b in _cuts(len(laws), self.backend.workers)
        ]
        return self._submit(kind, "", shards, _with_steps)

    def exact_values(self, controllers: str, tolerance: float) -> RayPending:
        """Exact values of each controller (a tabular world), to ``tolerance``."""
        laws = json.loads(controllers)
        shards = [(json.dumps(laws[a:b]), tolerance) for a, b in _cuts(len(laws), self.backend.workers)]
        return self._submit("exact", "", shards, np.concatenate)


Combine = Callable[[list[Any]], Any]


class RayPending:
    """The answers of a batch of tasks (a :class:`cehmm.backend.Pending`), waited for in slices;
    ``cancel`` leaves none running."""

    def __init__(self, ray: Any, refs: list[Any], combine: Combine) -> None:
        self._ray, self._refs, self._combine = ray, refs, combine

    def wait(self, timeout: float) -> bool:
        """Whether every task has answered (or one failed), after at most ``timeout`` seconds."""
        ready, _ = self._ray.wait(self._refs, num_returns=len(self._refs), timeout=timeout, fetch_local=False)
        return len(ready) == len(self._refs)

    def result(self) -> Any:
        """The combined answers; a task's exception raised as itself, the worker's traceback its
        ``__cause__`` (a :class:`RemoteTraceback`)."""
        try:
            return self._combine(self._ray.get(self._refs))
        except self._ray.exceptions.RayTaskError as error:
            self.cancel()
            cause = getattr(error, "cause", None)
            if not isinstance(cause, BaseException):
                raise
            raise cause from RemoteTraceback(_plain(str(error)))
        except BaseException:
            self.cancel()
            raise

    def cancel(self) -> None:
        """Stops every task still running (their worker processes are ended). Only those not
        done: Ray 2.60's driver aborts its process (``Check failed: ... Tried to complete task
        that was not pending``, in its task manager) when a task it force-cancels completes at
        the same moment, as the other shards of a batch do when all raise one error at once."""
        _, running = self._ray.wait(self._refs, num_returns=len(self._refs), timeout=0, fetch_local=False)
        for ref in running:
            self._ray.cancel(ref, force=True)


class RemoteTraceback(Exception):
    """Where a task's exception was raised: the worker's traceback, as text (the ``__cause__`` of
    the exception raised on the driver, as ``concurrent.futures`` does for its processes)."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


def _cuts(n: int, parts: int) -> list[tuple[int, int]]:
    """``0..n`` cut into at most ``parts`` contiguous ranges of sizes differing by at most 1."""
    parts = max(1, min(parts, n))
    size, extra = divmod(n, parts)
    bounds = [k * size + min(k, extra) for k in range(parts + 1)]
    return [(a, b) for a, b in zip(bounds, bounds[1:]) if b > a]


def _with_steps(parts: list[npt.NDArray[np.float64]]) -> npt.NDArray[np.float64]:
    """Shards' answers of episodes, each ending with the world's steps it took: their numbers
    concatenated in order, then the steps summed (whole numbers: exact in any order)."""
    steps = sum(float(part[-1]) for part in parts)
    return np.concatenate([part[:-1] for part in parts] + [np.array([steps])])


def _sum_counts(parts: list[npt.NDArray[np.uint32]]) -> npt.NDArray[np.uint32]:
    # Integer sums: exact in any order (the engine checked that they fit in 32 bits).
    return np.sum(parts, axis=0, dtype=np.uint64).astype(np.uint32)


#: The engine's function of each kind of controllers' shard.
_CONTROLLER_RUNS = {"controllers": "controller_values", "credit": "controller_credit", "steps": "controller_steps"}

#: The engine worlds of this worker process, by sampler.
_WORLDS: dict[str, Any] = {}


def _shard(key: str, world: list[Any], kind: str, policy: str, threads: int, *args: Any) -> Any:
    """One task on a worker: a shard of rewards, counts, or controllers' sampled or exact values."""
    engine = _WORLDS.get(key)
    if engine is None:
        import ray

        # Unpickled here, not by Ray: the world's arrays are its own, writable.
        user_world, options = pickle.loads(ray.get(world[0]))
        engine = _WORLDS[key] = core_world(user_world, **options)
        if len(_WORLDS) > 8:
            _WORLDS.pop(next(iter(_WORLDS)))
    if kind in _CONTROLLER_RUNS:
        run = getattr(_core, _CONTROLLER_RUNS[kind])
        controllers, seed, purpose, iteration, episodes = args
        return run(engine, controllers, seed, purpose, iteration, episodes, threads)
    if kind == "exact":
        controllers, tolerance = args
        return _core.controller_exact_values(engine, controllers, tolerance, threads)
    table = _core.Policy.from_json(policy)
    if kind == "rewards":
        seed, purpose, iteration, first, n = args
        return table.shard_rewards(engine, seed, purpose, iteration, first, n, threads)
    seed, iteration, episodes = args
    return table.rerun_counts(engine, seed, iteration, episodes, threads)
