"""Sizes refused before any work, never an abort, and a time limit that holds (issue 45, items 6,
7, 8, 13 and 17): each case runs as a user would, the memory-hungry ones in a subprocess under a
limited address space, where an allocation past it would abort the process."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import time
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces

import cehmm
from cehmm.spaces import Hashed

#: The address space the subprocesses may map: enough for the interpreter, numpy, the engine's
#: thread pools and a small search, far below what the refused searches would take.
LIMIT_BYTES = 6 << 30

#: A world of `Y` observations and `D` decisions (random observations, five steps, reward for
#: decision 0), made in the subprocesses from this text.
WORLD = """
import gymnasium as gym
class Wide(gym.Env):
    def __init__(self, y, d):
        self.observation_space, self.action_space = gym.spaces.Discrete(y), gym.spaces.Discrete(d)
    def reset(self, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        return int(self.np_random.integers(self.observation_space.n)), {}
    def step(self, a):
        self.t += 1
        return int(self.np_random.integers(self.observation_space.n)), float(a == 0), self.t >= 5, False, {}
"""


def _limited(body: str) -> subprocess.CompletedProcess[str]:
    """`body` run by a fresh interpreter whose address space is limited to LIMIT_BYTES."""
    script = (
        "import resource\n"
        f"resource.setrlimit(resource.RLIMIT_AS, ({LIMIT_BYTES}, {LIMIT_BYTES}))\n"
        "import cehmm\n" + WORLD + textwrap.dedent(body)
    )
    return subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)


def test_registers_past_a_u32_are_refused_not_truncated_and_nothing_aborts() -> None:
    done = _limited(
        """
        try:
            cehmm.optimize_controller(Wide(4, 2), search="ce", memory="registers", registers=2**32 + 2, register_size=2,
                                      max_iterations=1, progress=False)
        except cehmm.InvalidArgumentError as e:
            print("refused:", e)
        """
    )
    assert done.returncode == 0, done.stderr
    assert "refused: invalid registers: 4294967298 of register_size 2" in done.stdout


def test_registers_past_a_u32_are_refused_by_the_command_line() -> None:
    done = subprocess.run(
        ["cehmm", "controller", "--case", "1", "--registers", "4294967298", "--memory", "registers"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode != 0 and "invalid registers: 4294967298" in done.stderr, done.stderr


def test_a_search_whose_policy_file_would_not_be_read_back_is_refused_before_it_starts() -> None:
    # 64 Mealy nodes on 2048 observations and 16 decisions: up to 1024 pairs, 134 million
    # entries, a policy file of at least 537 MB (the engine reads 256 MiB): refused at once,
    # naming the setting, where it used to take 3.7 GB and abort while saving.
    done = _limited(
        """
        import time
        start = time.perf_counter()
        try:
            cehmm.optimize_controller(Wide(2048, 16), search="ce", nodes=64, memory="nodes", horizon=5, progress=False)
        except cehmm.InvalidArgumentError as e:
            print("refused:", e)
        print("seconds:", time.perf_counter() - start)
        """
    )
    assert done.returncode == 0, done.stderr
    assert "refused: invalid nodes: nodes 64 (64 nodes) with Mealy decisions on 2048 observations" in done.stdout
    assert "a policy file may have to be read back" in done.stdout
    # Before any episode: no warm-up, no iteration (a generous bound on a loaded machine).
    assert float(done.stdout.split("seconds:")[1]) < 30


class Board(gym.Env):
    """A 52-part board of 3 values each and 104 decisions (Concentration's shape): one step of
    an empty board."""

    observation_space = spaces.MultiDiscrete([3] * 52)
    action_space = spaces.Discrete(104)

    def reset(self, seed: int | None = None, options: Any = None) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        return np.zeros(52, dtype=np.int64), {}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        return np.zeros(52, dtype=np.int64), float(int(action) == 0), True, False, {}


def test_each_memory_is_bounded_with_its_own_decisions_and_named_by_its_own_setting() -> None:
    # On 1024 cells: the registers' 64 Mealy nodes may not fit, and the refusal names them (not
    # `nodes`, which the user set to 2); the clock's 64 Moore nodes and 2 flat nodes fit.
    big = cehmm.PythonWorld(Board(), observations=Hashed(1024), horizon=10)
    with pytest.raises(cehmm.InvalidArgumentError, match=r"^invalid registers: registers 3 of register_size 4") as e:
        cehmm.optimize_controller(big, nodes=2, max_iterations=1, progress=False, search="ce")
    assert "nodes 64" not in str(e.value)
    for memory in ("nodes", "clock"):
        result = cehmm.optimize_controller(
            big,
            nodes=2,
            memory=memory,
            samples=10,
            episodes=1,
            select_episodes=2,
            eval_episodes=2,
            max_iterations=1,
            progress=False,
            search="ce",
        )
        assert result.stop_reason == "max_iterations"


class Slow(gym.Env):
    """Ten steps of a bit to repeat, each taking about a millisecond: an evaluation of 100,000
    episodes takes about 17 minutes."""

    observation_space = spaces.Discrete(2)
    action_space = spaces.Discrete(2)

    def reset(self, seed: int | None = None, options: Any = None) -> tuple[int, dict[str, Any]]:
        super().reset(seed=seed)
        self.t, self.bit = 0, int(self.np_random.integers(2))
        return self.bit, {}

    def step(self, action: Any) -> tuple[int, float, bool, bool, dict[str, Any]]:
        time.sleep(0.001)
        self.t += 1
        reward = float(int(action) == self.bit)
        self.bit = int(self.np_random.integers(2))
        return self.bit, reward, self.t >= 10, False, {}


@pytest.mark.parametrize("optimiser", ["optimize", "optimize_controller", "run"])
def test_the_time_limit_holds_the_final_evaluation(optimiser: str) -> None:
    limit = 3.0
    common: dict[str, Any] = dict(time_limit=limit, eval_episodes=100_000, progress=False, horizon=10)
    start = time.perf_counter()
    if optimiser == "optimize":
        result = cehmm.optimize(Slow(), levels=[2], samples=20, **common)
    elif optimiser == "optimize_controller":
        result = cehmm.optimize_controller(
            Slow(), nodes=2, samples=10, episodes=2, select_episodes=10, **common, search="ce"
        )
    else:
        result = cehmm.run("random-search", Slow(), samples=5, episodes=2, **common)
    wall = time.perf_counter() - start
    # The limit, and one slice of the evaluation past it (a few episodes here) on a loaded machine.
    assert wall < limit + 2.0, f"{wall:.1f} s for a {limit} s limit"
    assert result.stop_reason == "time_limit"
    assert 0 < result.evaluation.episodes < 100_000
    assert np.isfinite(result.evaluation.mean)
