"""Stub of the compiled engine ``cehmm._core`` (crates/cehmm-py/src/lib.rs).

Private: use the ``cehmm`` package. Arguments are typed as the bindings extract them; the Python
layer checks types first. Arrays are numpy arrays: tables float64, rollouts int64.
"""

import os
from typing import Any, TypedDict, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "CehmmError",
    "InvalidArgumentError",
    "PolicyFormatError",
    "PolicyMismatchError",
    "TargetTracking",
    "Policy",
    "optimize",
    "QLearner",
    "evaluate_policy_windows",
    "epsilon",
    "ENGINE_VERSION",
    "CE_DEFAULTS",
    "DEFAULT_LEVELS",
    "WEAK_PATIENCE",
    "STRONG_PATIENCE",
    "WINDOW_DEFAULTS",
    "Q_DEFAULTS",
    "PAPER_REFERENCE",
]

ENGINE_VERSION: str
#: ``CeConfig::default()``: samples, rho, smoothing, patience, seed, eval_episodes, memory_update, restarts.
CE_DEFAULTS: dict[str, Any]
DEFAULT_LEVELS: list[int]
WEAK_PATIENCE: int
STRONG_PATIENCE: int
#: ``WindowConfig::default()``: window, episodes, chains, burn_in, windows_per_chain.
WINDOW_DEFAULTS: dict[str, int]
#: ``QConfig::default()`` and the checkpoint interval: gamma, alpha, ties, checkpoint_every.
Q_DEFAULTS: dict[str, Any]
PAPER_REFERENCE: float

class CehmmError(ValueError):
    """Base class of the errors raised by cehmm."""

class InvalidArgumentError(CehmmError):
    """An argument outside its domain or of the wrong type (``ceworld::Error::InvalidArgument``)."""

class PolicyFormatError(CehmmError):
    """An invalid policy file or table (``ceworld::Error::PolicyFormat``)."""

class PolicyMismatchError(CehmmError):
    """A policy whose observation or decision count differs from the world's (``ceworld::Error::Mismatch``)."""

# ``ceworld::Error::Io`` is raised as the built-in ``OSError`` subclass of its errno, with ``filename``.

class EvaluationDict(TypedDict):
    episodes: int
    mean: float
    std_error: float
    std: float
    min: float
    max: float
    quantiles: dict[float, float]

class UpperTables(TypedDict):
    start: npt.NDArray[np.float64]  # (U, |M_l|)
    step: npt.NDArray[np.float64]  # (|M_{l-1}|, U, |M_l|)

class TablesDict(TypedDict):
    h0: npt.NDArray[np.float64]  # (|M_1|, D)
    h1: npt.NDArray[np.float64]  # (Y, U, |M_1|)
    upper: list[UpperTables]  # levels 2..Λ

class RolloutDict(TypedDict):
    x: npt.NDArray[np.int64]  # (T, k), k = len(x_labels)
    x_labels: list[str]
    y: npt.NDArray[np.int64]  # (T,)
    d: npt.NDArray[np.int64]  # (T,)
    memory: npt.NDArray[np.int64]  # (T, Λ)
    reward: float

class HistoryDict(TypedDict):
    iteration: npt.NDArray[np.int64]  # (iterations,)
    mean: npt.NDArray[np.float64]
    best: npt.NDArray[np.float64]
    elite_threshold: npt.NDArray[np.float64]
    elite_mean: npt.NDArray[np.float64]
    seconds: npt.NDArray[np.float64]
    successful: npt.NDArray[np.bool_]

class OptimizeDict(TypedDict):
    policy: Policy
    last_policy: Policy
    history: HistoryDict
    evaluation: EvaluationDict
    stop_reason: str
    interrupted: bool
    best_iteration: int
    iterations: int
    seconds: float

@final
class TargetTracking:
    """``ceworld::TargetTracking``: the world of model §4."""

    def __new__(cls, case: int | None = None, **params: int | list[int] | tuple[int, int]) -> TargetTracking: ...
    @property
    def case(self) -> int: ...
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
    def optimum(self) -> int: ...

@final
class Policy:
    """``ceworld::PolicyFile``: an HHMM policy with its world and provenance (model §6)."""

    @staticmethod
    def uniform(world: TargetTracking, levels: list[int]) -> Policy: ...
    @staticmethod
    def random(world: TargetTracking, levels: list[int], seed: int) -> Policy: ...
    @staticmethod
    def clock(world: TargetTracking, levels: list[int]) -> Policy: ...
    @staticmethod
    def from_tables(
        h0: npt.NDArray[np.float64],
        h1: npt.NDArray[np.float64],
        upper: list[tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]],
        world: TargetTracking | None = None,
        provenance_json: str | None = None,
    ) -> Policy: ...
    @staticmethod
    def load(path: str | os.PathLike[str]) -> Policy: ...
    @staticmethod
    def from_json(text: str) -> Policy: ...
    def save(self, path: str | os.PathLike[str]) -> None: ...
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
        self, world: TargetTracking, episodes: int, seed: int, threads: int | None = None
    ) -> EvaluationDict: ...
    def rollout(self, world: TargetTracking, seed: int, episode: int = 0) -> RolloutDict: ...

def optimize(
    world: TargetTracking,
    initial: Policy,
    *,
    samples: int,
    rho: float,
    smoothing: float,
    patience: int,
    max_iterations: int | None,
    time_limit: float | None,
    target: float | None,
    seed: int,
    threads: int | None,
    eval_episodes: int,
    progress: bool,
    memory_update: str = "sampled",
    restarts: int = 1,
) -> OptimizeDict: ...

class WindowsDict(TypedDict):
    from_start: EvaluationDict  # (a) one window from each fresh start
    continuing: EvaluationDict  # (b) consecutive windows of continuing runs after a burn-in

class TrainDict(TypedDict):
    updates: int
    seconds: float
    interrupted: bool
    checkpoints: int

def epsilon(t: int) -> float: ...
def evaluate_policy_windows(
    policy: Policy,
    world: TargetTracking,
    *,
    window: int,
    episodes: int,
    chains: int,
    burn_in: int,
    windows_per_chain: int,
    seed: int,
    threads: int | None = None,
) -> WindowsDict: ...

@final
class QLearner:
    """``ceworld::QLearner<TargetTracking>``: a Q-learning run (table, counters, random stream, world state).

    ``QLearner(...)`` and ``load`` raise ``MemoryError`` when the table would not fit in memory.
    """

    def __new__(cls, world: TargetTracking, *, gamma: float, alpha: float, seed: int, ties: str) -> QLearner: ...
    @staticmethod
    def load(path: str | os.PathLike[str]) -> QLearner: ...
    def save(self, path: str | os.PathLike[str]) -> None: ...
    def train(
        self,
        until: int,
        *,
        progress: bool,
        checkpoint: str | os.PathLike[str] | None = None,
        checkpoint_every: float | None = None,
    ) -> TrainDict: ...
    def evaluate_windows(
        self,
        world: TargetTracking,
        *,
        window: int,
        episodes: int,
        chains: int,
        burn_in: int,
        windows_per_chain: int,
        seed: int,
        threads: int | None = None,
        ties: str | None = None,
    ) -> WindowsDict: ...
    @property
    def updates(self) -> int: ...
    @property
    def n_states(self) -> int: ...
    @property
    def n_actions(self) -> int: ...
    @property
    def table_bytes(self) -> int: ...
    @property
    def gamma(self) -> float: ...
    @property
    def alpha(self) -> float: ...
    @property
    def seed(self) -> int: ...
    @property
    def ties(self) -> str: ...  # "random" or "lowest"
    @property
    def reward_total(self) -> float: ...
    @property
    def seconds(self) -> float: ...
    def header(self) -> dict[str, Any]: ...
    def world(self) -> dict[str, Any]: ...
    def table(self) -> npt.NDArray[np.float32]: ...  # (n_states, n_actions)
    def row(self, state: int) -> npt.NDArray[np.float32]: ...  # (n_actions,)
    def state_index(self, state: list[int], y: int) -> int: ...
