"""The benchmark's fixed choices: the controllers, the CE settings, the quick subset, the horizon rule, the
default paths."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

#: Controller name -> levels (bottom first). A k-node controller is levels [k, k] (m_2[t] carries
#: m_1[t-1]); [1] is a blind policy (the same action law whatever is seen).
CONTROLLERS: dict[str, list[int]] = {
    "1 node": [1],
    "2 nodes": [2, 2],
    "4 nodes": [4, 4],
    "8 nodes": [8, 8],
    "two-level": [4, 2, 2],
    "8 nodes, slow h0": [8, 8],
    "8 nodes, controller CE": [8, 8],
}

#: Settings that differ for some controllers: "slow h0" refits the decision table at 0.02 while the
#: memory tables keep SMOOTHING, so that the memory takes shape before the decisions settle (model §3).
#: "controller CE" is the search over deterministic controllers ranked by exact values (model §8,
#: :func:`cehmm.optimize_controller` with its own defaults), given CONTROLLER_TIME_FACTOR times the time limit.
CONTROLLER_SETTINGS: dict[str, dict[str, Any]] = {
    "8 nodes, slow h0": {"decision_smoothing": 0.02},
    "8 nodes, controller CE": {"method": "controller"},
}
CONTROLLER_TIME_FACTOR = 30

#: The settings of every job (``default_settings``; each one a flag of the command).
SAMPLES = 2000
RHO = 0.05
SMOOTHING = 0.2
PATIENCE = 100
INIT = "random"
EVAL_EPISODES = 2000
SEED = 0
TIME_LIMIT = 8.0
#: The world's reward: "belief" has the same expected value as "sampled", with less noise for CE.
REWARD = "belief"
#: Absolute tolerance of the exact infinite-horizon value.
TOLERANCE = 1e-4

#: ``--quick``: these files and controllers, this time limit per job.
QUICK_FILES = ["tiger.95.POMDP", "tiger.aaai.POMDP", "1d.POMDP", "shuttle.95.POMDP", "cheese.95.POMDP"]
QUICK_CONTROLLERS = ["1 node", "2 nodes"]
QUICK_TIME_LIMIT = 2.0

#: The training horizon: the steps until γ^t falls below this weight (at most MAX_HORIZON); γ = 1 gets
#: UNDISCOUNTED_HORIZON.
HORIZON_WEIGHT = 0.05
MAX_HORIZON = 200
UNDISCOUNTED_HORIZON = 20

ROOT = Path(__file__).resolve().parents[3]
#: The benchmark files (the repository's copy when this package runs from a checkout).
DEFAULT_DATA_DIR = ROOT / "data" / "pomdp" if (ROOT / "data" / "pomdp").is_dir() else Path("data") / "pomdp"
#: ``--out``: the report is OUT/benchmarks.md, the data OUT/data/benchmarks.jsonl.
DEFAULT_OUT = Path("docs")
REPORT_NAME = "benchmarks.md"
JSONL_NAME = "benchmarks.jsonl"


def horizon(discount: float) -> int:
    """``min(200, ceil(log 0.05 / log γ))`` for γ < 1 (59 for 0.95); 20 for γ = 1."""
    if discount >= 1.0:
        return UNDISCOUNTED_HORIZON
    return min(MAX_HORIZON, math.ceil(math.log(HORIZON_WEIGHT) / math.log(discount)))


def default_settings() -> dict[str, Any]:
    """The settings of every job (each a flag of the command): :func:`cehmm.optimize` keywords and ``reward``."""
    return {
        "samples": SAMPLES,
        "rho": RHO,
        "smoothing": SMOOTHING,
        "patience": PATIENCE,
        "init": INIT,
        "reward": REWARD,
        "seed": SEED,
        "time_limit": TIME_LIMIT,
        "eval_episodes": EVAL_EPISODES,
    }
