"""The cross-entropy optimiser (model §3): :func:`optimize` and its :class:`OptimizeResult`."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Union

import numpy as np

from . import _core
from ._driven import driven
from .backend import Backend
from .callbacks import CallbackLike
from .ending import Ending
from .outside import Score
from .policy import Policy
from .ray_backend import sampled_world
from .results import Evaluation
from .world import core_world

#: What :func:`optimize` starts from.
Init = Union[None, str, Policy]

#: The engine's defaults (one home: ``ceworld::CeConfig::default()``).
CE_DEFAULTS = _core.CE_DEFAULTS
DEFAULT_LEVELS = tuple(_core.DEFAULT_LEVELS)
#: The names ``init`` accepts besides a :class:`Policy` (the engine's ``ceworld::Init``).
INIT_CHOICES = tuple(_core.INIT_CHOICES)
#: The names ``memory_update`` accepts (the engine's ``ceworld::MemoryUpdate``).
MEMORY_UPDATES = tuple(_core.MEMORY_UPDATES)


@dataclass(frozen=True, repr=False, eq=False)
class OptimizeResult(Ending):
    """The outcome of :func:`optimize`.

    Attributes:
        policy: the policy that drew the best iteration (highest mean reward), with its provenance.
        last_policy: the policy after the last update.
        history: one numpy array per statistic, one entry per iteration: ``iteration`` (int64),
            ``mean``, ``best``, ``elite_threshold``, ``elite_mean``, ``seconds`` (float64,
            seconds since the start), ``successful`` (bool: the mean beat every earlier one) and
            ``env_steps`` (int64: the world's steps learning had taken by the iteration's end,
            every run together).
        evaluation: :attr:`policy` evaluated on ``eval_episodes`` fresh episodes (unbiased,
            unlike the best iteration's mean).
        stop_reason: ``"patience"``, ``"max_iterations"``, ``"time_limit"``,
            ``"max_env_steps"``, ``"target"``, ``"callback"`` (``callback=`` returned ``False``)
            or ``"interrupted"`` (Ctrl-C).
        interrupted: whether Ctrl-C stopped it.
        best_iteration: index of the best iteration.
        iterations: number of iterations run.
        seconds: wall time, evaluation included.
        env_steps: the world's steps learning took (every run and session together).
        eval_env_steps: the world's steps of :attr:`evaluation`, counted apart.

    Example:
        >>> result = optimize(TargetTracking(case=1), levels=[4], samples=200, max_iterations=3, progress=False)
        >>> result.stop_reason, result.iterations, result.policy.levels
        ('max_iterations', 3, [4])
        >>> sorted(result.history), result.evaluation.episodes
        (['best', 'elite_mean', 'elite_threshold', 'env_steps', 'iteration', 'mean', 'seconds', 'successful'], 10000)
        >>> result.best_mean == float(result.history["mean"].max())
        True
    """

    policy: Policy
    last_policy: Policy
    history: dict[str, np.ndarray]
    evaluation: Evaluation
    best_iteration: int

    @property
    def iterations(self) -> int:
        """Number of iterations run."""
        return len(self.history["iteration"])

    def plot(self, x: str = "iteration") -> Any:
        """Its learning curve (:func:`cehmm.plots.learning_curve`): a matplotlib figure."""
        from .plots import learning_curve

        return learning_curve(self, x=x)

    @property
    def best_mean(self) -> float:
        """Mean reward of the best iteration (biased upwards; see :attr:`evaluation`)."""
        return float(self.history["mean"][self.best_iteration])

    def __repr__(self) -> str:
        e = self.evaluation
        return (
            f"OptimizeResult(stop_reason={self.stop_reason!r}, iterations={self.iterations}, "
            f"best_iteration={self.best_iteration} (mean {self.best_mean:.2f}), "
            f"evaluation={e.mean:.2f} ± {e.std_error:.2f} over {e.episodes} episodes, "
            f"levels={self.policy.levels}, seconds={self.seconds:.1f})"
        )


def optimize(
    world: Any,
    levels: Sequence[int] | None = None,
    samples: int = CE_DEFAULTS["samples"],
    rho: float = CE_DEFAULTS["rho"],
    smoothing: float = CE_DEFAULTS["smoothing"],
    decision_smoothing: float | None = None,
    patience: int = CE_DEFAULTS["patience"],
    max_iterations: int | None = None,
    time_limit: float | None = None,
    max_env_steps: int | None = None,
    target: float | None = None,
    seed: int = CE_DEFAULTS["seed"],
    threads: int | None = None,
    progress: bool = True,
    eval_episodes: int = CE_DEFAULTS["eval_episodes"],
    init: Init = None,
    memory_update: str = CE_DEFAULTS["memory_update"],
    restarts: int = CE_DEFAULTS["restarts"],
    checkpoint: str | os.PathLike[str] | None = None,
    checkpoint_every: float = CE_DEFAULTS["checkpoint_every"],
    resume: bool = False,
    score: Score | None = None,
    discount: float | None = None,
    horizon: int | None = None,
    backend: str | Backend = "local",
    workers: int | None = None,
    address: str | None = None,
    callback: CallbackLike = None,
    tensorboard_log: str | os.PathLike[str] | None = None,
) -> OptimizeResult:
    """Optimises an HHMM policy for ``world`` by Rubinstein's cross-entropy method (model §3).

    Each iteration draws ``samples`` episodes, keeps the best ``ceil(rho · samples)`` and refits
    every table to them (``h := smoothing · new + (1 − smoothing) · h``). The same seed and
    settings give the same result bit for bit, whatever ``threads``. Ctrl-C stops within
    a step of a world written in Python (between iterations of one run by the engine) and returns
    the result so far with ``interrupted`` set (no exception; the iteration it cut is dropped, the
    best policy evaluated for at most half a second); before the first iteration has ended, or a
    second time, it raises ``KeyboardInterrupt``.

    Args:
        world: the world, e.g. ``TargetTracking(case=3)``; or a world written in Python, a
            Gymnasium environment, an environment id or a factory (see :class:`PythonWorld`).
        levels: memory sizes per level, bottom first (default ``[16, 16]``, or the levels of
            ``init`` when it is a :class:`Policy`): ``[16]`` is memoryless, ``[16, 16]`` an IO-HMM.
        samples: episodes per iteration ``N``.
        rho: selective rate, ``0 < rho < 1``.
        smoothing: ``0 < smoothing <= 1``; 1 is the paper's basic CE.
        decision_smoothing: the smoothing of the decision table ``h0`` alone (default:
            ``smoothing``). Smaller lets the memory take shape before the decisions settle: on
            problems whose optimum needs memory (shuttle, 4x3) the decisions otherwise lock onto
            the best memoryless policy within a few iterations.
        patience: stop after this many unsuccessful iterations in a row (the paper's weak
            criterion is 100, its strong one 500).
        max_iterations: stop after this many iterations.
        time_limit: stop after this many seconds (checked between iterations), the final
            evaluation (and with ``restarts`` each run's score) included: the iterations stop
            early by what those episodes would take (as the iterations' ran; at most half the
            limit), and an evaluation that does not fit is cut at the limit, with fewer episodes
            (``evaluation.episodes``).
        max_env_steps: stop once learning has taken this many of the world's steps (SB3's
            ``total_timesteps``; every run and session together, the final evaluation's counted
            apart in ``eval_env_steps``): the iteration that reaches it is cut after the batch of
            about 256 episodes that does (its elite is of the episodes run), and the result's
            ``stop_reason`` is ``"max_env_steps"``. The count is the same for any thread or
            worker count.
        target: stop once an iteration's mean reward reaches this value.
        seed: seed of every random stream.
        threads: worker threads (default: one per core).
        progress: print a live progress line on the process's stderr (file descriptor 2), at most
            ten updates a second.
        eval_episodes: fresh episodes used to evaluate the best policy.
        init: ``None`` or ``"uniform"`` (uniform tables), ``"random"`` (random tables drawn from
            ``seed``), ``"clock"`` (a memory that counts the steps, so that ``h0`` learns a
            time-indexed plan; two equal levels such as ``[100, 100]``) or a :class:`Policy`.
        memory_update: ``"sampled"`` (count the memory states that were drawn: the paper) or
            ``"forward-backward"`` (count their posterior expectation given each elite episode's
            observations and decisions; at most 2 levels, and needs ``init="random"`` to break
            the symmetry of uniform tables).
        restarts: independent runs (the first with ``seed``, the others with seeds derived from
            it); the one whose policy scores best on ``eval_episodes`` selection episodes is
            returned, and evaluated on other, fresh episodes. ``time_limit`` covers them all.
        checkpoint: a file where the whole state of the run (tables, iteration, history, best
            so far, finished restarts) is saved every ``checkpoint_every`` seconds and whenever
            the run stops (the end, Ctrl-C), through a temporary file renamed over it.
        checkpoint_every: seconds between two checkpoints.
        resume: continue from ``checkpoint`` when that file exists (else start afresh). With
            the same world and settings (stopping rules, ``time_limit``, ``max_env_steps`` and
            ``threads`` may differ), the final policy is the one an uninterrupted run gives, bit for bit.
            With a checkpoint, a SIGTERM (a scheduler's) that finds its default action stops the
            run like Ctrl-C, saves the checkpoint, then ends the process as SIGTERM asks (status
            143 / -15): rerunning the same call with ``resume=True`` continues it.
        score: for a world written in Python, an episode's value from its
            ``(observations, decisions, rewards)`` (default: the sum of the rewards).
        discount: for a world written in Python, the discount of the default score.
        horizon: for a world written in Python, the most steps of an episode (default: its own).
        backend: ``"local"`` (this process's threads), ``"ray"`` (shards of every iteration's
            episodes sampled on a Ray cluster, the same result bit for bit; needs
            ``memory_update="sampled"``) or a :class:`~cehmm.RayBackend` (any :class:`cehmm.backend.Backend`).
        workers: with ``backend="ray"``: shards per iteration (default: the cluster's CPUs).
        address: with ``backend="ray"``: the cluster to join (default: the one this process
            joined, else a new local one).
        callback: called after every iteration with its record (a :class:`cehmm.callbacks.Iteration`:
            a dict of the history's scalars for that iteration, and the best policy so far on
            demand); returning ``False`` stops the run (``stop_reason`` ``"callback"``; with
            ``restarts``, no later run starts; a checkpoint is saved and resumes as at any stop).
            A list of callbacks calls each in turn; an exception a callback raises stops the run
            (its checkpoint saved) and propagates. See :mod:`cehmm.callbacks` for the built-ins.
        tensorboard_log: a folder where every iteration's scalars are written as a TensorBoard
            event file (:class:`cehmm.callbacks.TensorBoard`; needs ``pip install 'cehmm[tensorboard]'``).

    Returns:
        an :class:`OptimizeResult`.

    Raises:
        TypeError: an argument of the wrong type (``callback`` not a callable or a list of them).
        ImportError: ``tensorboard_log`` without tensorboardX installed.
        InvalidArgumentError: an argument out of its domain; the message names it and its value.
        PolicyMismatchError: ``init`` does not fit ``world``, or ``checkpoint`` was made with
            another world or other settings (the message names the first that differs).
        PolicyFormatError: ``checkpoint`` is not a valid checkpoint file.

    Example:
        >>> world = TargetTracking(case=1)
        >>> result = optimize(world, levels=[4], samples=200, max_iterations=5, progress=False)
        >>> result.iterations, len(result.history["mean"])
        (5, 5)
        >>> stopped = optimize(world, levels=[4], samples=200, progress=False,
        ...                    callback=lambda it: it["iteration"] < 2)
        >>> stopped.stop_reason, stopped.iterations
        ('callback', 3)
    """
    options = {k: v for k, v in (("score", score), ("discount", discount), ("horizon", horizon)) if v is not None}
    with driven(callback, tensorboard_log, checkpoint) as run:
        local = core_world(world, **options)
        sampled = sampled_world(local, world, options, backend, workers, address)
        raw = _core.optimize(
            sampled,
            _initial(local, levels, init, seed)._core,
            dict(
                samples=samples,
                rho=rho,
                smoothing=smoothing,
                decision_smoothing=decision_smoothing,
                patience=patience,
                max_iterations=max_iterations,
                time_limit=time_limit,
                max_env_steps=max_env_steps,
                target=target,
                seed=seed,
                threads=threads,
                eval_episodes=eval_episodes,
                memory_update=memory_update,
                restarts=restarts,
            ),
            progress=progress,
            checkpoint=checkpoint,
            checkpoint_every=checkpoint_every,
            resume=resume,
            callback=run.hook,
        )
        return run.ended(OptimizeResult._from_core(raw))


def _initial(world: Any, levels: Sequence[int] | None, init: Init, seed: int) -> Policy:
    if isinstance(init, Policy):
        if levels is not None and list(levels) != init.levels:
            raise _core.InvalidArgumentError(
                f"invalid levels: {levels!r} (expected None or the levels of init, {init.levels})"
            )
        return init
    kind = "uniform" if init is None else init
    if not isinstance(kind, str):
        raise TypeError(f"invalid init: {init!r} (expected None, one of {', '.join(INIT_CHOICES)} or a cehmm.Policy)")
    return Policy(_core.Policy.start(core_world(world), DEFAULT_LEVELS if levels is None else levels, kind, seed))
