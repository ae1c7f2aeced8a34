"""Callbacks of every optimiser, Stable-Baselines3's way: ``callback=`` of :func:`cehmm.optimize`,
:func:`cehmm.optimize_controller`, :func:`cehmm.run` and :func:`cehmm.qlearning` (and
:meth:`cehmm.QLearner.train`) is called after every iteration with its :class:`Iteration`, and
returning ``False`` stops the run as a stopping rule does: its ``stop_reason`` is ``"callback"``
(not ``"interrupted"``), its result is evaluated in full, and its checkpoint, saved at the stop as
at any stop, continues the run when resumed. ``None`` or ``True`` goes on. An exception the
callback raises stops the run (its checkpoint saved, as on Ctrl-C) and propagates.

A callback is any callable taking an :class:`Iteration`, a :class:`Callback` or a list of them
(:class:`CallbackList`). The built-ins: :class:`StopOnNoImprovement`, :class:`SaveBest`,
:class:`EvalOnEnv` and :class:`TensorBoard` (which ``tensorboard_log=DIR`` adds).

A :class:`Callback` also declares the files it writes (:meth:`~Callback.outputs`): before the
first iteration, they are held to the one rule of a run's outputs with the run's own checkpoint
(no file is another's, links followed: ``ceworld::files::check_distinct``) and each must be
writable (a regular file or a new name in a folder that can be written; a folder that exists or
can be made), so that a bad path is refused at once, not after the first iteration. Once the
optimiser has its result, every :class:`Callback` is given it (:meth:`~Callback.on_result`:
:class:`SaveBest` writes the result's policy), then closed (:meth:`~Callback.close`), however the
run ended.

What a callback raises after the run has its result (in :meth:`~Callback.on_result` or
:meth:`~Callback.close`) never costs the result: the optimiser returns it and warns
(``RuntimeWarning``, naming the callback and the error). When the run raised (a callback's own
exception, a ``KeyboardInterrupt`` before the first iteration), that exception propagates
unchanged and a ``close()`` that fails too is added to it as a note (``__notes__``).

A signal a callback sends to its own process is seen by the run before its next iteration, as
one from outside: ``SIGINT`` returns the result so far, marked interrupted; ``SIGTERM``, with a
checkpoint, saves it and ends the process as SIGTERM asks.

Example:
    >>> import cehmm
    >>> world = cehmm.TargetTracking(case=1)
    >>> result = cehmm.optimize(world, levels=[4], samples=200, progress=False,
    ...                         callback=lambda it: it["iteration"] < 4)
    >>> result.stop_reason, result.iterations
    ('callback', 5)
"""

from __future__ import annotations

import operator
import os
from collections.abc import Sequence
from typing import Any, Callable, NamedTuple, Optional, Union

import numpy as np

from . import _core
from .policy import Policy
from .results import Evaluation

__all__ = [
    "Callback",
    "CallbackList",
    "EvalOnEnv",
    "Iteration",
    "Output",
    "SaveBest",
    "StopOnNoImprovement",
    "TensorBoard",
]


class Iteration(dict[str, Any]):
    """One iteration as a callback gets it: a dict of the history's scalars for that iteration
    (one row of the result's ``history``: ``iteration``, ``mean``, ``best``, ``elite_threshold``,
    ``elite_mean``, ``seconds``, ``successful``, and the controller search's own fields),
    ``run`` (the run's index among the restarts, from 0, kept across a resume), ``step`` (the
    iteration's number counted on across the call's runs, kept across a resume) and
    ``score``, what the optimiser chooses its result by as of this iteration (the iteration's
    mean for :func:`cehmm.optimize` and :func:`cehmm.run`, the best value so far for
    :func:`cehmm.optimize_controller`); with the best policy so far on demand
    (:meth:`best_policy`).

    Q-learning's is its progress after a chunk of about a million updates: ``updates``,
    ``until``, ``epsilon``, ``reward_per_100``, ``mean_reward_per_100``, ``updates_per_second``,
    ``seconds``, ``table_bytes`` and ``iteration`` (the chunk's number in this call, from 0).

    A callback may add entries (:class:`EvalOnEnv` adds ``eval_mean`` and ``eval_std_error``):
    the callbacks after it in a list see them, :class:`TensorBoard` writes them.

    Example:
        >>> seen = []
        >>> result = cehmm.optimize(cehmm.TargetTracking(case=1), levels=[4], samples=200,
        ...                         max_iterations=2, progress=False, callback=seen.append)
        >>> sorted(seen[0])  # doctest: +NORMALIZE_WHITESPACE
        ['best', 'elite_mean', 'elite_threshold', 'env_steps', 'iteration', 'mean', 'run', 'score',
         'seconds', 'step', 'successful']
        >>> seen[1].best_policy().levels
        [4]
    """

    __slots__ = ("_core_policy",)

    def __init__(self, record: Any = (), policy: _core.Policy | None = None) -> None:
        super().__init__(record)
        self._core_policy = policy

    def best_policy(self) -> Policy | None:
        """The best policy so far (of the current run where there are restarts), its provenance
        the run's settings and ``"policy": "best so far"``; ``None`` for Q-learning (whose
        table is its learner's)."""
        return None if self._core_policy is None else Policy(self._core_policy)


#: What ``callback=`` takes.
CallbackLike = Union[Callable[[Iteration], Optional[bool]], Sequence[Callable[[Iteration], Optional[bool]]], None]

#: The placeholders of a series of files (:class:`SaveBest`, :class:`Output`): the iteration's
#: step counted on across the runs of one call, and its run.
PLACEHOLDERS = ("{iteration}", "{run}")


class Output(NamedTuple):
    """A file a :class:`Callback` writes, as :meth:`Callback.outputs` declares it: ``name`` (what
    an error calls it), ``path``, and whether it is a ``folder`` the callback writes files of its
    own names in (made if missing). A file's name may hold ``{iteration}`` and ``{run}``: a
    series of files, one per step (:class:`SaveBest`). Before the first iteration the run refuses
    an output that is the file of another (its checkpoint, another callback's), a path that is
    not a regular file (a directory, a device, a FIFO) or not a folder, and a folder that cannot
    be written.

    Example:
        >>> SaveBest("best_{iteration}.json").outputs()
        [Output(name='SaveBest path', path='best_{iteration}.json', folder=False)]
        >>> TensorBoard("runs").outputs()[0].folder
        True
    """

    name: str
    path: str
    folder: bool = False


class Callback:
    """The base of the built-in callbacks: called after every iteration with its
    :class:`Iteration`, it returns ``False`` to stop the run, ``None`` or ``True`` to go on.
    Three hooks, each called by every optimiser: :meth:`outputs` before the run (the files it
    writes, checked then), :meth:`on_result` once the run has its result, and :meth:`close` once
    the run has ended, however it ended. Any callable taking an :class:`Iteration` is a callback
    too (a subclass only adds the hooks).

    Example:
        >>> class Every(Callback):
        ...     def __init__(self):
        ...         self.means = []
        ...     def __call__(self, iteration):
        ...         self.means.append(iteration["mean"])
        ...     def on_result(self, result):
        ...         self.result = result
        >>> every = Every()
        >>> result = cehmm.optimize(cehmm.TargetTracking(case=1), levels=[4], samples=200,
        ...                         max_iterations=3, progress=False, callback=every)
        >>> len(every.means), every.result is result
        (3, True)
    """

    def __call__(self, iteration: Iteration) -> bool | None:
        raise NotImplementedError

    def outputs(self) -> list[Output]:
        """The files it writes (:class:`Output`, or ``(name, path)`` pairs): none by default."""
        return []

    def on_result(self, result: Any) -> None:
        """Called with the optimiser's result once it has one (not when the run raised); what it
        raises is a warning, the result returned all the same."""

    def close(self) -> None:
        """Called once the run has ended (the end, a stop, an exception)."""


class CallbackList(Callback):
    """Several callbacks, called in order after every iteration (every one of them, whatever
    the others answer): the run stops when one of them returns ``False``. ``callback=`` makes
    one of a list. Its outputs are theirs; the run gives each its result and closes each (see
    :mod:`cehmm.callbacks`).

    Args:
        callbacks: the callbacks (callables taking an :class:`Iteration`).

    Raises:
        TypeError: ``callbacks`` is not a list of callables (the message names the first that
            is not).

    Example:
        >>> stop = CallbackList([StopOnNoImprovement(patience=3), lambda it: it["iteration"] < 9])
        >>> result = cehmm.optimize(cehmm.TargetTracking(case=1), levels=[4], samples=200,
        ...                         progress=False, callback=stop)
        >>> result.stop_reason, result.iterations <= 10
        ('callback', True)
    """

    def __init__(self, callbacks: Sequence[Callable[[Iteration], bool | None]]) -> None:
        if isinstance(callbacks, (str, bytes)) or not isinstance(callbacks, (list, tuple)):
            raise TypeError(f"invalid callbacks: {callbacks!r} (expected a list of callables)")
        for k, c in enumerate(callbacks):
            if not callable(c):
                raise TypeError(f"invalid callbacks[{k}]: {c!r} (expected a callable taking the iteration)")
        self.callbacks = list(callbacks)

    def __call__(self, iteration: Iteration) -> bool:
        go_on = True
        for c in self.callbacks:
            go_on = _answer(c, c(iteration)) and go_on
        return go_on

    def outputs(self) -> list[Output]:
        """The outputs of every callback in it that is a :class:`Callback`."""
        return [Output(*o) for c in members(self) for o in c.outputs()]

    def on_result(self, result: Any) -> None:
        """Gives ``result`` to every callback that is a :class:`Callback` (all of them, then raises
        the first exception one raised, the others noted on it)."""
        _each(self, lambda c: c.on_result(result), "given the result")

    def close(self) -> None:
        """Closes every callback that is a :class:`Callback` (all of them, then raises the first
        exception one raised, the others noted on it)."""
        _each(self, lambda c: c.close(), "closed")


def members(callback: Any) -> list[Callback]:
    """The :class:`Callback` objects ``callback`` is made of: itself, or those of a
    :class:`CallbackList` (nested lists flattened); plain callables have no hooks."""
    if isinstance(callback, CallbackList):
        return [m for c in callback.callbacks for m in members(c)]
    return [callback] if isinstance(callback, Callback) else []


def failure(callback: Any, error: BaseException, when: str) -> str:
    """What a hook's failure says: the callback, the error, and when (``"closed"``)."""
    return f"callback {type(callback).__qualname__} raised {type(error).__name__} when {when}: {error}"


def note(error: BaseException, text: str) -> None:
    """Adds ``text`` to ``error``'s notes (``add_note`` from Python 3.11; ``__notes__`` before)."""
    if hasattr(error, "add_note"):
        error.add_note(text)
    else:  # pragma: no cover - Python < 3.11
        error.__notes__ = [*getattr(error, "__notes__", []), text]  # type: ignore[attr-defined]


def _each(callbacks: CallbackList, act: Callable[[Callback], None], when: str) -> None:
    failed: list[tuple[Callback, Exception]] = []
    for c in members(callbacks):
        try:
            act(c)
        except Exception as e:  # the others have theirs all the same
            failed.append((c, e))
    if failed:
        first = failed[0][1]
        for other, error in failed[1:]:
            note(first, failure(other, error, when))
        raise first


class StopOnNoImprovement(Callback):
    """Stops the run after ``patience`` iterations in a row whose ``key`` (default ``score``:
    the iteration's mean for :func:`cehmm.optimize`, so that ``patience=p`` stops where the
    engine's own ``patience=p`` would) did not beat the best so far by more than
    ``min_delta``.

    Args:
        patience: iterations without improvement, at least 1.
        key: the record's entry watched (e.g. ``"elite_mean"``, or ``"eval_mean"`` after an
            :class:`EvalOnEnv` in the same list).
        min_delta: the least gain that counts as an improvement, at least 0.

    Raises:
        TypeError, InvalidArgumentError: an argument of the wrong type or out of its domain.
        KeyError: (when called) the record has no ``key``; the message lists those it has.

    Example:
        >>> result = cehmm.optimize(cehmm.TargetTracking(case=1), levels=[4], samples=200,
        ...                         progress=False, callback=StopOnNoImprovement(patience=3))
        >>> result.stop_reason
        'callback'
    """

    def __init__(self, patience: int, key: str = "score", min_delta: float = 0.0) -> None:
        self.patience = _count("patience", patience)
        if not isinstance(key, str):
            raise TypeError(f"invalid key: {key!r} (expected the name of a record's entry, e.g. 'score')")
        self.key = key
        if isinstance(min_delta, bool) or not isinstance(min_delta, (int, float)):
            raise TypeError(f"invalid min_delta: {min_delta!r} (expected a number >= 0)")
        if not min_delta >= 0:
            raise _core.InvalidArgumentError(f"invalid min_delta: {min_delta!r} (expected a number >= 0)")
        self.min_delta = float(min_delta)
        self.best: float | None = None
        self.since = 0

    def __call__(self, iteration: Iteration) -> bool:
        if self.key not in iteration:
            raise KeyError(f"StopOnNoImprovement: the record has no {self.key!r} (it has {', '.join(iteration)})")
        value = float(iteration[self.key])
        if self.best is None or value > self.best + self.min_delta:
            self.best, self.since = value, 0
        else:
            self.since += 1
        return self.since < self.patience


class SaveBest(Callback):
    """Saves the best policy so far to ``path`` every ``every`` iterations (replacing the file,
    atomically: never half-written), where :meth:`cehmm.Policy.load` reads it.

    The file holds the best of the whole call: with ``restarts``, a run whose best so far scores
    below the policy saved (its record's ``score``, what the optimiser chooses by) does not write
    over it, and once the optimiser returns, the file holds the result's own policy
    (:meth:`on_result`). ``{iteration}`` in the file's name makes a series of files, one per save,
    numbered by the record's ``step``, counted on across the runs of the call and kept across a
    resume (TensorBoard's step: ``{iteration}`` of the second run goes on from the first's last),
    and ``{run}`` by the run's index among the restarts; each holds its run's best so far at that
    step.

    Args:
        path: the policy file (JSON, model §6); ``{iteration}`` and ``{run}`` only in its name.
        every: iterations between two saves, at least 1.

    Attributes:
        saved: the paths written, in order.
        best_score: the ``score`` of the policy saved at ``path`` during the run (``None``
            before the first save, or with placeholders).

    Raises:
        TypeError, InvalidArgumentError: an argument of the wrong type or out of its domain.
        InvalidArgumentError: (when called) the run has no policy (Q-learning).

    Example:
        >>> save = SaveBest("best.json", every=2)
        >>> result = cehmm.optimize(cehmm.TargetTracking(case=1), levels=[4], samples=200,
        ...                         max_iterations=4, restarts=2, progress=False, callback=save)
        >>> cehmm.Policy.load("best.json").provenance == result.policy.provenance  # the result's own
        True
        >>> steps = SaveBest("best-{run}-{iteration}.json")
        >>> result = cehmm.optimize(cehmm.TargetTracking(case=1), levels=[4], samples=200,
        ...                         max_iterations=2, restarts=2, progress=False, callback=steps)
        >>> steps.saved
        ['best-0-0.json', 'best-0-1.json', 'best-1-2.json', 'best-1-3.json']
    """

    def __init__(self, path: str | os.PathLike[str], every: int = 1) -> None:
        if not isinstance(path, (str, os.PathLike)):
            raise TypeError(f"invalid path: {path!r} (expected a str or os.PathLike)")
        self.path = os.fspath(path)
        if any(p in os.path.dirname(self.path) for p in PLACEHOLDERS):
            raise _core.InvalidArgumentError(
                f"invalid path: {self.path!r} (expected {' and '.join(PLACEHOLDERS)} in the file's name only, "
                "not in its folder)"
            )
        self.every = _count("every", every)
        self.saved: list[str] = []
        self.best_score: float | None = None
        self._series = any(p in self.path for p in PLACEHOLDERS)
        self._steps = Steps()
        self._calls = 0
        self._run: int | None = None
        self._run_best: float | None = None
        self._ended = False

    def __call__(self, iteration: Iteration) -> None:
        step, run = self._steps(iteration)
        if self._ended:  # a new call: its own best
            self.best_score, self._run, self._ended = None, None, False
        if run != self._run:
            self._run, self._run_best = run, None
        score = iteration.get("score")
        if isinstance(score, (int, float)) and not isinstance(score, bool):
            self._run_best = float(score) if self._run_best is None else max(self._run_best, float(score))
        self._calls += 1
        if self._calls % self.every:
            return
        if self._series:
            path = self.path.replace("{iteration}", str(step)).replace("{run}", str(run))
        elif self.best_score is not None and self._run_best is not None and self._run_best < self.best_score:
            return  # a worse run: the file keeps the better policy
        else:
            path = self.path
        _best(iteration, "SaveBest").save(path, overwrite=True)
        self.saved.append(path)
        if not self._series:
            self.best_score = self._run_best

    def outputs(self) -> list[Output]:
        """Its file (a series of files with placeholders)."""
        return [Output("SaveBest path", self.path)]

    def on_result(self, result: Any) -> None:
        """Writes the result's policy to ``path`` (without placeholders): the file holds what
        the optimiser returned, the best of the whole call."""
        policy = getattr(result, "policy", None)
        if not self._series and isinstance(policy, Policy):
            policy.save(self.path, overwrite=True)
            self.saved.append(self.path)

    def close(self) -> None:
        """Ends the call: the next call saves its own best."""
        self._ended = True


class EvalOnEnv(Callback):
    """Every ``every`` iterations, evaluates the best policy so far on ``world`` (a separate
    world or environment: a held-out variant, another seed of a Gymnasium environment) over
    ``episodes`` episodes, keeps the values in :attr:`history` and adds ``eval_mean`` and
    ``eval_std_error`` to the iteration's record (so that :class:`TensorBoard` and
    :class:`StopOnNoImprovement` with ``key="eval_mean"``, after it in a list, see them).

    Args:
        world: any world :meth:`cehmm.Policy.evaluate` takes.
        every: iterations between two evaluations, at least 1.
        episodes: episodes of each evaluation, at least 1.
        seed: seed of the evaluation's episodes (the same episodes each time: the values
            compare policies, not luck).

    Attributes:
        history: ``iteration``, ``mean``, ``std_error`` (lists, one entry per evaluation).
        evaluations: each :class:`cehmm.Evaluation`, in order.

    Raises:
        TypeError, InvalidArgumentError: an argument of the wrong type or out of its domain.
        InvalidArgumentError: (when called) the run has no policy (Q-learning).

    Example:
        >>> check = EvalOnEnv(cehmm.TargetTracking(case=1), every=2, episodes=100)
        >>> result = cehmm.optimize(cehmm.TargetTracking(case=1), levels=[4], samples=200,
        ...                         max_iterations=4, progress=False, callback=check)
        >>> check.history["iteration"]
        [1, 3]
    """

    def __init__(self, world: Any, every: int = 1, episodes: int = 1000, seed: int = 0) -> None:
        if world is None:
            raise TypeError("invalid world: None (expected the world to evaluate on)")
        self.world = world
        self.every = _count("every", every)
        self.episodes = _count("episodes", episodes)
        if isinstance(seed, bool):
            raise TypeError(f"invalid seed: {seed!r} (expected an integer >= 0)")
        self.seed = seed
        self.history: dict[str, list[float]] = {"iteration": [], "mean": [], "std_error": []}
        self.evaluations: list[Evaluation] = []
        self._calls = 0

    def __call__(self, iteration: Iteration) -> None:
        self._calls += 1
        if self._calls % self.every:
            return
        e = _best(iteration, "EvalOnEnv").evaluate(self.world, episodes=self.episodes, seed=self.seed)
        self.evaluations.append(e)
        self.history["iteration"].append(iteration.get("iteration", self._calls - 1))
        self.history["mean"].append(e.mean)
        self.history["std_error"].append(e.std_error)
        iteration["eval_mean"], iteration["eval_std_error"] = e.mean, e.std_error


class TensorBoard(Callback):
    """Writes every iteration's scalars (the record's numbers; ``successful`` and the other
    flags as 0 or 1) to a TensorBoard event file in ``log_dir``, one tag per entry, at the step
    of the iteration, counted on across restarts (Q-learning: the updates so far). Needs
    tensorboardX (``pip install 'cehmm[tensorboard]'``); ``tensorboard --logdir DIR`` shows it.
    Each run writes a file of its own, opened at its first iteration and closed at its end.

    Args:
        log_dir: the folder (made if missing; a file, a device or a FIFO is refused before the
            run).

    Raises:
        ImportError: tensorboardX is not installed (the message says how to install it).

    Example:
        >>> result = cehmm.optimize(cehmm.TargetTracking(case=1), levels=[4], samples=200,
        ...                         max_iterations=3, progress=False, tensorboard_log="runs")
        >>> [name.startswith("events.out.tfevents.") for name in os.listdir("runs")]
        [True]
        >>> board = TensorBoard("runs")  # the steps: counted on across restarts; Q-learning's updates
        >>> [board.step(Iteration({"iteration": k})) for k in (0, 1, 2, 0, 1)]
        [0, 1, 2, 3, 4]
        >>> board.step(Iteration({"updates": 2**20}))
        1048576
    """

    def __init__(self, log_dir: str | os.PathLike[str]) -> None:
        self._writer_class = _summary_writer()
        if not isinstance(log_dir, (str, os.PathLike)):
            raise TypeError(f"invalid tensorboard_log: {log_dir!r} (expected a folder: a str or os.PathLike)")
        self.log_dir = os.fspath(log_dir)
        self._writer: Any = None
        self._steps = Steps()

    def step(self, iteration: Iteration) -> int:
        """The step ``iteration`` is written at: its number, plus the iterations of the runs
        before it in the call (:class:`Steps`); Q-learning's updates."""
        return self._steps(iteration)[0]

    def __call__(self, iteration: Iteration) -> None:
        if self._writer is None:
            self._writer = self._writer_class(logdir=self.log_dir)
            self._steps = Steps()
        step = self.step(iteration)
        for key, value in iteration.items():
            if key not in ("iteration", "step") and isinstance(value, (int, float)):
                self._writer.add_scalar(key, float(value), step)

    def outputs(self) -> list[Output]:
        """Its folder."""
        return [Output("tensorboard_log", self.log_dir, folder=True)]

    def close(self) -> None:
        """Flushes and closes the event file (the next run opens another)."""
        if self._writer is not None:
            writer, self._writer = self._writer, None
            writer.close()


class Steps:
    """An iteration's step counted on across the runs of one call, and its run: the one count of
    :class:`TensorBoard`'s steps and :class:`SaveBest`'s names. The engine's records say both
    (``step`` and ``run``, kept across a resume); in a record without them a run is its
    ``restart``, or without it an iteration number that does not grow starts the next.
    Q-learning's step is its updates so far.

    Example:
        >>> steps = Steps()
        >>> [steps(Iteration({"iteration": k, "run": r})) for r, k in [(0, 0), (0, 1), (1, 0), (1, 1)]]
        [(0, 0), (1, 0), (2, 1), (3, 1)]
    """

    def __init__(self) -> None:
        self._last: int | None = None
        self._offset = 0
        self._run: Any = None
        self._runs = 0

    def __call__(self, iteration: Iteration) -> tuple[int, int]:
        """``(step, run)`` of ``iteration``, the next in the call."""
        if "updates" in iteration:
            return int(iteration["updates"]), 0
        if "step" in iteration and "run" in iteration:
            return int(iteration["step"]), int(iteration["run"])
        k = int(iteration.get("iteration", 0 if self._last is None else self._last + 1))
        run = iteration.get("run", iteration.get("restart"))
        if self._last is not None and (k <= self._last or (run is not None and run != self._run)):
            self._offset += self._last + 1
            self._runs += 1
        self._last, self._run = k, run
        return k + self._offset, int(run) if run is not None else self._runs


def _summary_writer() -> Any:
    """tensorboardX's ``SummaryWriter``, or an ``ImportError`` that says how to install it."""
    try:
        from tensorboardX import SummaryWriter
    except ImportError as e:
        raise ImportError(
            f"tensorboard_log needs tensorboardX, which cannot be imported here ({e}): "
            "pip install 'cehmm[tensorboard]'",
            name="tensorboardX",
        ) from e
    return SummaryWriter


def _count(name: str, value: Any) -> int:
    """``value`` as a count of at least 1 (numpy integers too), else the error naming it."""
    try:
        if isinstance(value, bool):
            raise TypeError
        n = operator.index(value)
    except TypeError:
        raise TypeError(f"invalid {name}: {value!r} (expected an integer >= 1)") from None
    if n < 1:
        raise _core.InvalidArgumentError(f"invalid {name}: {value!r} (expected an integer >= 1)")
    return n


def _best(iteration: Iteration, who: str) -> Policy:
    policy = iteration.best_policy()
    if policy is None:
        raise _core.InvalidArgumentError(
            f"invalid callback: {who} on a run that has no policy (Q-learning; expected cehmm.optimize, "
            "cehmm.optimize_controller or cehmm.run)"
        )
    return policy


def _answer(callback: Any, answer: Any) -> bool:
    """A callback's answer as go on (True) or stop (False); anything but a bool or None is refused."""
    if answer is None:
        return True
    if isinstance(answer, (bool, np.bool_)):
        return bool(answer)
    raise TypeError(
        f"invalid answer of callback {callback!r}: {answer!r} (expected True or None to go on, False to stop)"
    )
