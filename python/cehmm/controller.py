"""The cross-entropy method over deterministic controllers of a tabular world (model §8):
:func:`optimize_controller` and its :class:`ControllerResult`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _core
from .policy import Policy
from .pomdp import PomdpWorld
from .world import core_world

#: The engine's defaults (one home: ``ceworld::ControllerConfig::default()``).
CONTROLLER_DEFAULTS = _core.CONTROLLER_DEFAULTS


@dataclass(frozen=True, repr=False, eq=False)
class ControllerResult:
    """The outcome of :func:`optimize_controller`.

    Attributes:
        policy: the best controller, as a two-level policy ``[nodes, nodes]`` with one-hot
            tables (so :meth:`Policy.evaluate`, :meth:`Policy.evaluate_exact` and
            :meth:`Policy.graph` take it as it is).
        value: its exact value: infinite-horizon when the world's discount is below 1 (to
            ``tolerance``), else at the world's horizon.
        history: one numpy array per statistic, one entry per iteration of every run in order:
            ``restart``, ``iteration`` (int64), ``mean``, ``elite_min``, ``max``, ``best``
            (exact values), ``concentration`` (mean largest probability of the laws' rows: 1
            when every draw is the same controller), ``evaluated`` (controllers evaluated: fewer
            than ``samples`` when the time limit cut the iteration) and ``seconds``.
        stop_reason: why the last run stopped: ``"patience"``, ``"max_iterations"``,
            ``"time_limit"`` or ``"interrupted"`` (Ctrl-C).
        interrupted: whether Ctrl-C stopped it.
        best_iteration: the iteration that drew the best controller, within its run.
        restart: the run that found it.
        run_values: the best value of each run.
        seconds: wall time.
    """

    policy: Policy
    value: float
    history: dict[str, np.ndarray]
    stop_reason: str
    interrupted: bool
    best_iteration: int
    restart: int
    run_values: list[float]
    seconds: float

    def __repr__(self) -> str:
        return (
            f"ControllerResult(value={self.value:.6f}, nodes={self.policy.levels[0]}, "
            f"stop_reason={self.stop_reason!r}, runs={len(self.run_values)}, seconds={self.seconds:.1f})"
        )


def optimize_controller(
    world: PomdpWorld,
    nodes: int = CONTROLLER_DEFAULTS["nodes"],
    *,
    samples: int = CONTROLLER_DEFAULTS["samples"],
    rho: float = CONTROLLER_DEFAULTS["rho"],
    smoothing: float = CONTROLLER_DEFAULTS["smoothing"],
    patience: int = CONTROLLER_DEFAULTS["patience"],
    max_iterations: int | None = None,
    time_limit: float | None = None,
    tolerance: float = CONTROLLER_DEFAULTS["tolerance"],
    seed: int = CONTROLLER_DEFAULTS["seed"],
    threads: int | None = None,
    restarts: int = CONTROLLER_DEFAULTS["restarts"],
    progress: bool = True,
) -> ControllerResult:
    """Searches a deterministic ``nodes``-node controller of a tabular world by the cross-entropy
    method over whole controllers, each ranked by its exact value (model §8).

    Each iteration draws ``samples`` controllers from independent categorical laws (each node's
    action, each node's successor after each observation), computes their exact values, keeps
    the best ``ceil(rho · samples)`` (leaving out ties at the threshold when some controllers
    beat it) and refits the laws (``p := smoothing · frequency + (1 − smoothing) · p``). A run
    stops after ``patience`` iterations without a better controller or a higher elite
    threshold. Where :func:`optimize` learns from sampled episodes of any world, this needs a
    :class:`PomdpWorld` and finds better controllers on the small files that need memory
    (shuttle, 4x3: docs/benchmarks.md). The same seed and settings give the same result bit for
    bit, whatever ``threads``. Ctrl-C stops between iterations and returns the result so far
    with ``interrupted`` set.

    Args:
        world: a :class:`PomdpWorld`.
        nodes: nodes of the controller.
        samples: controllers per iteration.
        rho: selective rate, ``0 < rho < 1``.
        smoothing: ``0 < smoothing <= 1``.
        patience: iterations without progress before a run stops.
        max_iterations: stop a run after this many iterations.
        time_limit: stop after this many seconds (all runs together), checked before each
            controller's evaluation; an iteration it cuts does not refit the laws.
        tolerance: absolute tolerance of each infinite-horizon value.
        seed: seed of every random stream.
        threads: worker threads (default: one per core).
        restarts: independent runs (the first with ``seed``); the best controller of all is
            returned (values are exact, so the choice has no selection bias).
        progress: print a live progress line on stderr.

    Returns:
        a :class:`ControllerResult`.

    Raises:
        TypeError: ``world`` is not a :class:`PomdpWorld`, or an argument has the wrong type.
        InvalidArgumentError: an argument out of its domain; the message names it and its value.

    Example:
        >>> tiger = PomdpWorld.from_file("data/pomdp/tiger.95.POMDP", horizon=100)
        >>> result = optimize_controller(tiger, nodes=5, progress=False)  # doctest: +SKIP
        >>> round(result.value, 2)  # doctest: +SKIP
        19.37
    """
    if not isinstance(world, PomdpWorld):
        raise TypeError(f"invalid world: {world!r} (expected a cehmm.PomdpWorld)")
    raw = _core.optimize_controller(
        core_world(world),
        nodes=nodes,
        samples=samples,
        rho=rho,
        smoothing=smoothing,
        patience=patience,
        max_iterations=max_iterations,
        time_limit=time_limit,
        tolerance=tolerance,
        seed=seed,
        threads=threads,
        restarts=restarts,
        progress=progress,
    )
    return ControllerResult(
        policy=Policy(raw.policy),
        value=raw.value,
        history=dict(raw.history),
        stop_reason=raw.stop_reason,
        interrupted=raw.interrupted,
        best_iteration=raw.best_iteration,
        restart=raw.restart,
        run_values=list(raw.run_values),
        seconds=raw.seconds,
    )
