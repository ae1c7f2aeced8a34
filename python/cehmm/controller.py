"""The cross-entropy method over deterministic controllers of any world, valued exactly on a
tabular world or from sampled episodes on any (model §8): :func:`optimize_controller` and its
:class:`ControllerResult`."""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import _core
from ._driven import driven
from .backend import Backend
from .callbacks import CallbackLike
from .ending import Ending
from .optimizer import CE_DEFAULTS
from .outside import Score
from .policy import Policy
from .ray_backend import sampled_world
from .results import Evaluation
from .world import core_world

#: The engine's defaults (one home: ``ceworld::ControllerConfig::default()``).
CONTROLLER_DEFAULTS = _core.CONTROLLER_DEFAULTS


@dataclass(frozen=True, repr=False, eq=False)
class ControllerResult(Ending):
    """The outcome of :func:`optimize_controller`.

    Attributes:
        policy: the best controller, as a two-level policy with one-hot tables (so
            :meth:`Policy.evaluate`, :meth:`Policy.evaluate_exact` and :meth:`Policy.graph`
            take it as it is): ``[nodes, nodes]`` for Moore decisions, ``[pairs, nodes]`` for
            Mealy decisions, the lower memory the (decision, next node) pairs the machine takes
            (docs/model.md §8); its ``levels[-1]`` are the nodes reached.
        value: its value. Exact (``kind == "exact"``): infinite-horizon when the world's
            discount is below 1 (to ``tolerance``), else at the world's horizon. Sampled: the
            mean of ``evaluation``, on fresh episodes it was not chosen on.
        kind: ``"exact"`` or ``"sampled"``.
        evaluation: sampled values: the controller on ``eval_episodes`` fresh episodes (the
            same as ``policy.evaluate(eval_episodes, seed)``); ``None`` on exact values.
        history: one numpy array per statistic, one entry per iteration of every run in order,
            the fields shared with :class:`OptimizeResult`'s history meaning the same there:
            ``restart``, ``iteration`` (int64), ``mean``, ``best``, ``elite_threshold`` (the
            smallest value kept in the elite), ``elite_mean`` (the iteration's values: exact,
            or means over its ``episodes`` episodes), ``successful`` (bool: a better controller
            or a higher elite threshold, which resets the patience count), ``best_so_far`` (the
            best value of the run so far: exact, or on the selection episodes),
            ``concentration`` (mean largest probability of the laws' rows: 1 when every draw is
            the same controller), ``evaluated`` (controllers evaluated: fewer than ``samples``
            when the time limit cut the iteration), ``episodes`` (int64, sampled values: the
            world's episodes the iteration ran, selection included: what it cost, like
            ``seconds``; 0 on exact values), ``injected`` (bool: the laws were mixed
            with the uniform law after this iteration), ``grown`` (bool: the laws grew a node
            after this iteration), ``widened`` (bool: the memoryless stage ended after this
            iteration), ``seconds`` and ``env_steps`` (int64, sampled values: the world's steps
            learning had taken by the iteration's end, every run together; 0 on exact values).
            The model search's are :class:`cehmm.RunResult`'s: ``iteration``, ``mean`` (its
            explorers'), ``best`` and ``best_so_far`` (both the best so far on the selection
            episodes), ``elite_threshold``
            and ``elite_mean`` (of the memories ranked on the model), ``successful`` (the best so
            far replaced), ``seconds`` and ``env_steps``.
        stop_reason: why the last run stopped: ``"patience"``, ``"max_iterations"``,
            ``"time_limit"``, ``"max_env_steps"``, ``"target"``, ``"callback"`` (``callback=``
            returned ``False``) or ``"interrupted"`` (Ctrl-C).
        interrupted: whether Ctrl-C stopped it.
        best_iteration: the iteration that drew the best controller, within its run (the model
            search: the last that replaced its best so far).
        restart: the run that found it.
        run_values: the best value of each run (exact, or on the selection episodes).
        start: the model start on a discounted tabular world (``model_nodes``): the controller
            built from the world's point-based values, then improved node by node (docs/model.md
            §8), as ``{"built", "value", "nodes", "blind", "kept"}``: its exact value as built,
            once improved, its nodes, the best blind policy's exact value and whether it beat
            that (the search then started around it); ``None`` where none was built.
        seconds: wall time.
        env_steps: sampled values: the world's steps learning took (selection included).
        eval_env_steps: sampled values: the world's steps of :attr:`evaluation`.

    Example:
        >>> tiger = PomdpWorld.from_file("data/pomdp/tiger.95.POMDP", horizon=100)
        >>> result = optimize_controller(tiger, nodes=5, max_iterations=2, progress=False)
        >>> result.kind, round(result.value, 2), result.evaluation
        ('exact', 19.37, None)
        >>> result.policy.levels, result.stop_reason, len(result.run_values)
        ([5, 5], 'max_iterations', 1)
    """

    policy: Policy
    value: float
    kind: str
    evaluation: Evaluation | None
    history: dict[str, np.ndarray]
    best_iteration: int
    restart: int
    run_values: list[float]
    start: dict[str, Any] | None

    def plot(self, x: str = "iteration") -> Any:
        """Its learning curve (:func:`cehmm.plots.learning_curve`): a matplotlib figure."""
        from .plots import learning_curve

        return learning_curve(self, x=x)

    def __repr__(self) -> str:
        return (
            f"ControllerResult(value={self.value:.6f} ({self.kind}), nodes={self.policy.levels[-1]}, "
            f"stop_reason={self.stop_reason!r}, runs={len(self.run_values)}, seconds={self.seconds:.1f})"
        )


def optimize_controller(
    world: Any,
    nodes: int | None = None,
    *,
    value: str | None = None,
    search: str | None = None,
    episodes: int | None = None,
    samples: int | None = None,
    rho: float | None = None,
    smoothing: float | None = None,
    patience: int | None = None,
    max_iterations: int | None = None,
    target: float | None = None,
    time_limit: float | None = None,
    max_env_steps: int | None = None,
    tolerance: float | None = None,
    seed: int = CONTROLLER_DEFAULTS["seed"],
    threads: int | None = None,
    restarts: int | None = None,
    candidates: int | None = None,
    select_episodes: int | None = None,
    eval_episodes: int = CONTROLLER_DEFAULTS["eval_episodes"],
    injection: float | None = None,
    injections: int | None = None,
    growths: int | None = None,
    model_nodes: int | None = None,
    template: str | None = None,
    template_weight: float = CONTROLLER_DEFAULTS["template_weight"],
    decisions: str | None = None,
    memoryless_patience: int | None = None,
    memory: str | None = None,
    registers: int | None = None,
    register_size: int | None = None,
    credit: str | None = None,
    progress: bool = True,
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
) -> ControllerResult:
    """Searches a deterministic controller of ``world``: by the cross-entropy method over whole
    controllers (``search="ce"``, model §8), or by the model search, which learns a memory from
    every step it takes (``search="model"``, model §10).

    Unless ``search`` says otherwise, the search is ``"model"`` on sampled values (the default of
    every world but a :class:`PomdpWorld`) where the world's value is the sum of its steps' rewards
    (a world written in Python or a Gymnasium environment without a ``score``, a :class:`PomdpWorld`
    with ``value="sampled"``), and ``"ce"`` elsewhere (exact values, a world scored as a whole such
    as the paper's :class:`TargetTracking`). The model search is ``cehmm.run("model-search", world,
    ...)``: each iteration a few explorers run a few episodes, every step taken is kept, candidate
    memories are ranked and their decisions planned on the model those steps give, and the best
    plans are confirmed on the iteration's selection episodes; the best so far is replaced only by a
    plan that beats it there by more than the noise. At 50,000 steps of POPGym's memory games it
    reaches at least RecurrentPPO's value where the CE over controllers stays at the best memoryless
    policy's (docs/memory-benchmark.md). It takes the settings below it shares with the CE over
    controllers, meaning the same there (``nodes``, ``registers``, ``template``,
    ``template_weight``, ``samples``: its explorers, ``episodes``: theirs, ``rho``, ``smoothing``,
    ``select_episodes``, ``patience``, ``max_iterations``, ``target``, ``time_limit``,
    ``max_env_steps``, ``seed``, ``threads``, ``eval_episodes``), with its own defaults
    (``cehmm.stepped.OPTIMISERS["model-search"]``, where its other settings are: use
    :func:`cehmm.run` for them); a setting of the CE over controllers alone is refused by name.

    The CE over controllers: each iteration draws ``samples`` controllers from independent
    categorical laws (each node's decision, each node's successor after each observation), values
    them, keeps the best ``ceil(rho · samples)`` (leaving out ties at the threshold when some
    controllers beat it) and refits the laws (``p := smoothing · frequency + (1 − smoothing) · p``).
    A run stops after ``patience`` iterations without a better controller or a higher elite
    threshold.

    On a :class:`PomdpWorld` the values are exact by default. On every other world (the
    engine's, a world written in Python, a Gymnasium environment, an id, a factory or a vector
    environment: whatever :func:`optimize` takes), and on a :class:`PomdpWorld` with
    ``value="sampled"``, each controller's value is the mean of ``episodes`` episodes shared by
    every controller of the iteration (common random numbers: new ones each iteration). The
    iteration's best ``candidates`` controllers are then scored again on ``select_episodes``
    fixed selection episodes, the best so far is the best there, and the controller returned is
    valued on ``eval_episodes`` fresh episodes (its ``evaluation``): the maximum of noisy
    estimates is not what is reported. Where :func:`optimize` learns memory only slowly from
    sampled episodes, a controller holds an observation as long as it pays (docs/benchmarks.md).
    The same seed and settings give the same result bit for bit, whatever ``threads``. Ctrl-C
    stops the search and returns the result so far with ``interrupted`` set, as for
    :func:`optimize`.

    Args:
        world: any world :func:`optimize` takes.
        nodes: nodes of the controller (where no model start is kept: see ``model_nodes``;
            default 8 with ``search="ce"``; with ``"model"`` 16, a power of ``registers``).
        value: ``"exact"`` (a :class:`PomdpWorld` only; its default) or ``"sampled"`` (the
            default of every other world).
        search: ``"ce"`` (the CE over controllers) or ``"model"`` (the model search: on
            sampled values of a world that gives its steps' rewards only, and their default).
        episodes: sampled values: episodes per controller and iteration (default 20; the model
            search: 4 per explorer).
        samples: controllers per iteration (default 2000 on exact values, 200 on sampled:
            ``cehmm.controller.CONTROLLER_DEFAULTS`` and its ``"sampled"`` entry; the model
            search: 16 explorers).
        rho: selective rate, ``0 < rho < 1`` (default 0.02 on exact values, 0.05 on sampled;
            the model search's rounds on the model: 0.05).
        smoothing: ``0 < smoothing <= 1`` (default 0.1 on exact values, 0.25 on sampled: with
            credit within episodes the decisions' refits are sure enough for larger steps; the
            model search: 0.5).
        patience: iterations without progress (default 50; the model search: 20) before a run
            stops (or, with ``injections`` left, escapes).
        max_iterations: stop a run after this many iterations.
        target: stop once the best value so far reaches this.
        time_limit: stop after this many seconds (all runs together), checked before each
            controller's evaluation on exact values here, between groups of about 1024
            episodes on sampled values here, before each iteration on a backend; an iteration it
            cuts does not refit the laws. On sampled values it holds the returned controller's
            evaluation too: the iterations stop early by what ``eval_episodes`` would take (as
            their own episodes ran; at most half the limit), and an evaluation that does not fit
            is cut at the limit, with fewer episodes (``evaluation.episodes``).
        max_env_steps: sampled values: stop once learning has taken this many of the world's
            steps (selection episodes included; every run and session together; the
            evaluation's counted apart in ``eval_env_steps``): an iteration values no more
            controllers than the steps left cover once its selection's are kept (foreseen from
            the mean length of its episodes), so the count passes the budget by one batch of
            the world at most, or stops short of it where the steps left no longer cover a
            selection; ``stop_reason`` is ``"max_env_steps"``. Refused on exact values (no step
            is taken).
        tolerance: absolute tolerance of each infinite-horizon value (default 1e-6), and the least gain that
            counts as progress.
        seed: seed of every random stream.
        threads: worker threads (default: one per core).
        restarts: independent runs (default 0, see below; the first with ``seed``); the best controller of all is
            returned (exact values, or the best on the selection episodes). 0 (the default):
            runs follow one another until ``time_limit`` or ``target`` (one run without a time
            limit).
        candidates: sampled values: controllers of each iteration (default 4) scored on the selection
            episodes.
        select_episodes: sampled values: the selection episodes (default 200; the model search: 10 a
            confirmed plan, each iteration's own).
        eval_episodes: sampled values: the fresh episodes of ``evaluation``.
        injection: the weight of the uniform law mixed into every law at an escape (default 0.2).
        injections: escapes per run (default 0): when patience runs out, mix the uniform law in and go on
            (0: stop).
        growths: escapes by growth per run (default 0), once the injections are spent: when patience runs
            out, start the laws again around the best controller with one node more (the new
            node a copy of the node it enters most) and go on; the policy returned may have up
            to ``nodes + growths`` nodes.
        model_nodes: on a discounted tabular world (a ``PomdpWorld``, valued here or on a
            backend), the most nodes of the controller built from the world's model (point-based
            values over the beliefs met on the way, made into a controller: docs/model.md §8).
            Where it beats every blind policy it is kept: the search then has its nodes
            (instead of ``nodes``), the laws start around it (its choices at
            ``template_weight``) and the first iteration values it, so the result is never
            worse. 0: no model start (default 64).
        template: where there is no model start, the memory the laws start from:
            ``"uniform"``, ``"hold"`` (a latch: every node but the start node stays where it
            is), ``"clock"`` (node ``q`` moves on to ``q + 1``), ``"mixed"`` (both) or
            ``"window"`` (the last observations: node ``q`` moves to ``(q · Y + y) mod nodes``,
            so ``Y^k`` nodes hold the last ``k``); the
            search keeps of it what pays (default ``"uniform"`` on exact values, ``"mixed"`` on
            sampled: measured in docs/memory-benchmark.md; the model search: ``"uniform"``).
        template_weight: the template's weight in the first successor laws (the model start's
            in every first law), ``0 <= w < 1``.
        decisions: what a decision reads: ``"moore"`` (the node) or ``"mealy"`` (the node and
            the observation: one node is a memoryless policy); default ``"moore"`` on exact
            values, ``"mealy"`` on sampled.
        memoryless_patience: with Mealy decisions and no model start, a memoryless stage first:
            the laws start with one node and widen to ``nodes`` around the best memoryless
            policy after this many iterations without a better controller (three times as
            many in all at most), so that memory only adds to it; 0: none (default 0 on exact
            values, 10 on sampled).
        memory: the memory's layout where no model start is kept: ``"nodes"`` (``nodes`` flat
            nodes), ``"registers"`` (factored: ``registers`` registers of ``register_size``
            values, ``register_size ** registers`` nodes, each register moving on the
            observation and the register before it, so that the laws grow as
            ``registers · register_size³`` rather than ``nodes²``; Mealy decisions),
            ``"clock"`` (64 nodes, node ``t`` for step ``t`` and the last holding, kept at
            weight 0.99, with Moore decisions and no memoryless stage: a time-indexed policy,
            what a game of search such as Battleship needs) or ``"alternate"`` (runs take
            turns: flat nodes from ``template``, registers from the ``"window"`` template, a
            shift register of the last observations, then the clock; in the first round the
            first run ends by 50 % of ``time_limit`` and the second by 95 %; the best run is
            kept). Default ``"nodes"`` on exact values, ``"alternate"`` on sampled.
        registers: registers of a factored memory, at least 2 (default 3; the model search: 2,
            0 for flat nodes).
        register_size: values of each register (default 4; the ``"window"`` template's first register
            copies the observation modulo this), at least 2.
        credit: what refits the decision laws on sampled values (default ``"steps"``): ``"steps"`` (credit within
            episodes: where the world's value is the discounted sum of its steps' rewards, a
            world written in Python or a Gymnasium environment without ``score``, each decision
            row moves towards the decision whose steps had the highest mean value still to
            come, over every controller's episodes of the iteration; elsewhere the elite) or
            ``"elite"`` (the elite controllers' decisions, as the memory's laws). Default
            ``"steps"``.
        progress: print a live progress line on stderr.
        checkpoint: a file where the whole state of the search (laws, best controller so far,
            history, finished restarts) is saved every ``checkpoint_every`` seconds and whenever
            it stops (the end, Ctrl-C), through a temporary file renamed over it.
        checkpoint_every: seconds between two checkpoints.
        resume: continue from ``checkpoint`` when that file exists (else start afresh): with
            the same world and settings (stopping rules, ``time_limit``, ``max_env_steps`` and
            ``threads`` may differ) the result is the one an uninterrupted search gives, bit for bit. With a
            checkpoint, a SIGTERM that finds its default action stops the search like Ctrl-C,
            saves the checkpoint, then ends the process as SIGTERM asks.
        score: for a world written in Python, an episode's value from its
            ``(observations, decisions, rewards)`` (default: the sum of the rewards).
        discount: for a world written in Python, the discount of the default score.
        horizon: for a world written in Python, the most steps of an episode (default: its own).
        backend: ``"local"``, ``"ray"`` (every iteration's controllers valued in shards on a Ray
            cluster, exact or sampled, the same result bit for bit) or a
            :class:`~cehmm.RayBackend` (any :class:`cehmm.backend.Backend`; see :func:`optimize`).
        workers: with ``backend="ray"``: shards per iteration (default: the cluster's CPUs).
        address: with ``backend="ray"``: the cluster to join.
        callback: called after every iteration with its record (a :class:`cehmm.callbacks.Iteration`:
            a dict of the history's scalars for that iteration, ``score`` its best value so far,
            and the best policy so far on demand); returning ``False`` stops the run
            (``stop_reason`` ``"callback"``; with ``restarts``, no later run starts; a checkpoint
            is saved and resumes as at any stop).
            A list of callbacks calls each in turn; an exception a callback raises stops the run
            (its checkpoint saved) and propagates. See :mod:`cehmm.callbacks` for the built-ins.
        tensorboard_log: a folder where every iteration's scalars are written as a TensorBoard
            event file (:class:`cehmm.callbacks.TensorBoard`; needs ``pip install 'cehmm[tensorboard]'``).

    Returns:
        a :class:`ControllerResult`.

    Raises:
        TypeError: ``world`` is not a world, or an argument has the wrong type.
        ImportError: ``tensorboard_log`` without tensorboardX installed.
        InvalidArgumentError: an argument out of its domain (``value="exact"`` on a world that
            is not tabular among them); the message names it and its value.

    Example:
        >>> tiger = PomdpWorld.from_file("data/pomdp/tiger.95.POMDP", horizon=100)
        >>> result = optimize_controller(tiger, nodes=5, progress=False)  # doctest: +SKIP
        >>> round(result.value, 2)  # doctest: +SKIP
        19.37
        >>> stopped = optimize_controller(tiger, nodes=3, progress=False, callback=lambda it: it["iteration"] < 1)
        >>> stopped.stop_reason, len(stopped.history["iteration"])
        ('callback', 2)
    """
    options = {k: v for k, v in (("score", score), ("discount", discount), ("horizon", horizon)) if v is not None}
    with driven(callback, tensorboard_log, checkpoint) as run:
        raw = _core.optimize_controller(
            sampled_world(core_world(world, **options), world, options, backend, workers, address),
            dict(
                nodes=nodes,
                smoothing=smoothing,
                patience=patience,
                max_iterations=max_iterations,
                time_limit=time_limit,
                max_env_steps=max_env_steps,
                tolerance=tolerance,
                seed=seed,
                threads=threads,
                restarts=restarts,
                episodes=episodes,
                candidates=candidates,
                select_episodes=select_episodes,
                eval_episodes=eval_episodes,
                injection=injection,
                injections=injections,
                growths=growths,
                model_nodes=model_nodes,
                template_weight=template_weight,
                target=target,
                # None: the default of the kind of value used (the engine's to resolve).
                samples=samples,
                rho=rho,
                template=template,
                decisions=decisions,
                memoryless_patience=memoryless_patience,
                memory=memory,
                registers=registers,
                register_size=register_size,
                credit=credit,
            ),
            value=value,
            search=search,
            progress=progress,
            checkpoint=checkpoint,
            checkpoint_every=checkpoint_every,
            resume=resume,
            callback=run.hook,
        )
        return run.ended(ControllerResult._from_core(raw))
