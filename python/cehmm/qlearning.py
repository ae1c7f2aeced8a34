"""Tabular Q-learning, the paper's baseline (model §5, last rows), and the paper's comparison of
policies on 100-step windows.

The learner sees the last observation and both mobiles' cells and headings (``16 × 1600 × 1600``
states on the 20 × 20 grid, 16 actions), runs the world as a continuing task (never reset) and
updates ``Q(s, a) += α (r + γ max Q(s', ·) − Q(s, a))`` with ``γ = 0.99``, ``α = 0.1`` and
ε-greedy exploration, ``ε_t = min(1, 1/ln t)``; greedy ties are broken uniformly at random
(``ties="random"``) or by the lowest index (``ties="lowest"``), in learning and in the greedy policy.
The table is float32, row-major ``[state][action]`` (2.6 GB for the paper's world; a table that
would not fit in memory is refused with ``MemoryError`` before anything is allocated). See ``docs/qlearning.md``.
"""

from __future__ import annotations

import os
from typing import Any, Union

import numpy as np

from . import _core
from ._driven import driven
from .callbacks import CallbackLike
from .policy import Policy
from .results import WindowEvaluation, windows
from .world import World, core_world

PathLike = Union[str, "os.PathLike[str]"]

#: The paper's best case-3 reward: the 100 % of its comparison table.
PAPER_REFERENCE: float = _core.PAPER_REFERENCE

#: Window settings of :meth:`QLearner.evaluate_windows` and :func:`evaluate_windows` (the engine's).
WINDOW_DEFAULTS: dict[str, int] = dict(_core.WINDOW_DEFAULTS)

#: Q-learning settings (the engine's ``QConfig``: the paper's γ and α, seed 0, random ties; and
#: checkpoints every 600 s).
Q_DEFAULTS: dict[str, Any] = dict(_core.Q_DEFAULTS)

#: How greedy ties may be broken (the engine's ``ceworld::Ties``).
TIES = tuple(_core.TIES)

__all__ = [
    "PAPER_REFERENCE",
    "Q_DEFAULTS",
    "TIES",
    "WINDOW_DEFAULTS",
    "QLearner",
    "WindowEvaluation",
    "epsilon",
    "evaluate_windows",
    "qlearning",
]


class QLearner:
    """A Q-learning run on a world with a known state (target tracking): the table and
    everything needed to go on.

    Make one with :func:`qlearning` (which also trains it) or :meth:`load`; train it further with
    :meth:`train`; evaluate its greedy policy (ties broken as in learning) like a policy with
    :meth:`evaluate_windows`.

    Attributes:
        interrupted: whether Ctrl-C stopped the last :meth:`train`.
        stop_reason: why the last :meth:`train` stopped: ``"iterations"`` (it ran them all),
            ``"callback"`` (its ``callback`` returned ``False``) or ``"interrupted"`` (Ctrl-C);
            ``None`` before any.

    Example:
        >>> world = TargetTracking(case=3, width=5, height=5, start_b=[0, 4], start_c=[4, 4],
        ...                        target_rows=[0, 2], target_cell=[2, 2])
        >>> learner = qlearning(world, iterations=10_000, progress=False)
        >>> learner.updates, learner.table.shape
        (10000, (160000, 16))
    """

    __slots__ = ("_core", "interrupted", "stop_reason")

    def __init__(self, core: _core.QLearner) -> None:
        if not isinstance(core, _core.QLearner):
            raise TypeError("use cehmm.qlearning or QLearner.load to make a QLearner")
        self._core = core
        self.interrupted = False
        self.stop_reason: str | None = None

    @classmethod
    def new(
        cls,
        world: World,
        gamma: float = Q_DEFAULTS["gamma"],
        alpha: float = Q_DEFAULTS["alpha"],
        seed: int = Q_DEFAULTS["seed"],
        ties: str = Q_DEFAULTS["ties"],
    ) -> QLearner:
        """A fresh run with a zero table, not trained yet.

        Raises:
            MemoryError: the table would not fit in the memory the system reports available.
            InvalidArgumentError: ``gamma`` outside ``[0, 1)``, ``alpha`` outside ``(0, 1]``, or
                ``ties`` neither ``"random"`` nor ``"lowest"``.
        """
        return cls(_core.QLearner(core_world(world), dict(gamma=gamma, alpha=alpha, seed=seed, ties=ties)))

    @classmethod
    def load(cls, path: PathLike) -> QLearner:
        """Reads a run saved by :meth:`save` or a ``ceworld qlearn`` table/checkpoint."""
        return cls(_core.QLearner.load(os.fspath(path)))

    def save(self, path: PathLike, *, overwrite: bool = False) -> None:
        """Writes the run: a JSON header (settings, counters, random stream, world state), then the
        table as little-endian float32; through a temporary file, so never half-written. An
        existing ``path`` is replaced only when ``overwrite`` (else ``InvalidArgumentError``)."""
        self._core.save(os.fspath(path), overwrite=overwrite)

    def train(
        self,
        iterations: int,
        *,
        checkpoint: PathLike | None = None,
        checkpoint_every: float | None = None,
        progress: bool = True,
        callback: CallbackLike = None,
        tensorboard_log: PathLike | None = None,
    ) -> QLearner:
        """Runs updates until the run has ``iterations`` in all (a run is continued, not restarted).

        With ``checkpoint``, the run is saved there every ``checkpoint_every`` seconds (if given),
        when Ctrl-C stops it and at the end, and a SIGTERM stops it as Ctrl-C does, then ends the
        process as SIGTERM asks (see :func:`cehmm.optimize`). Ctrl-C stops between chunks of about
        a million updates and sets :attr:`interrupted` (no exception). ``callback`` is called after every
        chunk with its progress (a :class:`cehmm.callbacks.Iteration` without a policy: the table
        cannot be read while it learns), and ``False`` stops it there (:attr:`stop_reason`
        ``"callback"``, the checkpoint saved); ``tensorboard_log`` writes that progress to a
        TensorBoard event file (see :func:`cehmm.optimize`). Returns ``self``.

        Example:
            >>> learner = QLearner.new(TargetTracking(case=3, width=5, height=5, start_b=[0, 4],
            ...                        start_c=[4, 4], target_rows=[0, 2], target_cell=[2, 2]))
            >>> learner.train(3 * 2**20, progress=False, callback=lambda it: False).stop_reason  # doctest: +SKIP
            'callback'
        """
        with driven(callback, tensorboard_log, checkpoint) as run:
            reason = self._core.train(
                iterations,
                progress=progress,
                checkpoint=None if checkpoint is None else os.fspath(checkpoint),
                checkpoint_every=checkpoint_every,
                callback=run.hook,
            )
            self.interrupted = reason == "interrupted"
            self.stop_reason = reason or "iterations"
            return run.ended(self)

    def evaluate_windows(
        self,
        world: World | None = None,
        *,
        seed: int = 0,
        threads: int | None = None,
        reference: float = PAPER_REFERENCE,
        ties: str | None = None,
        window: int = WINDOW_DEFAULTS["window"],
        episodes: int = WINDOW_DEFAULTS["episodes"],
        chains: int = WINDOW_DEFAULTS["chains"],
        burn_in: int = WINDOW_DEFAULTS["burn_in"],
        windows_per_chain: int = WINDOW_DEFAULTS["windows_per_chain"],
    ) -> WindowEvaluation:
        """The greedy policy's reward on windows, as the paper evaluates it.

        Args:
            world: the world (default: the run's own).
            seed: seed of the evaluation runs (reproducible whatever ``threads``).
            threads: worker threads (default: one per core).
            ties: ``"random"`` or ``"lowest"`` (default: as in learning, :attr:`ties`).
            reference: the reward counted as 100 % (the paper: 69).
            window: steps per window (the paper: 100).
            episodes: (a) windows from the initial state, one per fresh start.
            chains: (b) independent continuing runs, each from a fresh start.
            burn_in: (b) steps each continuing run makes before its first window.
            windows_per_chain: (b) consecutive windows per continuing run after the burn-in.
        """
        settings = dict(
            window=window, episodes=episodes, chains=chains, burn_in=burn_in, windows_per_chain=windows_per_chain
        )
        return windows(
            self._core.evaluate_windows(
                core_world(self.world if world is None else world),
                settings,
                seed=seed,
                threads=threads,
                reference=reference,
                ties=ties,
            )
        )

    @property
    def updates(self) -> int:
        """Updates run so far (``t`` of the last one)."""
        return self._core.header()["updates"]  # type: ignore[no-any-return]

    @property
    def epsilon(self) -> float:
        """The exploration rate of the next update, ``min(1, 1/ln t)``."""
        return epsilon(self.updates + 1)

    @property
    def n_states(self) -> int:
        """Number of known states (rows of the table)."""
        return self._core.header()["n_states"]  # type: ignore[no-any-return]

    @property
    def n_actions(self) -> int:
        """Number of actions (columns of the table)."""
        return self._core.header()["n_actions"]  # type: ignore[no-any-return]

    @property
    def table_bytes(self) -> int:
        """Size of the table in bytes (4 per value)."""
        return self._core.table_bytes

    @property
    def gamma(self) -> float:
        """Discount ``γ``."""
        return self._core.header()["gamma"]  # type: ignore[no-any-return]

    @property
    def alpha(self) -> float:
        """Learning rate ``α``."""
        return self._core.header()["alpha"]  # type: ignore[no-any-return]

    @property
    def seed(self) -> int:
        """Seed of the run's random stream."""
        return self._core.header()["seed"]  # type: ignore[no-any-return]

    @property
    def ties(self) -> str:
        """How greedy ties are broken, in learning and in the greedy policy: ``"random"`` or ``"lowest"``."""
        return self._core.header()["ties"]  # type: ignore[no-any-return]

    @property
    def reward_total(self) -> float:
        """Sum of the rewards of every update (the ε-greedy learning run's own reward)."""
        return self._core.header()["reward_total"]  # type: ignore[no-any-return]

    @property
    def seconds(self) -> float:
        """Seconds spent learning, over every session."""
        return self._core.header()["seconds"]  # type: ignore[no-any-return]

    @property
    def header(self) -> dict[str, Any]:
        """The header of the run's file: settings, counters, random stream and world state."""
        return self._core.header()

    @property
    def world(self) -> World:
        """The world the table was learnt in."""
        return World.from_dict(self._core.world().to_dict())

    @property
    def table(self) -> np.ndarray:
        """A copy of the table, float32, shape ``(n_states, n_actions)`` (2.6 GB for the paper's world)."""
        return self._core.table()

    def row(self, state: int) -> np.ndarray:
        """``Q(state, ·)``, float32, shape ``(n_actions,)``."""
        return self._core.row(state)

    def greedy_actions(self, state: int) -> np.ndarray:
        """The greedy actions of ``state``: every action of maximal value (int64, ascending)."""
        row = self.row(state)
        return np.flatnonzero(row == row.max())

    def state_index(self, state: Any, y: int) -> int:
        """The known state of a world state seen through observation ``y``: ``(y·P + B)·P + C``.

        Args:
            state: ``(b_i, b_j, b_heading, c_i, c_j, c_heading, target_i, target_j)``, as in a
                rollout's ``x`` row (the target is not part of the known state).
            y: the observation.
        """
        return self._core.state_index([int(v) for v in state], y)

    def __repr__(self) -> str:
        h = self.header  # one read of the run's counters and settings
        return (
            f"QLearner(updates={h['updates']}, states={h['n_states']}, actions={h['n_actions']}, "
            f"gamma={h['gamma']:g}, alpha={h['alpha']:g}, ties={h['ties']!r}, seed={h['seed']}, "
            f"reward_per_100={100.0 * h['reward_total'] / max(h['updates'], 1):.2f})"
        )


def epsilon(t: int) -> float:
    """``ε_t = min(1, 1/ln t)`` for update ``t`` (counted from 1): 1 while ``t <= 2``."""
    return _core.epsilon(t)


def qlearning(
    world: World,
    iterations: int = 10**9,
    *,
    seed: int = Q_DEFAULTS["seed"],
    gamma: float = Q_DEFAULTS["gamma"],
    alpha: float = Q_DEFAULTS["alpha"],
    ties: str = Q_DEFAULTS["ties"],
    checkpoint: PathLike | None = None,
    checkpoint_every: float | None = Q_DEFAULTS["checkpoint_every"],
    resume: bool = False,
    progress: bool = True,
    callback: CallbackLike = None,
    tensorboard_log: PathLike | None = None,
) -> QLearner:
    """Q-learning on ``world`` as a continuing task, the paper's baseline; returns the learner.

    Args:
        world: the world (``TargetTracking(case=3)`` for the paper's table of 655 million values).
        iterations: number of updates in all.
        seed: seed of the run's single random stream.
        gamma: discount, ``0 <= gamma < 1``.
        alpha: learning rate, ``0 < alpha <= 1``.
        ties: how greedy ties are broken, in learning and in the greedy policy: ``"random"``
            (uniformly among the best actions) or ``"lowest"`` (the lowest index).
        checkpoint: a file where the run is saved every ``checkpoint_every`` seconds, on Ctrl-C and
            at the end.
        checkpoint_every: seconds between checkpoints.
        resume: continue the run saved in ``checkpoint`` (if the file exists) instead of starting
            afresh; the resumed run is exactly the one that was interrupted.
        progress: print a live progress line on stderr.
        callback: called after every chunk of about a million updates with its progress;
            ``False`` stops the run there (see :meth:`QLearner.train`).
        tensorboard_log: a folder where that progress is written as a TensorBoard event file.

    Raises:
        MemoryError: the table would not fit in the memory the system reports available.
        InvalidArgumentError: a bad argument, or ``resume`` with settings other than the checkpoint's.
        PolicyMismatchError: the checkpoint was made in another world.

    Example:
        >>> small = TargetTracking(case=3, width=5, height=5, start_b=[0, 4], start_c=[4, 4],
        ...                        target_rows=[0, 2], target_cell=[2, 2])
        >>> learner = qlearning(small, iterations=20_000, progress=False)
        >>> learner.updates, learner.stop_reason, learner.n_actions, learner.table.dtype
        (20000, 'iterations', 16, dtype('float32'))
        >>> more = qlearning(small, iterations=30_000, checkpoint="q.bin", resume=True, progress=False)
        >>> more.updates  # no checkpoint yet: a fresh run, saved in q.bin at its end
        30000
        >>> qlearning(small, iterations=40_000, checkpoint="q.bin", resume=True, progress=False).updates
        40000
    """
    settings = dict(gamma=gamma, alpha=alpha, seed=seed, ties=ties)
    if resume and checkpoint is not None and os.path.exists(checkpoint):
        learner = QLearner(_core.QLearner.resume(os.fspath(checkpoint), core_world(world), settings))
    else:
        learner = QLearner(_core.QLearner(core_world(world), settings))
    return learner.train(
        iterations,
        checkpoint=checkpoint,
        checkpoint_every=checkpoint_every,
        progress=progress,
        callback=callback,
        tensorboard_log=tensorboard_log,
    )


def evaluate_windows(
    policy: Policy | QLearner,
    world: World | None = None,
    *,
    seed: int = 0,
    threads: int | None = None,
    reference: float = PAPER_REFERENCE,
    window: int = WINDOW_DEFAULTS["window"],
    episodes: int = WINDOW_DEFAULTS["episodes"],
    chains: int = WINDOW_DEFAULTS["chains"],
    burn_in: int = WINDOW_DEFAULTS["burn_in"],
    windows_per_chain: int = WINDOW_DEFAULTS["windows_per_chain"],
) -> WindowEvaluation:
    """Any policy — an HHMM :class:`Policy` (run continuously: memory carried, start tables only at
    the very first step) or a :class:`QLearner`'s greedy policy — on the paper's windows; see
    :meth:`QLearner.evaluate_windows` for the arguments.

    Example:
        >>> small = TargetTracking(case=3, width=5, height=5, start_b=[0, 4], start_c=[4, 4],
        ...                        target_rows=[0, 2], target_cell=[2, 2])
        >>> sizes = dict(episodes=100, chains=2, burn_in=10, windows_per_chain=5)
        >>> learnt = evaluate_windows(qlearning(small, iterations=10_000, progress=False), **sizes)
        >>> learnt.from_start.episodes, learnt.continuing.episodes, learnt.reference
        (100, 10, 69.0)
        >>> uniform = evaluate_windows(Policy.uniform(small, [2]), small, reference=100.0, **sizes)
        >>> [round(p) for p in uniform.percent()["from_start"]]  # worst, mean, best window
        [54, 85, 100]
    """
    settings = dict(
        window=window, episodes=episodes, chains=chains, burn_in=burn_in, windows_per_chain=windows_per_chain
    )
    if isinstance(policy, QLearner):
        return policy.evaluate_windows(world, seed=seed, threads=threads, reference=reference, **settings)
    if not isinstance(policy, Policy):
        raise TypeError(f"invalid policy: {policy!r} (expected a cehmm.Policy or a cehmm.QLearner)")
    if world is None:
        world = World.from_dict(policy.world)
    return windows(
        _core.evaluate_policy_windows(
            policy._core, core_world(world), settings, seed=seed, threads=threads, reference=reference
        )
    )
