"""Stub of the compiled engine ``cehmm._core`` (crates/cehmm-py/src/).

Private: use the ``cehmm`` package. The bindings take Python or numpy numbers: a value of the
wrong type raises ``TypeError``, one out of its domain :class:`InvalidArgumentError`. Arrays are
numpy arrays: tables float64, rollouts int64, Q tables float32.
"""

import os
from collections.abc import Callable, Mapping, Sequence
from typing import Any, TypedDict, final

import numpy as np
import numpy.typing as npt

from .backend import Sampler

__all__ = [
    "CehmmError",
    "InvalidArgumentError",
    "PolicyFormatError",
    "PolicyMismatchError",
    "ModelFormatError",
    "InternalError",
    "World",
    "WorldError",
    "OutsideWorld",
    "RemoteWorld",
    "controller_exact_values",
    "controller_values",
    "controller_credit",
    "controller_steps",
    "Policy",
    "cli",
    "read_file",
    "check_distinct",
    "check_writable",
    "optimize",
    "Agent",
    "Session",
    "optimize_controller",
    "run",
    "OPTIMISERS",
    "QLearner",
    "evaluate_policy_windows",
    "epsilon",
    "ENGINE_VERSION",
    "GRAPH_PRUNE",
    "BACKEND_METHODS",
    "PENDING_METHODS",
    "PACKAGE_COMMANDS",
    "CE_DEFAULTS",
    "CONTROLLER_DEFAULTS",
    "INIT_CHOICES",
    "MEMORY_UPDATES",
    "TIES",
    "DEFAULT_LEVELS",
    "WEAK_PATIENCE",
    "STRONG_PATIENCE",
    "WINDOW_DEFAULTS",
    "Q_DEFAULTS",
    "PAPER_REFERENCE",
]

ENGINE_VERSION: str
GRAPH_PRUNE: float
BACKEND_METHODS: list[str]  # what a RemoteWorld asks of its sampler (cehmm.backend.Sampler)
PENDING_METHODS: list[str]  # what it asks of a pending answer (cehmm.backend.Pending)
#: ``CeConfig::default()``: samples, rho, smoothing, patience, seed, eval_episodes, memory_update, restarts.
CE_DEFAULTS: dict[str, Any]
CONTROLLER_DEFAULTS: dict[str, Any]
INIT_CHOICES: list[str]
MEMORY_UPDATES: list[str]
TIES: list[str]
DEFAULT_LEVELS: list[int]
WEAK_PATIENCE: int
STRONG_PATIENCE: int
#: ``WindowConfig::default()`` as it serialises: window, episodes, chains, burn_in, windows_per_chain.
WINDOW_DEFAULTS: dict[str, int]
#: ``QConfig::default()`` as it serialises (gamma, alpha, seed, ties) and the checkpoint interval,
#: checkpoint_every.
Q_DEFAULTS: dict[str, Any]
PAPER_REFERENCE: float
#: Every optimiser given by its step (``ceworld::run::OPTIMISERS``): name -> its settings with their defaults.
OPTIMISERS: dict[str, dict[str, Any]]

class CehmmError(ValueError):
    """Base class of the errors raised by cehmm (a ``ValueError``).

    Example:
        >>> try:
        ...     cehmm.TargetTracking(case=4)
        ... except cehmm.CehmmError as error:
        ...     print(type(error).__name__, isinstance(error, ValueError))
        InvalidArgumentError True
    """

class InvalidArgumentError(CehmmError):
    """An argument outside its domain (``ceworld::Error::InvalidArgument``).

    Example:
        >>> cehmm.TargetTracking(case=4)
        Traceback (most recent call last):
        ...
        cehmm.InvalidArgumentError: invalid case: 4 (expected 1, 2 or 3)
    """

class PolicyFormatError(CehmmError):
    """An invalid policy file or table (``ceworld::Error::PolicyFormat``).

    Example:
        >>> cehmm.Policy.from_json("{}")
        Traceback (most recent call last):
        ...
        cehmm.PolicyFormatError: invalid policy: format is missing (expected "cehmm-policy")
    """

class InternalError(CehmmError):
    """A bug: a panic inside the engine, caught (``ceworld::Error::Internal``; please report it).

    Example:
        >>> issubclass(cehmm.InternalError, cehmm.CehmmError)
        True
    """

class ModelFormatError(CehmmError):
    """An invalid ``.pomdp`` file (``ceworld::Error::ModelFormat``): the message names its line
    and column.

    Example:
        >>> with open("bad.POMDP", "w") as f:
        ...     _ = f.write("discount: 2")
        >>> cehmm.PomdpWorld.from_file("bad.POMDP")
        Traceback (most recent call last):
        ...
        cehmm.ModelFormatError: invalid model file bad.POMDP:1:11: discount 2 is out of range (expected ...)
    """

class PolicyMismatchError(CehmmError):
    """A policy whose observation or decision count differs from the world's (``ceworld::Error::Mismatch``).

    Example:
        >>> tiger = cehmm.PomdpWorld.from_file("data/pomdp/tiger.95.POMDP")
        >>> cehmm.Policy.uniform(cehmm.TargetTracking(case=1), [2]).evaluate(tiger, episodes=10)
        Traceback (most recent call last):
        ...
        cehmm.PolicyMismatchError: policy does not match the world: the policy has 16 observations ...
    """

class WorldError(CehmmError):
    """A world written in Python that returned something outside its shape (``ceworld::Error::World``).

    Example:
        >>> class Broken:
        ...     n_observations, n_decisions, horizon = 2, 2, 3
        ...     def reset(self, seed): return 5  # observations are 0 and 1
        ...     def step(self, decision): return 0, 0.0, False
        >>> cehmm.Policy.uniform(Broken(), [2]).evaluate(Broken(), episodes=10)
        Traceback (most recent call last):
        ...
        cehmm.WorldError: world ...Broken, episode 0 (evaluate), reset: observation 5 (expected 0..2)
    """

# ``ceworld::Error::WrongType`` is raised as ``TypeError``; ``ceworld::Error::Io`` as the built-in
# ``OSError`` subclass of its errno, with ``filename``.

class UpperTables(TypedDict):
    start: npt.NDArray[np.float64]  # (U, |M_l|)
    step: npt.NDArray[np.float64]  # (|M_{l-1}|, U, |M_l|)

class TablesDict(TypedDict):
    h0: npt.NDArray[np.float64]  # (|M_1|, D)
    h1: npt.NDArray[np.float64]  # (Y, U, |M_1|)
    upper: list[UpperTables]  # levels 2..Λ

@final
class World:
    """``ceworld::AnyWorld``: any registered world, by name (model §1)."""

    def __new__(cls, name: str, **params: Any) -> World: ...
    def __eq__(self, value: object, /) -> bool: ...
    @staticmethod
    def from_dict(world: Any) -> World: ...
    @staticmethod
    def names() -> list[str]: ...
    @staticmethod
    def defaults(name: str) -> dict[str, Any]: ...
    @property
    def name(self) -> str: ...
    @property
    def n_observations(self) -> int: ...
    @property
    def n_decisions(self) -> int: ...
    @property
    def horizon(self) -> int: ...
    @property
    def params(self) -> dict[str, Any]: ...
    def to_dict(self) -> dict[str, Any]: ...
    def state_labels(self) -> list[str]: ...
    def exact_optimum(self) -> float: ...
    def model(self) -> dict[str, Any]: ...

@final
class RemoteWorld:
    """A world whose episodes a backend samples elsewhere (``cehmm.ray_backend``)."""

    def __new__(cls, backend: Sampler, world: World | OutsideWorld) -> RemoteWorld: ...
    @property
    def backend(self) -> Sampler: ...
    @property
    def description(self) -> dict[str, Any]: ...

@final
class OutsideWorld:
    """A world written in Python (``ceworld::episodes::outside::BatchWorld``), made by ``cehmm.PythonWorld``."""

    def __new__(
        cls,
        world: Any,
        *,
        observations: int,
        decisions: int,
        horizon: int,
        batched: bool,
        batch: int,
        description: dict[str, Any],
        discount: float,
        score: Any | None,
    ) -> OutsideWorld: ...
    @property
    def description(self) -> dict[str, Any]: ...
    @property
    def batch(self) -> int: ...

class _RolloutDict(TypedDict):
    x: npt.NDArray[np.int64]  # (T, k), k = len(x_labels)
    x_labels: list[str]
    y: npt.NDArray[np.int64]  # (T,)
    d: npt.NDArray[np.int64]  # (T,)
    memory: npt.NDArray[np.int64]  # (T, Λ)
    reward: float

class _WindowsDict(TypedDict):
    from_start: dict[str, Any]
    continuing: dict[str, Any]
    reference: float
    shown: str

@final
class Policy:
    """``ceworld::PolicyFile``: an HHMM policy with its world and provenance (model §6)."""

    @staticmethod
    def start(world: World | OutsideWorld, levels: Any, init: str, seed: int) -> Policy: ...
    @staticmethod
    def from_tables(
        h0: npt.NDArray[np.float64],
        h1: npt.NDArray[np.float64],
        upper: list[tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]],
        world: World | OutsideWorld | None = None,
        provenance: dict[str, Any] | None = None,
    ) -> Policy: ...
    @staticmethod
    def load(path: str | os.PathLike[str]) -> Policy: ...
    @staticmethod
    def from_json(text: str) -> Policy: ...
    def save(self, path: str | os.PathLike[str], *, overwrite: bool = False) -> None: ...
    def to_json(self) -> str: ...
    @property
    def levels(self) -> list[int]: ...
    @property
    def n_obs(self) -> int: ...
    @property
    def n_actions(self) -> int: ...
    @property
    def parameter_count(self) -> int: ...
    @property
    def world(self) -> dict[str, Any]: ...
    @property
    def provenance(self) -> dict[str, Any]: ...
    def tables(self) -> TablesDict: ...
    def evaluate(
        self, world: World | OutsideWorld, episodes: int, seed: int, threads: int | None = None
    ) -> dict[str, Any]: ...
    def rollout(self, world: World | OutsideWorld, seed: int, episode: int) -> _RolloutDict: ...
    def shard_rewards(
        self,
        world: World | OutsideWorld,
        seed: int,
        purpose: str,
        iteration: int,
        first: int,
        n: int,
        threads: int | None = None,
    ) -> npt.NDArray[np.float64]: ...
    def rerun_counts(
        self,
        world: World | OutsideWorld,
        seed: int,
        iteration: int,
        episodes: Sequence[int],
        threads: int | None = None,
    ) -> npt.NDArray[np.uint32]: ...
    def evaluate_exact(
        self, world: World | OutsideWorld, horizon: int | None, infinite: bool, tolerance: float
    ) -> dict[str, Any]: ...
    def graph(self, world: World | OutsideWorld, form: str, prune: float) -> Any: ...
    def most_likely(self) -> Policy: ...

#: A run's per-iteration callback: ``callback(record, policy)``, the iteration's record (the
#: history's fields and ``score``) and the best policy so far (``None`` for Q-learning); False
#: stops the run (stop reason ``"callback"``), None or True goes on.
_Callback = Callable[[dict[str, Any], Policy | None], bool | None]

def controller_values(
    world: World | OutsideWorld,
    controllers: str,
    seed: int,
    purpose: str,
    iteration: int,
    episodes: int,
    threads: int | None = None,
) -> npt.NDArray[np.float64]: ...
def controller_credit(
    world: World | OutsideWorld,
    controllers: str,
    seed: int,
    purpose: str,
    iteration: int,
    episodes: int,
    threads: int | None = None,
) -> npt.NDArray[np.float64]: ...
def controller_steps(
    world: World | OutsideWorld,
    controllers: str,
    seed: int,
    purpose: str,
    iteration: int,
    episodes: int,
    threads: int | None = None,
) -> npt.NDArray[np.float64]: ...
def controller_exact_values(
    world: World,
    controllers: str,
    tolerance: float,
    threads: int | None = None,
) -> npt.NDArray[np.float64]: ...
def cli(args: Sequence[str | os.PathLike[str]]) -> int: ...

PACKAGE_COMMANDS: list[tuple[str, str]]

def read_file(path: str | os.PathLike[str], max_bytes: int, what: str) -> bytes: ...
def check_distinct(
    inputs: Sequence[tuple[str, str | os.PathLike[str]]], outputs: Sequence[tuple[str, str | os.PathLike[str]]]
) -> None: ...
def check_writable(option: str, path: str | os.PathLike[str]) -> None: ...
def optimize(
    world: World | OutsideWorld,
    initial: Policy,
    settings: Mapping[str, object],
    *,
    progress: bool,
    checkpoint: str | os.PathLike[str] | None = None,
    checkpoint_every: float | None = None,
    resume: bool | None = None,
    callback: _Callback | None = None,
) -> dict[str, Any]: ...
def optimize_controller(
    world: World | OutsideWorld,
    settings: Mapping[str, object],
    *,
    value: str | None = None,
    search: str | None = None,
    progress: bool,
    checkpoint: str | os.PathLike[str] | None = None,
    checkpoint_every: float | None = None,
    resume: bool | None = None,
    callback: _Callback | None = None,
) -> dict[str, Any]: ...
def run(
    name: str,
    world: World | OutsideWorld | RemoteWorld,
    settings: Mapping[str, object],
    *,
    progress: bool,
    checkpoint: str | os.PathLike[str] | None = None,
    checkpoint_every: float | None = None,
    resume: bool | None = None,
    callback: _Callback | None = None,
) -> dict[str, Any]: ...

@final
class Agent:
    """``ceworld::policy::agent::Agent``: a policy acting one observation at a time."""

    def __new__(cls, policy: Policy, seed: int) -> Agent: ...
    def reset(self) -> None: ...
    def act(self, observation: int) -> int: ...
    @property
    def memory(self) -> list[int]: ...

@final
class Session:
    """``ceworld::world::session::Session``: an episode of a world stepped from outside."""

    def __new__(cls, world: World, seed: int, episode: int) -> Session: ...
    @property
    def observation(self) -> int: ...
    @property
    def t(self) -> int: ...
    @property
    def reward(self) -> float: ...
    def step(self, decision: int) -> tuple[int, float, bool]: ...
    def describe(self) -> list[int]: ...

def epsilon(t: int) -> float: ...
def evaluate_policy_windows(
    policy: Policy,
    world: World,
    settings: Mapping[str, object],
    *,
    seed: int,
    threads: int | None,
    reference: float,
) -> _WindowsDict: ...

@final
class QLearner:
    """``ceworld::qlearn::AnyLearner``: a Q-learning run (table, counters, random stream, world state).

    ``QLearner(...)``, ``load`` and ``resume`` raise ``MemoryError`` when the table would not fit in memory.
    """

    def __new__(cls, world: World, settings: Mapping[str, object]) -> QLearner: ...
    @staticmethod
    def load(path: str | os.PathLike[str]) -> QLearner: ...
    @staticmethod
    def resume(path: str | os.PathLike[str], world: World, settings: Mapping[str, object]) -> QLearner: ...
    def save(self, path: str | os.PathLike[str], *, overwrite: bool = False) -> None: ...
    def train(
        self,
        until: int,
        *,
        progress: bool,
        checkpoint: str | os.PathLike[str] | None = None,
        checkpoint_every: float | None = None,
        callback: _Callback | None = None,
    ) -> str | None: ...
    def evaluate_windows(
        self,
        world: World,
        settings: Mapping[str, object],
        *,
        seed: int,
        threads: int | None,
        reference: float,
        ties: str | None,
    ) -> _WindowsDict: ...
    @property
    def table_bytes(self) -> int: ...
    def header(self) -> dict[str, Any]: ...
    def world(self) -> World: ...
    def table(self) -> npt.NDArray[np.float32]: ...  # (n_states, n_actions)
    def row(self, state: int) -> npt.NDArray[np.float32]: ...  # (n_actions,)
    def state_index(self, state: list[int], y: int) -> int: ...
