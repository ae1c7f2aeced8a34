"""An optimiser given by its iteration step (``ceworld::run::OPTIMISERS``; issue 30): the random
search over controllers reaches Python (``cehmm.run``) and the command line (``cehmm run``) by
its registration alone, with settings by name, the progress line, the history, checkpoints
resumed bit for bit, and worlds written in Python (the Ray backend: tests/test_ray.py)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from worlds import Corridor

import cehmm

TIGER = Path(__file__).parents[1] / "data" / "pomdp" / "tiger.95.POMDP"
SETTINGS = dict(nodes=3, samples=40, episodes=20, eval_episodes=500, progress=False)


def test_its_settings_and_defaults_come_from_the_registry() -> None:
    defaults = cehmm.stepped.OPTIMISERS["random-search"]
    assert defaults["nodes"] == 4 and defaults["max_iterations"] is None
    with pytest.raises(cehmm.InvalidArgumentError, match='"anneal"'):
        cehmm.run("anneal", Corridor(), progress=False)
    with pytest.raises(cehmm.InvalidArgumentError, match='setting: "speed"'):
        cehmm.run("random-search", Corridor(), speed=1, progress=False)
    with pytest.raises(TypeError, match="nodes"):
        cehmm.run("random-search", Corridor(), nodes="3", progress=False)


def test_it_runs_on_engine_worlds_and_worlds_written_in_python() -> None:
    tiger = cehmm.PomdpWorld(TIGER, horizon=20)
    result = cehmm.run("random-search", tiger, max_iterations=5, **SETTINGS)
    assert result.stop_reason == "max_iterations" and len(result.history["mean"]) == 5
    assert result.policy.levels == [3, 3]
    assert result.policy.provenance["method"] == "random-search"
    assert np.all(np.diff(result.history["best"]) >= 0)
    corridor = cehmm.run("random-search", Corridor(), max_iterations=3, **SETTINGS)
    assert corridor.evaluation.episodes == 500
    # The same seed, the same search, whatever the threads.
    again = cehmm.run("random-search", tiger, max_iterations=5, threads=1, **SETTINGS)
    assert again.policy.to_json() == result.policy.to_json()


def test_a_run_resumes_from_its_checkpoint(tmp_path: Path) -> None:
    tiger = cehmm.PomdpWorld(TIGER, horizon=20)
    whole = cehmm.run("random-search", tiger, max_iterations=8, **SETTINGS)
    path = tmp_path / "search.ckpt"
    cehmm.run("random-search", tiger, max_iterations=3, checkpoint=path, resume=True, **SETTINGS)
    rest = cehmm.run("random-search", tiger, max_iterations=8, checkpoint=path, resume=True, **SETTINGS)
    assert list(rest.history["best"]) == list(whole.history["best"])
    assert rest.evaluation == whole.evaluation
    with pytest.raises(cehmm.PolicyMismatchError, match="nodes 3, not 4"):
        cehmm.run("random-search", tiger, checkpoint=path, resume=True, **{**SETTINGS, "nodes": 4})


def test_the_command_line_runs_it_by_name(tmp_path: Path) -> None:
    def cli(*args: str) -> subprocess.CompletedProcess[str]:
        command = [sys.executable, "-m", "cehmm.cli", "run", "random-search", *args]
        return subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=120)

    listed = cli("--list")
    assert listed.returncode == 0 and "nodes = 4" in listed.stdout, listed.stderr
    sets = ["--set", "nodes=3", "--set", "samples=40", "--set", "episodes=20", "--set", "eval_episodes=500"]
    done = cli("--pomdp", str(TIGER), "--horizon", "20", *sets, "--set", "max_iterations=4", "--history", "h.jsonl")
    assert done.returncode == 0, done.stderr
    assert "max_iterations: 4 iterations" in done.stdout
    assert "iter " in done.stderr  # the progress line
    policy = json.loads((tmp_path / "policy.json").read_text())
    assert policy["provenance"]["method"] == "random-search" and policy["provenance"]["nodes"] == 3
    assert len((tmp_path / "h.jsonl").read_text().splitlines()) == 4
    bad = cli("--pomdp", str(TIGER), "--set", "nodes=0", "--out", "other.json")
    assert bad.returncode == 2 and "invalid nodes: 0" in bad.stderr


class EchoNoisy:
    """A ``Box`` observation of two parts, a noise and a card (0 or 1): each step after the first
    pays 1 for naming the card one step back (8 steps: 7 at best)."""

    def __init__(self) -> None:
        import gymnasium

        self.observation_space = gymnasium.spaces.Box(0.0, 1.0, shape=(2,))
        self.action_space = gymnasium.spaces.Discrete(2)
        self.rng = np.random.default_rng(0)

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        self.rng = np.random.default_rng(seed)
        self.t, self.before = 0, -1
        return self._observe(), {}

    def _observe(self) -> np.ndarray:
        self.card = int(self.rng.integers(2))
        return np.array([self.rng.random(), float(self.card)], dtype=np.float32)

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict]:
        reward = float(int(action) == self.before)
        self.before, self.t = self.card, self.t + 1
        return self._observe(), reward, False, self.t >= 8, {}


def test_the_search_of_memories_looks_at_the_parts_of_a_box_observation() -> None:
    # Issue 47: the encoding's bins per dimension reach the engine (the description's radices),
    # whose lenses may look at the card's dimension alone, a step back.
    world = cehmm.PythonWorld(EchoNoisy(), horizon=8)
    assert world.description["spaces"]["observation"]["radices"] == [16, 3]
    settings = dict(memories=50, rounds=3, threads=1, seed=0, eval_episodes=200, progress=False)
    result = cehmm.run("model-search", world, max_env_steps=10_000, **settings)
    assert result.evaluation.mean == 7.0


def test_the_search_of_memories_on_the_model_of_every_step_learns_a_latch_within_its_budget() -> None:
    # Issue 47: the T-maze's cue held through a corridor of 4, learnt from 20,000 steps of the
    # world (every step serving every memory ranked on the model), its value the optimum.
    from cehmm.memory_tasks import TMaze

    maze = TMaze(corridor=4)
    result = cehmm.run("model-search", maze, max_env_steps=20_000, memories=100, rounds=5, seed=0, progress=False)
    assert result.stop_reason in ("max_env_steps", "patience")
    # Past the budget by one explorer's episodes at most (the selection keeps within it).
    assert 0 < result.env_steps <= 20_000 + 4 * maze.horizon
    assert result.evaluation.mean == pytest.approx(1.0)
    assert result.policy.provenance["method"] == "model-search"
    # A world whose value is of the whole episode (the paper's target tracking) is refused,
    # naming why.
    with pytest.raises(cehmm.InvalidArgumentError, match="not the \\(discounted\\) sum of its steps' rewards"):
        cehmm.run("model-search", cehmm.TargetTracking(case=1), max_iterations=1, progress=False)
    # A .pomdp file's world gives its steps' rewards: on tiger, 10,000 steps learn to open a door
    # (listening forever is worth -(1 - 0.95^20) / 0.05 = -12.83 over 20 steps). Seeds 0-4 give
    # -10.18, -8.65, -9.97, -7.58 and -8.42 (each explorer on episodes of its own; before,
    # sharing them, -11.41, -13.45, -3.48, -8.22, -10.30): tiger's doors are a weak spot.
    tiger = cehmm.run("model-search", cehmm.PomdpWorld(TIGER, horizon=20), max_env_steps=10_000, progress=False)
    assert tiger.evaluation.mean > -12.83
