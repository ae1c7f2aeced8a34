"""What evaluations give back: :class:`Evaluation`, :class:`ExactValue`, :class:`Rollout` and
:class:`WindowEvaluation`, each made from the dict the engine returns (its fields, and the line
its ``repr`` shows, which the engine writes: ``ceworld::progress``).

A result's fields are named twice: once in the engine's struct that the bindings hand on
(``Evaluation``, ``ExactValue``, serialised by name), once in the class here that a user reads;
the class is made from the dict by name, so a field one side lacks fails at once.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from ._core import InvalidArgumentError


@dataclass(frozen=True)
class Evaluation:
    """The reward of a policy over fresh episodes.

    Attributes:
        episodes: number of episodes.
        mean: mean reward.
        std_error: standard error of the mean (``std / sqrt(episodes)``).
        std: sample standard deviation of the reward.
        min: smallest reward.
        max: largest reward.
        quantiles: ``{q: value}`` for q = 0.05, 0.25, 0.5, 0.75, 0.95 (nearest rank).

    Example:
        >>> world = cehmm.TargetTracking(case=1)
        >>> evaluation = cehmm.Policy.uniform(world, [4]).evaluate(world, episodes=1000, seed=0)
        >>> evaluation
        Evaluation(mean=1.46 ± 0.17, episodes=1000, std=5.50, min=0.00, max=51.00, median=0.00)
        >>> evaluation.quantiles[0.95]
        13.0
    """

    episodes: int
    mean: float
    std_error: float
    std: float
    min: float
    max: float
    quantiles: dict[float, float]
    shown: str = field(default="", repr=False, compare=False)

    def __repr__(self) -> str:
        return f"Evaluation({self.shown})"


@dataclass(frozen=True)
class ExactValue:
    """An exact value of a policy on a tabular world (model §7).

    Attributes:
        value: the expected (discounted) reward.
        steps: steps of the recursion (the horizon, or the steps taken to reach the tolerance).
        tail_bound: a bound on what the steps not taken could add (0 at a finite horizon).

    Example:
        >>> tiger = cehmm.PomdpWorld.from_file("data/pomdp/tiger.95.POMDP", horizon=10)
        >>> value = cehmm.Policy.uniform(tiger, [2]).evaluate_exact(infinite=True)
        >>> value
        ExactValue(value=-606.6666663705813, steps=418, tail_bound=9.8e-07)
        >>> round(float(value), 3)
        -606.667
    """

    value: float
    steps: int
    tail_bound: float

    def __float__(self) -> float:
        return self.value

    def __repr__(self) -> str:
        return f"ExactValue(value={self.value}, steps={self.steps}, tail_bound={self.tail_bound:.1e})"


@dataclass(frozen=True, eq=False)
class Rollout:
    """One recorded episode of a policy in a world; step ``t`` is row ``t`` of every array.

    Attributes:
        x: hidden state ``x_t``, shape ``(T, k)``, int64; columns named by ``x_labels``.
        x_labels: names of the columns of ``x``.
        y: observation ``y_t``, shape ``(T,)``, int64.
        d: decision ``d_t``, shape ``(T,)``, int64.
        memory: memory states ``m_1[t] .. m_Λ[t]``, shape ``(T, Λ)``, int64.
        reward: the episode's reward ``V``.

    Example:
        >>> world = cehmm.TargetTracking(case=1)
        >>> episode = cehmm.Policy.uniform(world, [4]).rollout(world, seed=0)
        >>> episode
        Rollout(steps=100, levels=1, reward=0.0)
        >>> episode.x_labels[-2:], episode.column("target_i")[:3]
        (['target_i', 'target_j'], array([10, 10, 10]))
    """

    x: npt.NDArray[np.int64]
    x_labels: list[str]
    y: npt.NDArray[np.int64]
    d: npt.NDArray[np.int64]
    memory: npt.NDArray[np.int64]
    reward: float

    def __len__(self) -> int:
        return len(self.y)

    def column(self, label: str) -> npt.NDArray[np.int64]:
        """The column of ``x`` named ``label`` (e.g. ``"target_i"``).

        Raises:
            InvalidArgumentError: no column has that name.
        """
        if label not in self.x_labels:
            raise InvalidArgumentError(f"invalid label: {label!r} (expected one of {self.x_labels})")
        return self.x[:, self.x_labels.index(label)]

    def plot(self, **kwargs: Any) -> Any:
        """The episode drawn (:func:`cehmm.plots.rollout`, keywords passed on): a matplotlib figure."""
        from .plots import rollout

        return rollout(self, **kwargs)

    def animate(self, path: str | os.PathLike[str], **kwargs: Any) -> Any:
        """The episode as an animation saved to ``path`` (:func:`cehmm.plots.animation`, keywords
        passed on)."""
        from .plots import animation

        return animation(self, path, **kwargs)

    def __repr__(self) -> str:
        return f"Rollout(steps={len(self)}, levels={self.memory.shape[1]}, reward={self.reward})"


@dataclass(frozen=True)
class WindowEvaluation:
    """The non-discounted reward of windows of a policy's runs, as the paper compares policies.

    Attributes:
        from_start: one window from each fresh start of the world (``min`` is the worst
            window, ``max`` the best).
        continuing: consecutive windows of long continuing runs after a burn-in (correlated:
            its ``std_error`` is optimistic).
        reference: the reward that counts as 100 % (the paper: 69).

    Example:
        >>> small = cehmm.TargetTracking(case=3, width=5, height=5, start_b=[0, 4], start_c=[4, 4],
        ...                              target_rows=[0, 2], target_cell=[2, 2])
        >>> policy = cehmm.Policy.uniform(small, [2])
        >>> windows = cehmm.evaluate_windows(policy, small, reference=100.0, episodes=100, chains=2,
        ...                                  burn_in=10, windows_per_chain=5)
        >>> windows
        WindowEvaluation(from_start: worst/mean/best 54/85/100 % over 100 windows; continuing: ...)
        >>> windows.from_start.episodes, windows.continuing.episodes
        (100, 10)
    """

    from_start: Evaluation
    continuing: Evaluation
    reference: float
    shown: str = field(default="", repr=False, compare=False)

    def percent(self) -> dict[str, tuple[float, float, float]]:
        """``{"from_start": (worst, mean, best), "continuing": (...)}`` in % of ``reference``."""

        def of(e: Evaluation) -> tuple[float, float, float]:
            return tuple(100.0 * x / self.reference for x in (e.min, e.mean, e.max))  # type: ignore[return-value]

        return {"from_start": of(self.from_start), "continuing": of(self.continuing)}

    def __repr__(self) -> str:
        return f"WindowEvaluation({self.shown})"


def evaluation(raw: dict[str, Any]) -> Evaluation:
    """The :class:`Evaluation` of the engine's dict."""
    return Evaluation(**raw)


def windows(raw: dict[str, Any]) -> WindowEvaluation:
    """The :class:`WindowEvaluation` of the engine's dict."""
    return WindowEvaluation(
        **{**raw, "from_start": evaluation(raw["from_start"]), "continuing": evaluation(raw["continuing"])}
    )
