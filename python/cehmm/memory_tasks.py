"""Tasks that need memory, written as batched numpy worlds (the batched protocol of
:class:`cehmm.PythonWorld`): a policy without memory cannot reach their optimum.

* :class:`RepeatFirst` and :class:`RepeatPrevious` follow POPGym's games of the same names
  (Morad et al., 2023: ``popgym-RepeatFirstEasy-v0`` and ``popgym-RepeatPreviousEasy-v0`` with
  their default sizes), with their rules and rewards, vectorised over episodes (the draws of the
  decks differ from POPGym's, the laws are the same).
* :class:`TMaze` is Bakker's T-maze (2002): a sign at the start of a corridor tells which way to
  turn at its end.

Each has ``n_observations``, ``n_decisions``, ``horizon``, ``optimum`` (the best mean value),
``memoryless`` (the best value of a policy that sees only the current observation) and
``batched = True``; ``reset(n, seed)`` and ``step(decisions)`` work on ``n`` episodes at once.

Example:
    >>> import cehmm
    >>> found = cehmm.optimize_controller(TMaze(corridor=4), nodes=4, target=1.0, progress=False)
    >>> found.value, found.stop_reason
    (1.0, 'target')
"""

from __future__ import annotations

import numpy as np

__all__ = ["RepeatFirst", "RepeatPrevious", "TMaze"]


class _Cards:
    """A shuffled deck of ``52 · decks`` cards per episode, seen as suits 0..3."""

    batched = True
    n_observations = 4
    n_decisions = 4

    def __init__(self, decks: int = 1) -> None:
        if isinstance(decks, bool) or not isinstance(decks, int) or decks < 1:
            raise ValueError(f"invalid decks: {decks!r} (expected a positive int)")
        self.decks = decks
        self.cards = 52 * decks
        # POPGym ends the game when one card is left in the deck: cards − 1 steps.
        self.horizon = self.cards - 1

    def reset(self, n: int, seed: int) -> np.ndarray:
        rng = np.random.default_rng(seed)
        self._suits = (np.argsort(rng.random((n, self.cards)), axis=1) % 4).astype(np.int64)
        self._t = 0
        return self._suits[:, 0].copy()

    def _advance(self) -> tuple[np.ndarray, np.ndarray]:
        self._t += 1
        done = np.full(len(self._suits), self._t >= self.horizon)
        return self._suits[:, min(self._t, self.cards - 1)].copy(), done

    def __repr__(self) -> str:
        return f"{type(self).__name__}(decks={self.decks})"


class RepeatFirst(_Cards):
    """POPGym's RepeatFirst: at every step, name the suit of the first card dealt.

    Each of the ``cards − 1`` steps pays ``+1/(cards − 1)`` when the decision is the first card's
    suit, ``−1/(cards − 1)`` otherwise: the optimum is 1 (a controller that holds the first
    suit), the best memoryless policy (repeat the current card) about −0.5.

    Example:
        >>> game = RepeatFirst()
        >>> first = game.reset(n=3, seed=0)  # the suits of three episodes' first cards
        >>> first
        array([3, 0, 2])
        >>> observations, rewards, done = game.step(first)  # named: +1/51 each
        >>> (rewards * 51).tolist(), done.tolist()
        ([1.0, 1.0, 1.0], [False, False, False])
        >>> game.horizon, round(game.memoryless, 3)
        (51, -0.499)
    """

    optimum = 1.0

    @property
    def memoryless(self) -> float:
        # Naming the current card is right when it has the first card's suit: 12 of the other
        # 51 cards of one deck do (13·decks − 1 of cards − 1), and the first step is always right.
        same = (13 * self.decks - 1) / (self.cards - 1)
        steps = self.horizon
        right = (1 + (steps - 1) * same) / steps
        return 2 * right - 1

    def step(self, decisions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        scale = 1.0 / (self.cards - 1)
        rewards = np.where(decisions == self._suits[:, 0], scale, -scale)
        observations, done = self._advance()
        return observations, rewards, done


class RepeatPrevious(_Cards):
    """POPGym's RepeatPrevious: name the suit of the card dealt ``k − 1`` steps before the
    current one (``k = 4`` in the Easy game).

    The steps from the ``k``-th on pay ``±1/(cards − k)``: the optimum is 1, and a memoryless
    policy cannot beat chance (a mean of −0.5, four suits).

    Example:
        >>> game = RepeatPrevious(k=2)  # name the card dealt one step before
        >>> previous = game.reset(n=3, seed=0)
        >>> observations, rewards, done = game.step(previous)  # the first step is not scored
        >>> rewards.tolist()
        [0.0, 0.0, 0.0]
        >>> observations, rewards, done = game.step(previous)
        >>> (rewards * 50).tolist()
        [1.0, 1.0, 1.0]
    """

    optimum = 1.0
    memoryless = -0.5

    def __init__(self, decks: int = 1, k: int = 4) -> None:
        super().__init__(decks)
        if isinstance(k, bool) or not isinstance(k, int) or not 1 <= k < self.cards:
            raise ValueError(f"invalid k: {k!r} (expected 1 <= k < {self.cards})")
        self.k = k

    def step(self, decisions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        held = self._t + 1  # cards dealt so far, the current one included
        if held >= self.k:
            scale = 1.0 / (self.cards - self.k)
            rewards = np.where(decisions == self._suits[:, held - self.k], scale, -scale)
        else:
            rewards = np.zeros(len(decisions))
        observations, done = self._advance()
        return observations, rewards, done


class TMaze:
    """Bakker's T-maze: the start shows a sign (observation 0 or 1), the ``corridor − 1`` cells
    after it look alike (2), and the junction at the corridor's end (3) has two ways out.

    Decisions: 0 forward, 1 turn up, 2 turn down. Turning at the junction ends the episode, with
    +1 where the sign pointed and −1 the other way; turning in the corridor and going forward at
    the junction cost 0.01 and stay. An episode that has not turned after ``horizon`` steps
    (``corridor + 10``) ends with what it has. The optimum is 1 (``corridor`` steps forward, then
    the sign's way); without memory the junction is a coin toss: at best 0.

    Example:
        >>> maze = TMaze(corridor=2)
        >>> maze.reset(n=4, seed=0)  # the signs
        array([1, 1, 1, 0])
        >>> maze.step(np.zeros(4, dtype=np.int64))[0]  # forward: the corridor
        array([2, 2, 2, 2])
        >>> maze.step(np.zeros(4, dtype=np.int64))[0]  # forward: the junction
        array([3, 3, 3, 3])
        >>> observations, rewards, done = maze.step(np.array([2, 2, 2, 1]))  # the signs' ways
        >>> rewards.tolist(), done.tolist()
        ([1.0, 1.0, 1.0, 1.0], [True, True, True, True])
    """

    batched = True
    n_observations = 4
    n_decisions = 3
    optimum = 1.0
    memoryless = 0.0

    def __init__(self, corridor: int = 10) -> None:
        if isinstance(corridor, bool) or not isinstance(corridor, int) or corridor < 1:
            raise ValueError(f"invalid corridor: {corridor!r} (expected a positive int)")
        self.corridor = corridor
        self.horizon = corridor + 10

    def reset(self, n: int, seed: int) -> np.ndarray:
        rng = np.random.default_rng(seed)
        self._sign = rng.integers(0, 2, n)
        self._position = np.zeros(n, dtype=np.int64)
        return self._sign.astype(np.int64)

    def step(self, decisions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        at_junction = self._position == self.corridor
        turn = decisions != 0
        rewards = np.where(turn != at_junction, -0.01, 0.0)
        done = at_junction & turn
        rewards = np.where(done, np.where(decisions == self._sign + 1, 1.0, -1.0), rewards)
        self._position = np.where(~at_junction & ~turn, self._position + 1, self._position)
        observations = np.where(self._position == self.corridor, 3, 2).astype(np.int64)
        return observations, rewards, done

    def __repr__(self) -> str:
        return f"TMaze(corridor={self.corridor})"
