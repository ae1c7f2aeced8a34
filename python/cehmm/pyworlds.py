"""The paper's target-tracking world written in Python: reference implementations of
:class:`cehmm.TargetTracking` (model §4) under two world protocols, as templates for worlds of
one's own.

* **Episode protocol** (:class:`TrackingEpisodes`): one episode at a time, pure Python.
  Attributes ``n_observations``, ``n_decisions``, ``horizon``; ``reset(seed) -> y_1``;
  ``step(d_t) -> (y_{t+1}, r_t, terminated)``. The caller stops after ``horizon`` steps.
* **Batched protocol** (:class:`TrackingBatch`, class attribute ``batched = True``): ``n``
  independent episodes at once, vectorised over the episodes with numpy.
  ``reset(n, seed) -> int64[n]``; ``step(int64[n]) -> (int64[n], float64[n], bool[n])``.

In both, the reward of step ``t`` is 1 when ``d∞(B_t, R_t) <= reward_radius`` or
``d∞(C_t, R_t) <= reward_radius`` (the positions before the step's moves), so the rewards of the
``horizon`` steps sum to the engine's episode value ``V``; ``terminated`` is always false. Each
step then moves the target (from ``R_t``, ``B_t``, ``C_t``) and the mobiles (by ``d_t``), and
emits the next observation. They follow the engine in distribution (the random draws differ),
and exactly in case 1, where the world is deterministic.
"""

from __future__ import annotations

import random
from collections.abc import Sequence

import numpy as np

__all__ = ["TrackingEpisodes", "TrackingBatch"]

# Headings 0 up, 1 right, 2 down, 3 left: the unit step ahead and the heading change of each move
# (0 turn left, 1 turn right, 2 forward, 3 nothing).
_AHEAD_I = (0, 1, 0, -1)
_AHEAD_J = (-1, 0, 1, 0)
_TURN = (3, 1, 0, 0)
_FORWARD = 2


class _Tracking:
    """The parameters shared by both protocols (the keywords of :class:`cehmm.TargetTracking`)."""

    n_decisions = 16

    def __init__(
        self,
        case: int = 3,
        *,
        width: int = 20,
        height: int = 20,
        horizon: int = 100,
        start_b: Sequence[int] = (0, 19),
        start_c: Sequence[int] = (19, 19),
        start_heading: int = 2,
        reward_radius: int = 3,
        observe_radius: int = 3,
        target_cell: Sequence[int] = (10, 10),
        target_rows: Sequence[int] = (0, 9),
    ) -> None:
        if isinstance(case, bool) or case not in (1, 2, 3):
            raise ValueError(f"invalid case: {case!r} (expected 1, 2 or 3)")
        self.case = int(case)
        self.width, self.height, self.horizon = int(width), int(height), int(horizon)
        self.start_b = (int(start_b[0]), int(start_b[1]))
        self.start_c = (int(start_c[0]), int(start_c[1]))
        self.start_heading = int(start_heading)
        self.reward_radius, self.observe_radius = int(reward_radius), int(observe_radius)
        self.target_cell = (int(target_cell[0]), int(target_cell[1]))
        self.target_rows = (int(target_rows[0]), int(target_rows[1]))
        # Case 2 hides the target: a single observation, always 0.
        self.n_observations = 1 if case == 2 else 16
        # The target moves in cases 2 and 3; on a 1×1 grid it has nowhere to go (all weights 0).
        self._moving = case != 1 and self.width * self.height > 1

    def __repr__(self) -> str:
        return f"{type(self).__name__}(case={self.case})"


class TrackingEpisodes(_Tracking):
    """The target-tracking world, one episode at a time (the episode protocol), in pure Python.

    ``TrackingEpisodes(case=3, **params)`` takes the keywords of :class:`cehmm.TargetTracking`.
    ``reset(seed)`` starts an episode from its own ``random.Random(seed)`` and returns ``y_1``;
    ``step(d)`` returns ``(y_{t+1}, r_t, False)`` with ``r_t`` 1.0 when step ``t`` is rewarded.
    :meth:`describe` gives the state as the engine's ``Session.describe()`` does.

    Example:
        >>> world = TrackingEpisodes(case=1)
        >>> world.reset(seed=0)
        0
        >>> # B turns right twice (to face up), 6 forward, right, 7 forward; C stays (move 3).
        >>> plan = [4 * 1 + 3] * 2 + [4 * 2 + 3] * 6 + [4 * 1 + 3] + [4 * 2 + 3] * 7
        >>> plan += [4 * 3 + 3] * (world.horizon - len(plan))
        >>> sum(world.step(d)[1] for d in plan)  # rewarded from step 17 on
        84.0
    """

    def reset(self, seed: int) -> int:
        """Starts an episode drawn from ``seed``: its first observation ``y_1``."""
        self._rng = random.Random(seed)
        if self.case == 1:
            self.target = self.target_cell
        else:
            first, last = self.target_rows
            cell = self._rng.randrange((last - first + 1) * self.width)
            self.target = (cell % self.width, first + cell // self.width)
        self.b = (*self.start_b, self.start_heading)
        self.c = (*self.start_c, self.start_heading)
        return self._observe()

    def step(self, decision: int) -> tuple[int, float, bool]:
        """Takes ``decision`` ``d = 4·a_B + a_C``: ``(next observation, this step's reward, False)``."""
        if not 0 <= decision < 16:
            raise ValueError(f"invalid decision: {decision!r} (expected 0..16)")
        (bi, bj, _), (ci, cj, _) = self.b, self.c
        ri, rj = self.target
        radius = self.reward_radius
        rewarded = max(abs(bi - ri), abs(bj - rj)) <= radius or max(abs(ci - ri), abs(cj - rj)) <= radius
        if self._moving:
            self.target = self._move_target(ri, rj, bi, bj, ci, cj)
        self.b = self._apply(self.b, decision >> 2)
        self.c = self._apply(self.c, decision & 3)
        return self._observe(), 1.0 if rewarded else 0.0, False

    def describe(self) -> list[int]:
        """The state: ``b_i, b_j, b_heading, c_i, c_j, c_heading, target_i, target_j``."""
        return [*self.b, *self.c, *self.target]

    def _move_target(self, ri: int, rj: int, bi: int, bj: int, ci: int, cj: int) -> tuple[int, int]:
        """The target's next cell: one of the in-grid cells of its 3×3 neighbourhood (itself
        included) with probability proportional to ``|r' − B|² + |r' − C|²``."""
        cells = []
        weights = []
        for j in (rj - 1, rj, rj + 1):
            if 0 <= j < self.height:
                gj = (j - bj) ** 2 + (j - cj) ** 2
                for i in (ri - 1, ri, ri + 1):
                    if 0 <= i < self.width:
                        cells.append((i, j))
                        weights.append((i - bi) ** 2 + (i - ci) ** 2 + gj)
        x = self._rng.random() * sum(weights)
        for cell, weight in zip(cells, weights):
            if x < weight:
                return cell
            x -= weight
        # Only reached through rounding: the last cell of positive weight.
        return next(cell for cell, weight in zip(reversed(cells), reversed(weights)) if weight > 0)

    def _apply(self, mobile: tuple[int, int, int], action: int) -> tuple[int, int, int]:
        """One mobile's move: turn left, turn right, forward (staying put at the edge), nothing."""
        i, j, heading = mobile
        if action == _FORWARD:
            ni, nj = i + _AHEAD_I[heading], j + _AHEAD_J[heading]
            if 0 <= ni < self.width and 0 <= nj < self.height:
                return ni, nj, heading
            return mobile
        return i, j, (heading + _TURN[action]) & 3

    def _observe(self) -> int:
        """``y = obs_B + 4·obs_C``, each 2 bits: target strictly ahead, target within
        ``d∞ < observe_radius``; always 0 in case 2."""
        if self.case == 2:
            return 0
        ri, rj = self.target
        y = 0
        for mobile, scale in ((self.b, 1), (self.c, 4)):
            i, j, heading = mobile
            di, dj = ri - i, rj - j
            ahead = _AHEAD_I[heading] * di + _AHEAD_J[heading] * dj > 0
            near = max(abs(di), abs(dj)) < self.observe_radius
            y += scale * (ahead + 2 * near)
        return y


# The 3×3 neighbourhood: the column (and row) offsets as a column, and the offsets of the nine
# cells in the order k = 3·row + column that the flattened weights take.
_OFFSETS = np.array([[-1], [0], [1]], dtype=np.int64)
_CELL_DI = np.tile([-1, 0, 1], 3)
_CELL_DJ = np.repeat([-1, 0, 1], 3)
# Replaces the weight part of an off-grid column or row: the cell's weight is then clipped to 0.
_OFF_GRID = -(1 << 60)
_AHEAD_I_NP = np.array(_AHEAD_I, dtype=np.int64)
_AHEAD_J_NP = np.array(_AHEAD_J, dtype=np.int64)
# Indexed by 4·heading + action: the cell change if the move is made, and the new heading.
_MOVE_DI = np.array([_AHEAD_I[h] * (a == _FORWARD) for h in range(4) for a in range(4)], dtype=np.int64)
_MOVE_DJ = np.array([_AHEAD_J[h] * (a == _FORWARD) for h in range(4) for a in range(4)], dtype=np.int64)
_MOVE_HEADING = np.array([(h + _TURN[a]) & 3 for h in range(4) for a in range(4)], dtype=np.int64)
# d >> 2 is B's action, d >> 0 C's (each & 3): the two rows of the mobiles' arrays.
_ACTION_SHIFT = np.array([[2], [0]], dtype=np.int64)


class TrackingBatch(_Tracking):
    """The target-tracking world, ``n`` independent episodes at once (the batched protocol).

    ``TrackingBatch(case=3, **params)`` takes the keywords of :class:`cehmm.TargetTracking`.
    ``reset(n, seed)`` starts ``n`` episodes from their own ``np.random.default_rng(seed)`` and
    returns their first observations (int64); ``step(decisions)`` returns the next observations
    (int64), the step's rewards (float64, 0 or 1) and ``done`` (bool, always false). Every
    operation is vectorised over the episodes: the two mobiles are the rows of ``(2, n)`` arrays,
    B first, and the target's nine candidate cells the rows of ``(9, n)`` arrays.
    :meth:`describe` gives the states as the engine's ``Session.describe()`` does, one row each.

    Example:
        >>> world = TrackingBatch(case=3)
        >>> y = world.reset(n=1000, seed=0)
        >>> total = sum(world.step((7 * y) % 16)[1] for _ in range(world.horizon))
        >>> total.shape
        (1000,)
    """

    batched = True

    def reset(self, n: int, seed: int) -> np.ndarray:
        """Starts ``n`` episodes drawn from ``seed``: their first observations."""
        self._rng = np.random.default_rng(seed)
        self.n = n = int(n)
        if self.case == 1:
            self.target_i = np.full(n, self.target_cell[0], dtype=np.int64)
            self.target_j = np.full(n, self.target_cell[1], dtype=np.int64)
        else:
            first, last = self.target_rows
            cell = self._rng.integers(0, (last - first + 1) * self.width, size=n, dtype=np.int64)
            self.target_i, self.target_j = cell % self.width, first + cell // self.width
        self.mobile_i = np.repeat(np.array([[self.start_b[0]], [self.start_c[0]]], dtype=np.int64), n, axis=1)
        self.mobile_j = np.repeat(np.array([[self.start_b[1]], [self.start_c[1]]], dtype=np.int64), n, axis=1)
        self.heading = np.full((2, n), self.start_heading, dtype=np.int64)
        self._done = np.zeros(n, dtype=bool)
        return self._observe()

    def step(self, decisions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Takes one decision per episode: ``(observations, rewards, done)``."""
        d = np.asarray(decisions, dtype=np.int64)
        if d.shape != (self.n,) or (d.size and (d.min() < 0 or d.max() > 15)):
            raise ValueError(f"invalid decisions: expected {self.n} integers in 0..16 (got shape {d.shape})")
        # The reward of step t: from the positions before anything moves (found by _observe).
        rewards = self._rewarded.astype(np.float64)
        if self._moving:
            self._move_target()
        # The mobiles' moves. A forward move changes one coordinate by 1; clipping that
        # coordinate to the grid undoes a move off the grid, as the rules want.
        move = 4 * self.heading + ((d >> _ACTION_SHIFT) & 3)  # (2, n)
        self.mobile_i = np.clip(self.mobile_i + _MOVE_DI[move], 0, self.width - 1)
        self.mobile_j = np.clip(self.mobile_j + _MOVE_DJ[move], 0, self.height - 1)
        self.heading = _MOVE_HEADING[move]
        return self._observe(), rewards, self._done.copy()

    def describe(self) -> np.ndarray:
        """The states, ``(n, 8)``: ``b_i, b_j, b_heading, c_i, c_j, c_heading, target_i, target_j``."""
        mi, mj, h = self.mobile_i, self.mobile_j, self.heading
        return np.stack((mi[0], mj[0], h[0], mi[1], mj[1], h[1], self.target_i, self.target_j), axis=1)

    def _move_target(self) -> None:
        """Moves every target to a cell of its 3×3 neighbourhood in the grid, with probability
        proportional to ``|r' − B|² + |r' − C|²`` (the mobiles before they move): the weight of
        cell ``(i, j)`` is ``f(i) + g(j)``; one uniform per episode, inverse CDF."""
        (bi, ci), (bj, cj) = self.mobile_i, self.mobile_j
        columns = self.target_i + _OFFSETS  # (3, n)
        rows = self.target_j + _OFFSETS
        f = (columns - bi) ** 2 + (columns - ci) ** 2
        g = (rows - bj) ** 2 + (rows - cj) ** 2
        f = np.where((columns >= 0) & (columns < self.width), f, _OFF_GRID)
        g = np.where((rows >= 0) & (rows < self.height), g, _OFF_GRID)
        cumulative = (g[:, None, :] + f[None, :, :]).reshape(9, -1)  # cell k = 3·row + column
        np.maximum(cumulative, 0, out=cumulative)  # off-grid cells weigh 0
        # The running sums in place: np.cumsum is slow along a short axis, and so is a fresh
        # array per operation on large batches.
        for k in range(1, 9):
            cumulative[k] += cumulative[k - 1]
        # u·total < total for u < 1 (round to nearest), so the cell k has a positive weight.
        x = self._rng.random(self.n) * cumulative[8]
        k = (cumulative <= x).sum(axis=0)
        self.target_i = self.target_i + _CELL_DI[k]
        self.target_j = self.target_j + _CELL_DJ[k]

    def _observe(self) -> np.ndarray:
        """``y = obs_B + 4·obs_C`` per episode (zeros in case 2); also whether the current step
        is rewarded (the same distances)."""
        di, dj = self.target_i - self.mobile_i, self.target_j - self.mobile_j  # (2, n)
        distance = np.maximum(np.abs(di), np.abs(dj))
        self._rewarded = (distance <= self.reward_radius).any(axis=0)
        if self.case == 2:
            return np.zeros(self.n, dtype=np.int64)
        ahead = _AHEAD_I_NP[self.heading] * di + _AHEAD_J_NP[self.heading] * dj > 0
        seen = ahead + 2 * (distance < self.observe_radius)
        return seen[0] + 4 * seen[1]
