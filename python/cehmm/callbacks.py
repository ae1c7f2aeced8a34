"""Callbacks of every optimiser, Stable-Baselines3's way: ``callback=`` of :func:`cehmm.optimize`,
:func:`cehmm.optimize_controller`, :func:`cehmm.run` and :func:`cehmm.qlearning` (and
:meth:`cehmm.QLearner.train`) is called after every iteration with its :class:`Iteration`, and
returning ``False`` stops the run as a stopping rule does: its ``stop_reason`` is ``"callback"``
(not ``"interrupted"``), its result is evaluated in full, and its checkpoint, saved at the stop as
at any stop, continues the run when resumed. ``None`` or ``True`` goes on. An exception the
callback raises stops the run (its checkpoint saved, as on Ctrl-C) and propagates.

A callback is any callable taking an :class:`Iteration`, a :class:`Callback` (whose
:meth:`~Callback.close` is called once the run has ended) or a list of them
(:class:`CallbackList`). The built-ins: :class:`StopOnNoImprovement`, :class:`SaveBest`,
:class:`EvalOnEnv` and :class:`TensorBoard` (which ``tensorboard_log=DIR`` adds).

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
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any, Callable, Optional, Union

import numpy as np

from . import _core
from .policy import Policy
from .results import Evaluation

__all__ = [
    "Callback",
    "CallbackList",
    "EvalOnEnv",
    "Iteration",
    "SaveBest",
    "StopOnNoImprovement",
    "TensorBoard",
]


class Iteration(dict[str, Any]):
    """One iteration as a callback gets it: a dict of the history's scalars for that iteration
    (one row of the result's ``history``: ``iteration``, ``mean``, ``best``, ``elite_threshold``,
    ``elite_mean``, ``seconds``, ``successful``, and the controller search's own fields) and
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
        >>> sorted(seen[0])
        ['best', 'elite_mean', 'elite_threshold', 'iteration', 'mean', 'score', 'seconds', 'successful']
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


class Callback:
    """The base of the built-in callbacks: called after every iteration with its
    :class:`Iteration`, it returns ``False`` to stop the run, ``None`` or ``True`` to go on;
    :meth:`close` is called once the run has ended, however it ended. Any callable taking an
    :class:`Iteration` is a callback too (a subclass only adds :meth:`close`).

    Example:
        >>> class Every(Callback):
        ...     def __init__(self):
        ...         self.means = []
        ...     def __call__(self, iteration):
        ...         self.means.append(iteration["mean"])
        >>> every = Every()
        >>> result = cehmm.optimize(cehmm.TargetTracking(case=1), levels=[4], samples=200,
        ...                         max_iterations=3, progress=False, callback=every)
        >>> len(every.means)
        3
    """

    def __call__(self, iteration: Iteration) -> bool | None:
        raise NotImplementedError

    def close(self) -> None:
        """Called once the run has ended (the end, a stop, an exception)."""


class CallbackList(Callback):
    """Several callbacks, called in order after every iteration (every one of them, whatever
    the others answer): the run stops when one of them returns ``False``. ``callback=`` makes
    one of a list.

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

    def close(self) -> None:
        """Closes every callback that is a :class:`Callback` (all of them, then raises the first
        exception one raised)."""
        failed: list[BaseException] = []
        for c in self.callbacks:
            if isinstance(c, Callback):
                try:
                    c.close()
                except BaseException as e:  # the others are closed all the same
                    failed.append(e)
        if failed:
            raise failed[0]


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
    atomically: never half-written), where :meth:`cehmm.Policy.load` reads it; ``{iteration}``
    in ``path`` is replaced by the iteration's number (one file per save).

    Args:
        path: the policy file (JSON, model §6).
        every: iterations between two saves, at least 1.

    Raises:
        TypeError, InvalidArgumentError: an argument of the wrong type or out of its domain.
        InvalidArgumentError: (when called) the run has no policy (Q-learning).

    Example:
        >>> save = SaveBest("best.json", every=2)
        >>> result = cehmm.optimize(cehmm.TargetTracking(case=1), levels=[4], samples=200,
        ...                         max_iterations=4, progress=False, callback=save)  # doctest: +SKIP
        >>> cehmm.Policy.load("best.json").levels  # doctest: +SKIP
        [4]
    """

    def __init__(self, path: str | os.PathLike[str], every: int = 1) -> None:
        if not isinstance(path, (str, os.PathLike)):
            raise TypeError(f"invalid path: {path!r} (expected a str or os.PathLike)")
        self.path = os.fspath(path)
        self.every = _count("every", every)
        self.saved: list[str] = []
        self._calls = 0

    def __call__(self, iteration: Iteration) -> None:
        self._calls += 1
        if self._calls % self.every:
            return
        policy = _best(iteration, "SaveBest")
        path = self.path.replace("{iteration}", str(iteration.get("iteration", self._calls - 1)))
        policy.save(path, overwrite=True)
        self.saved.append(path)


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
        log_dir: the folder (made if missing).

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
        self._last: int | None = None
        self._offset = 0

    def step(self, iteration: Iteration) -> int:
        """The step ``iteration`` is written at: its number, plus the iterations of the runs
        before it (a number that does not grow starts a new run); Q-learning's updates."""
        if "updates" in iteration:
            return int(iteration["updates"])
        k = int(iteration.get("iteration", 0 if self._last is None else self._last + 1))
        if self._last is not None and k <= self._last:
            self._offset += self._last + 1
        self._last = k
        return k + self._offset

    def __call__(self, iteration: Iteration) -> None:
        if self._writer is None:
            self._writer = self._writer_class(logdir=self.log_dir)
            self._last, self._offset = None, 0
        step = self.step(iteration)
        for key, value in iteration.items():
            if key != "iteration" and isinstance(value, (int, float)):
                self._writer.add_scalar(key, float(value), step)

    def close(self) -> None:
        """Flushes and closes the event file (the next run opens another)."""
        if self._writer is not None:
            writer, self._writer = self._writer, None
            writer.close()


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


def as_callback(callback: CallbackLike) -> Callable[[Iteration], bool | None] | None:
    """``callback=`` as one callable: ``None``, a callable, or a :class:`CallbackList` of a list.

    Raises:
        TypeError: anything else (the message names it).
    """
    if callback is None or callable(callback):
        return callback
    if isinstance(callback, (list, tuple)):
        return CallbackList(list(callback))
    raise TypeError(
        f"invalid callback: {callback!r} (expected a callable taking the iteration, a list of them, or None)"
    )


@contextmanager
def driven(
    callback: CallbackLike, tensorboard_log: str | os.PathLike[str] | None = None
) -> Iterator[Callable[[dict[str, Any], _core.Policy | None], bool] | None]:
    """The engine's per-iteration hook of ``callback=`` and ``tensorboard_log=`` (``None`` for
    neither), checked before the run; every :class:`Callback` among them is closed once the
    block has ended, however it ended. Every optimiser runs inside it."""
    one = as_callback(callback)
    if tensorboard_log is not None:
        board = TensorBoard(tensorboard_log)
        one = board if one is None else CallbackList([one, board])
    if one is None:
        yield None
        return
    call = one

    def hook(record: dict[str, Any], policy: _core.Policy | None) -> bool:
        return _answer(call, call(Iteration(record, policy)))

    try:
        yield hook
    finally:
        if isinstance(one, Callback):
            one.close()
