"""HHMM policies (model §2): tables as numpy arrays, policy files (model §6), evaluation and rollouts."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any, Union

import numpy as np

from . import _core
from ._core import Agent, InvalidArgumentError, PolicyFormatError
from .backend import Backend
from .encoded import EnvAgent, policy_encodings
from .outside import PythonWorld, _is_gym_env
from .ray_backend import sampled_world
from .results import Evaluation, ExactValue, Rollout, evaluation
from .world import World, core_world, world_title

PathLike = Union[str, "os.PathLike[str]"]

#: ``{"h0": array, "h1": array, "upper": [{"start": array, "step": array}, ...]}``
Tables = dict[str, Any]


class Policy:
    """A hierarchical HMM policy with input and output (model §2), with its world and provenance.

    With levels ``[|M_1|, ..., |M_Λ|]`` (bottom first), ``Y`` observations and ``D`` decisions,
    the tables (:attr:`tables`, float64, every innermost row summing to 1) are:

    * ``h0[m1, d]``, shape ``(|M_1|, D)``: the decision given the bottom memory;
    * ``h1[y, u, m1]``, shape ``(Y, U, |M_1|)``, ``u = m_2[t]``, ``U = |M_2|`` (1 when ``Λ = 1``);
    * for each level ``l = 2..Λ``, ``upper[l - 2]`` holds ``start[u, m_l]``, shape
      ``(U, |M_l|)`` (used at ``t = 1``), and ``step[p, u, m_l]``, shape
      ``(|M_{l-1}|, U, |M_l|)`` with ``p = m_{l-1}[t-1]``, ``u = m_{l+1}[t]``, ``U = |M_{l+1}|``
      (1 at the top level).

    Make one with :meth:`uniform`, :meth:`random`, :meth:`from_tables`, :meth:`load` or
    :func:`cehmm.optimize`.

    Example:
        >>> world = TargetTracking(case=1)
        >>> policy = Policy.uniform(world, [16, 16])
        >>> policy.parameter_count
        4320
        >>> policy.evaluate(world, episodes=1000).mean  # doctest: +SKIP
        15.8
    """

    __slots__ = ("_core",)

    def __init__(self, core: _core.Policy) -> None:
        if not isinstance(core, _core.Policy):
            raise TypeError("use Policy.uniform, Policy.random, Policy.from_tables or Policy.load to make a Policy")
        self._core = core

    # -- construction ------------------------------------------------------------------------

    @classmethod
    def uniform(cls, world: World, levels: Sequence[int]) -> Policy:
        """The policy whose every row is uniform (the starting point of the CE method).

        Raises:
            InvalidArgumentError: ``levels`` is not a non-empty list of sizes in ``1..=65535``.
            TypeError: ``levels`` is not a list of ints.
        """
        return cls(_core.Policy.start(core_world(world), levels, "uniform", 0))

    @classmethod
    def random(cls, world: World, levels: Sequence[int], seed: int = 0) -> Policy:
        """A policy with random rows (each entry uniform in (0, 1], then normalised), drawn from ``seed``."""
        return cls(_core.Policy.start(core_world(world), levels, "random", seed))

    @classmethod
    def clock(cls, world: World, levels: Sequence[int]) -> Policy:
        """A two-level policy whose memory is a clock, ``m_1[t] = m_2[t] = (t - 1) mod M``, with
        uniform decisions: under CE its ``h0`` becomes a time-indexed plan (levels ``[M, M]``;
        ``M >= T`` gives every step its own row). The structure that solves case 2."""
        return cls(_core.Policy.start(core_world(world), levels, "clock", 0))

    @classmethod
    def from_tables(
        cls,
        tables: Mapping[str, Any],
        world: Any = None,
        provenance: Mapping[str, Any] | None = None,
    ) -> Policy:
        """A policy from its tables (as returned by :attr:`tables`; arrays or nested lists).

        The levels, ``Y`` and ``D`` are read from the shapes; every shape, entry and row is then
        checked. With ``world`` (a cehmm world, or one written in Python), the policy must fit it
        and is stored with it.

        Raises:
            PolicyFormatError: a missing table, a wrong shape (the message names the table and the
                expected shape), a negative or non-finite entry, a row not summing to 1.
            PolicyMismatchError: the tables do not fit ``world``.
        """
        if not isinstance(tables, Mapping):
            raise PolicyFormatError(f"tables is {type(tables).__name__} (expected a dict with h0, h1 and upper)")
        h0 = _array(tables, "h0")
        h1 = _array(tables, "h1")
        upper_entries = tables.get("upper", [])
        if isinstance(upper_entries, Mapping) or not isinstance(upper_entries, Sequence):
            raise PolicyFormatError("upper is not a list (expected [{'start': array, 'step': array}, ...])")
        upper = []
        for k, entry in enumerate(upper_entries):
            if not isinstance(entry, Mapping):
                raise PolicyFormatError(f"upper[{k}] is not a dict (expected {{'start': array, 'step': array}})")
            upper.append((_array(entry, "start", f"upper[{k}]."), _array(entry, "step", f"upper[{k}].")))
        core = None if world is None else core_world(world)
        return cls(_core.Policy.from_tables(h0, h1, upper, core, None if provenance is None else dict(provenance)))

    @classmethod
    def load(cls, path: PathLike) -> Policy:
        """Reads and checks a policy file (JSON, model §6).

        Raises:
            PolicyFormatError: not a valid policy file; the message names the file, the table (or
                the field of the world's recorded spaces) and what was expected.
            OSError: the file cannot be read (e.g. ``FileNotFoundError``).
        """
        policy = cls(_core.Policy.load(os.fspath(path)))
        policy._encodings(f"policy file {os.fspath(path)}")
        return policy

    @classmethod
    def from_json(cls, text: str) -> Policy:
        """Reads and checks a policy document (model §6) from its JSON text."""
        if not isinstance(text, str):
            raise TypeError(f"invalid text: {text!r} (expected a str of JSON)")
        policy = cls(_core.Policy.from_json(text))
        policy._encodings("policy document")
        return policy

    def save(self, path: PathLike, *, overwrite: bool = False) -> None:
        """Writes the policy file (JSON, model §6), atomically (through a temporary file).

        Raises:
            InvalidArgumentError: ``path`` exists and ``overwrite`` is not set (the command line's
                ``--force``), or is a directory or a device.
        """
        self._core.save(os.fspath(path), overwrite=overwrite)

    def to_json(self) -> str:
        """The policy document (model §6) as JSON text."""
        return self._core.to_json()

    # -- description ---------------------------------------------------------------------------

    @property
    def tables(self) -> Tables:
        """The tables as float64 arrays (fresh copies; shapes in the class docstring)."""
        return self._core.tables()

    @property
    def levels(self) -> list[int]:
        """Memory sizes per level, bottom first."""
        return self._core.levels

    @property
    def n_obs(self) -> int:
        """Number of observations ``Y``."""
        return self._core.n_obs

    @property
    def n_actions(self) -> int:
        """Number of decisions ``D``."""
        return self._core.n_actions

    @property
    def parameter_count(self) -> int:
        """The paper's number of free parameters, start tables excluded (model §2): 4320 for
        levels ``[16, 16]`` with ``Y = D = 16``, 758 for ``[16, 2, 2, 2]``."""
        return self._core.parameter_count

    @property
    def world(self) -> dict[str, Any]:
        """The world the policy was made for, as stored in its file (empty when unknown)."""
        return self._core.world

    @property
    def provenance(self) -> dict[str, Any]:
        """How the policy was made (seed, samples, rho, iterations, mean reward, ...)."""
        return self._core.provenance

    # -- use ---------------------------------------------------------------------------------------

    def evaluate(
        self,
        world: Any = None,
        episodes: int = 10000,
        seed: int = 0,
        threads: int | None = None,
        backend: str | Backend = "local",
        workers: int | None = None,
        address: str | None = None,
    ) -> Evaluation:
        """The reward over ``episodes`` fresh episodes (reproducible from ``seed``, whatever ``threads``).

        Args:
            world: the world (default: the one stored with the policy); or a world written in
                Python, a Gymnasium environment (see :class:`~cehmm.PythonWorld`).
            episodes: number of episodes.
            seed: seed of the episodes; episode ``k`` is :meth:`rollout` ``(world, seed, episode=k)``.
            threads: worker threads (default: one per core).
            backend: ``"local"``, ``"ray"`` (the episodes run in shards on a Ray cluster, the
                same rewards) or a :class:`~cehmm.RayBackend` (see :func:`~cehmm.optimize`).
            workers: with ``backend="ray"``: shards (default: the cluster's CPUs).
            address: with ``backend="ray"``: the cluster to join.

        Raises:
            PolicyMismatchError: the policy's ``Y`` or ``D`` differ from the world's.
        """
        world = self._world(world)
        sampled = sampled_world(core_world(world), world, {}, backend, workers, address)
        return evaluation(self._core.evaluate(sampled, episodes, seed, threads))

    def evaluate_exact(
        self,
        world: World | None = None,
        *,
        horizon: int | None = None,
        infinite: bool = False,
        tolerance: float = 1e-6,
    ) -> ExactValue:
        """The exact expected reward on a tabular world (:class:`~cehmm.PomdpWorld`, model §7).

        Args:
            world: the world (default: the one stored with the policy).
            horizon: steps (default: the world's horizon).
            infinite: the infinite-horizon discounted value instead (a discount below 1),
                computed to within ``tolerance`` (absolute; see :attr:`ExactValue.tail_bound`).

        Raises:
            InvalidArgumentError: the world is not tabular, or ``infinite`` with a discount of 1.
            PolicyMismatchError: the policy's ``Y`` or ``D`` differ from the world's.
        """
        return ExactValue(**self._core.evaluate_exact(core_world(self._world(world)), horizon, infinite, tolerance))

    def graph(self, world: World | None = None, form: str = "text", prune: float = _core.GRAPH_PRUNE) -> Any:
        """The policy as a finite-state controller (a policy graph) on a tabular world.

        Its nodes are the memories reachable from the start; each node takes a decision and each
        observation moves it to a next node, with the policy's probabilities.

        Args:
            world: the world (default: the one stored with the policy).
            form: ``"text"`` (a str in the file's own names), ``"json"`` (a dict in those names),
                ``"dot"`` (Graphviz's DOT language, a str: ``dot -Tpng``; drawn without Graphviz
                by :func:`cehmm.plots.policy_graph`) or ``"pg"`` (pomdp-solve's policy-graph
                format ``N A Z1 Z2 ...``, node 0 the initial one; deterministic policies only).
            prune: laws of this probability or less are left out (and the memories only they
                reach): a learned policy keeps small probabilities everywhere (default 0.001; 0
                keeps all but rounding noise, below 1e-12).

        Raises:
            InvalidArgumentError: the world is not tabular, or ``"pg"`` for a policy that is not
                deterministic.
        """
        return self._core.graph(core_world(self._world(world)), form, prune)

    def most_likely(self) -> Policy:
        """The most likely policy: every law at its likeliest outcome (the first of equals), a
        deterministic controller with the same memory; ``graph(form="pg")`` takes it."""
        return Policy(self._core.most_likely())

    def agent(self, seed: int = 0) -> Agent | EnvAgent:
        """This policy as an agent for any loop (a Gymnasium loop, a robot's): ``agent.reset()`` at
        the start of each episode, then ``agent.act(observation) -> decision`` at each step; the
        memory is kept between calls. Its draws come from ``seed`` (episode ``k`` after ``k``
        resets has its own stream). Observations are the world's indices (``0..n_obs``); for a
        policy learnt on a Gymnasium environment, an :class:`~cehmm.encoded.EnvAgent` that takes
        the observations the environment returns and answers actions of its action space,
        through the encodings the policy file recorded (:mod:`cehmm.spaces`).

        Example:
            >>> world = TargetTracking(case=1)
            >>> agent = Policy.uniform(world, [4]).agent(seed=3)
            >>> agent.reset()
            >>> agent.act(0) in range(world.n_decisions)
            True
        """
        found = self._encodings()
        agent = Agent(self._core, seed)
        return agent if found is None else EnvAgent(agent, *found)

    def rollout(self, world: Any = None, seed: int = 0, episode: int = 0) -> Rollout:
        """One recorded episode: episode ``episode`` of :meth:`evaluate` with the same ``seed``
        (for a world written in Python, run alone: the very episode of :meth:`evaluate` for the
        episode protocol; for a batched world, the policy's draws of that episode, the world's
        own of a batch of one; ``x`` is empty, the hidden state being the world's business).

        Returns:
            a :class:`Rollout` with ``x`` (T × 8 for target tracking), ``x_labels``, ``y``, ``d``,
            ``memory`` (T × Λ) and ``reward``.

        Raises:
            PolicyMismatchError: the policy's ``Y`` or ``D`` differ from the world's.
        """
        return Rollout(**self._core.rollout(core_world(self._world(world)), seed, episode))

    def _world(self, world: Any) -> Any:
        if world is not None:
            found = self._encodings() if isinstance(world, str) or _is_gym_env(world) else None
            # A Gymnasium environment met again: through the encodings the policy was learnt with.
            return world if found is None else PythonWorld(world, observations=found[0], actions=found[1])
        stored = self.world
        if not stored:
            raise InvalidArgumentError("invalid world: None (expected a cehmm world: this policy has no stored world)")
        return World.from_dict(stored)

    def _encodings(self, source: str = "policy") -> tuple[Any, Any] | None:
        """The encodings of the Gymnasium spaces the policy's world records, checked against it
        (:func:`cehmm.encoded.policy_encodings`), or None."""
        return policy_encodings(self.world, self.n_obs, self.n_actions, source)

    def __reduce__(self) -> tuple[Any, ...]:
        return (Policy.from_json, (self.to_json(),))

    def __repr__(self) -> str:
        world = self.world
        where = f", world={world_title(world)}" if world else ""
        mean = self.provenance.get("mean_reward")
        score = f", mean_reward={mean:.2f}" if isinstance(mean, (int, float)) else ""
        return (
            f"Policy(levels={self.levels}, n_obs={self.n_obs}, n_actions={self.n_actions}, "
            f"parameters={self.parameter_count}{where}{score})"
        )


def _array(tables: Mapping[str, Any], key: str, prefix: str = "") -> np.ndarray:
    """A table as a C-contiguous float64 array, or a :class:`PolicyFormatError` naming it."""
    if key not in tables:
        raise PolicyFormatError(f"{prefix}{key} is missing")
    try:
        return np.ascontiguousarray(tables[key], dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise PolicyFormatError(f"{prefix}{key} is not an array of numbers ({e})") from None
