"""Results of running a policy: reward statistics (:class:`Evaluation`) and one recorded episode
(:class:`Rollout`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


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
    """

    episodes: int
    mean: float
    std_error: float
    std: float
    min: float
    max: float
    quantiles: dict[float, float] = field(default_factory=dict)

    @classmethod
    def _from_dict(cls, d: dict[str, Any]) -> Evaluation:
        return cls(**d)

    def __repr__(self) -> str:
        return (
            f"Evaluation(mean={self.mean:.3f} ± {self.std_error:.3f}, episodes={self.episodes}, "
            f"std={self.std:.3f}, min={self.min:g}, max={self.max:g}, median={self.quantiles.get(0.5, float('nan')):g})"
        )


@dataclass(frozen=True, repr=False, eq=False)
class Rollout:
    """One recorded episode of a policy in a world; step ``t`` is row ``t`` of every array.

    Attributes:
        x: hidden state ``x_t``, shape ``(T, k)``, int64; columns named by :attr:`x_labels`
            (target tracking: ``b_i, b_j, b_heading, c_i, c_j, c_heading, target_i, target_j``).
        x_labels: names of the columns of :attr:`x`.
        y: observation ``y_t``, shape ``(T,)``, int64.
        d: decision ``d_t``, shape ``(T,)``, int64.
        memory: memory states ``m_1[t] .. m_Λ[t]``, shape ``(T, Λ)``, int64.
        reward: the episode's reward ``V``.
    """

    x: np.ndarray
    x_labels: list[str]
    y: np.ndarray
    d: np.ndarray
    memory: np.ndarray
    reward: float

    def __len__(self) -> int:
        return len(self.y)

    def column(self, label: str) -> np.ndarray:
        """The column of :attr:`x` named ``label`` (e.g. ``"target_i"``)."""
        return self.x[:, self.x_labels.index(label)]

    def __repr__(self) -> str:
        return f"Rollout(steps={len(self)}, levels={self.memory.shape[1]}, reward={self.reward:g})"
