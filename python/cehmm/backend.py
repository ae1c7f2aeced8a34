"""What a backend is: where an optimisation's episodes are sampled when not here (model §9).

The optimisers run on the driver; each iteration a :class:`~cehmm._core.RemoteWorld` asks its
:class:`Sampler` for the rewards of a range of episodes, the counts of the elite, or the values
of a batch of controllers, each answered at once by a :class:`Pending` that the engine waits
for in short slices (so that Ctrl-C cancels what is still running). A :class:`Backend` (such as
:class:`cehmm.RayBackend`) binds a world to its sampler; ``backend=`` of every optimiser takes
one. The engine names the same methods (``_core.BACKEND_METHODS``, ``_core.PENDING_METHODS``):
tests/test_backend.py holds the two to each other.

Policies and controllers travel as JSON text; episode ``k`` of ``(seed, purpose, iteration)``
must be sampled from its own random stream (the engine's ``_core.controller_values`` and the
worker functions of :mod:`cehmm.ray_backend` do), so that a backend gives the local result, bit
for bit.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt


@runtime_checkable
class Pending(Protocol):
    """An answer on its way.

    Example:
        >>> class Done:
        ...     def __init__(self, values): self.values = values
        ...     def wait(self, timeout): return True
        ...     def result(self): return self.values
        ...     def cancel(self): pass
        >>> isinstance(Done(np.zeros(3)), Pending)
        True
    """

    def wait(self, timeout: float) -> bool:
        """Whether the answer is ready, after at most ``timeout`` seconds."""
        ...

    def result(self) -> npt.NDArray[Any]:
        """The answer: a 1-d numpy array (float64 values, uint32 counts); a failure raised."""
        ...

    def cancel(self) -> None:
        """Stops whatever is still running for this answer."""
        ...


@runtime_checkable
class Sampler(Protocol):
    """The episodes of one world, sampled elsewhere (:class:`Backend` has one that samples
    them here).

    Example:
        >>> from cehmm.ray_backend import RaySampler
        >>> issubclass(RaySampler, Sampler)
        True
    """

    def rewards(self, policy: str, seed: int, purpose: str, iteration: int, first: int, n: int) -> Pending:
        """Rewards of episodes ``first..first + n`` of ``(seed, purpose, iteration)`` under
        ``policy`` (a policy document), then the world's steps they took (``n + 1`` numbers:
        what a budget in steps counts)."""
        ...

    def counts(self, policy: str, seed: int, iteration: int, episodes: npt.NDArray[np.uint64]) -> Pending:
        """The summed counts (the policy's table layout) of ``episodes`` of iteration
        ``iteration``."""
        ...

    def controller_values(self, controllers: str, seed: int, purpose: str, iteration: int, episodes: int) -> Pending:
        """The reward of episodes ``0..episodes`` of each controller, controller after
        controller, then the world's steps they took."""
        ...

    def controller_credit(self, controllers: str, seed: int, purpose: str, iteration: int, episodes: int) -> Pending:
        """As :meth:`controller_values`, with each controller's credit within its episodes (model
        §8), controller after controller: 1.0 where credited (else 0.0), its ``episodes``
        values, then its decision rows' visits and summed credit; then the world's steps they took
        (``_core.controller_credit``)."""
        ...

    def controller_steps(self, controllers: str, seed: int, purpose: str, iteration: int, episodes: int) -> Pending:
        """As :meth:`controller_values`, with every step of each episode, episode after episode
        (what a learner of memory from every step keeps, model §10): its value, 1.0 where
        credited (else 0.0), the discount, its length ``L``, its ``L`` observations, its ``L``
        rewards; then the world's steps they took (``_core.controller_steps``)."""
        ...

    def exact_values(self, controllers: str, tolerance: float) -> Pending:
        """The exact value of each controller (a tabular world), to ``tolerance``."""
        ...


@runtime_checkable
class Backend(Protocol):
    """Binds a world to the :class:`Sampler` of its episodes.

    Example:
        A backend that samples in this process, with the engine's functions that the workers of
        :mod:`cehmm.ray_backend` run, gives the local result, bit for bit:

        >>> from cehmm import _core
        >>> from cehmm.world import core_world
        >>> class Done:
        ...     def __init__(self, values): self.values = values
        ...     def wait(self, timeout): return True
        ...     def result(self): return self.values
        ...     def cancel(self): pass
        >>> class Here:
        ...     def bind(self, world, options):
        ...         return HereSampler(core_world(world, **options))
        >>> class HereSampler:
        ...     def __init__(self, world): self.world = world
        ...     def rewards(self, policy, seed, purpose, iteration, first, n):
        ...         table = _core.Policy.from_json(policy)
        ...         return Done(table.shard_rewards(self.world, seed, purpose, iteration, first, n))
        ...     def counts(self, policy, seed, iteration, episodes):
        ...         table = _core.Policy.from_json(policy)
        ...         return Done(table.rerun_counts(self.world, seed, iteration, episodes))
        ...     def controller_values(self, controllers, seed, purpose, iteration, episodes):
        ...         args = (self.world, controllers, seed, purpose, iteration, episodes)
        ...         return Done(_core.controller_values(*args))
        ...     def controller_credit(self, controllers, seed, purpose, iteration, episodes):
        ...         args = (self.world, controllers, seed, purpose, iteration, episodes)
        ...         return Done(_core.controller_credit(*args))
        ...     def controller_steps(self, controllers, seed, purpose, iteration, episodes):
        ...         args = (self.world, controllers, seed, purpose, iteration, episodes)
        ...         return Done(_core.controller_steps(*args))
        ...     def exact_values(self, controllers, tolerance):
        ...         return Done(_core.controller_exact_values(self.world, controllers, tolerance))
        >>> isinstance(Here(), Backend), isinstance(HereSampler(None), Sampler)
        (True, True)
        >>> world = cehmm.TargetTracking(case=1)
        >>> here = cehmm.optimize(world, levels=[4], samples=200, max_iterations=3, progress=False,
        ...                       backend=Here())
        >>> local = cehmm.optimize(world, levels=[4], samples=200, max_iterations=3, progress=False)
        >>> here.policy.to_json() == local.policy.to_json()
        True
    """

    def bind(self, world: Any, options: dict[str, Any]) -> Sampler:
        """The sampler of ``world`` (an engine world or a world written in Python; ``options``
        those of ``core_world``)."""
        ...
