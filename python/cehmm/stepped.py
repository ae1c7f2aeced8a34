"""Any optimiser given by its iteration step (``ceworld::run::OPTIMISERS``), by name:
:func:`run` and its :class:`RunResult`. Such an optimiser gets every run option of the others
(progress, checkpoints, Ctrl-C, the Ray backend) from the engine's run spine."""

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

#: Every optimiser given by its step: name -> its settings with their defaults.
OPTIMISERS: dict[str, dict[str, Any]] = dict(_core.OPTIMISERS)


@dataclass(frozen=True, eq=False)
class RunResult(Ending):
    """The outcome of :func:`run`.

    Attributes:
        policy: the best policy found, with its provenance (the settings, the method).
        history: one numpy array per statistic, one entry per iteration (``iteration``,
            ``mean``, ``best`` and ``best_so_far`` (both the best so far: the optimiser's own
            value of its best), ``elite_threshold``, ``elite_mean``, ``seconds``,
            ``successful``, ``env_steps``).
        evaluation: :attr:`policy` on fresh episodes.
        stop_reason: ``"patience"``, ``"max_iterations"``, ``"time_limit"``,
            ``"max_env_steps"``, ``"callback"``
            (``callback=`` returned ``False``) or ``"interrupted"``.
        seconds: wall time, every session together.
        env_steps: the world's steps learning took, every session together.
        eval_env_steps: the world's steps of :attr:`evaluation`, counted apart.

    Example:
        >>> tiger = PomdpWorld.from_file("data/pomdp/tiger.95.POMDP", horizon=20)
        >>> result = run("random-search", tiger, samples=20, max_iterations=3, progress=False)
        >>> result.stop_reason, result.interrupted, len(result.history["mean"])
        ('max_iterations', False, 3)
        >>> result.policy.levels, result.evaluation.episodes
        ([4, 4], 10000)
    """

    policy: Policy
    history: dict[str, np.ndarray]
    evaluation: Evaluation


def run(
    name: str,
    world: Any,
    *,
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
    **settings: Any,
) -> RunResult:
    """Runs the optimiser ``name`` (a key of :data:`OPTIMISERS`, e.g. ``"random-search"``) on
    ``world`` with ``settings`` (by name; see ``OPTIMISERS[name]`` for them and their defaults).

    The run options mean what they mean for :func:`optimize`: ``progress``, ``checkpoint``,
    ``checkpoint_every``, ``resume`` (bit for bit), ``score``, ``discount`` and ``horizon`` for
    a world written in Python, ``backend``, ``workers`` and ``address`` for Ray, ``callback``
    and ``tensorboard_log`` (:mod:`cehmm.callbacks`: after every iteration; ``False`` stops the
    run, ``stop_reason`` ``"callback"``).

    Raises:
        InvalidArgumentError: an unknown optimiser or setting, or a setting out of its domain.
        TypeError: ``callback`` is not a callable or a list of them.
        ImportError: ``tensorboard_log`` without tensorboardX installed.

    Example:
        >>> tiger = PomdpWorld.from_file("data/pomdp/tiger.95.POMDP", horizon=20)
        >>> result = run("random-search", tiger, samples=20, progress=False,
        ...              callback=lambda it: it["iteration"] < 2)
        >>> result.stop_reason, len(result.history["iteration"])
        ('callback', 3)
    """
    options = {k: v for k, v in (("score", score), ("discount", discount), ("horizon", horizon)) if v is not None}
    with driven(callback, tensorboard_log, checkpoint) as run:
        sampled = sampled_world(core_world(world, **options), world, options, backend, workers, address)
        raw = _core.run(
            name,
            sampled,
            settings,
            progress=progress,
            checkpoint=checkpoint,
            checkpoint_every=checkpoint_every,
            resume=resume,
            callback=run.hook,
        )
        return run.ended(RunResult._from_core(raw))
