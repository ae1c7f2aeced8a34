"""The cross-entropy search over deterministic controllers (model §8) from Python: it reaches
tiger's optimum, its value is the exact value of the policy it returns, it is deterministic
whatever the threads; on sampled values it takes every world (the engine's, Python's in both
protocols), reaches the optimum of tasks that need memory, reports a value from fresh episodes,
and refuses what it cannot search."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import cehmm
from cehmm.memory_tasks import RepeatFirst, RepeatPrevious, TMaze

DATA = Path(__file__).resolve().parents[1] / "data" / "pomdp"


@pytest.fixture(scope="module")
def tiger() -> cehmm.PomdpWorld:
    return cehmm.PomdpWorld.from_file(DATA / "tiger.95.POMDP", horizon=100)


def test_the_result_says_what_the_model_start_was(tiger: cehmm.PomdpWorld) -> None:
    result = cehmm.optimize_controller(tiger, max_iterations=1, progress=False)
    start = result.start
    assert start is not None and set(start) == {"built", "value", "nodes", "blind", "kept"}
    # Tiger's point-based controller is its optimum already (SARSOP [19.3711, 19.3721]); the
    # best blind policy listens for ever: -1 / (1 - 0.95).
    assert start["kept"] and start["nodes"] == result.policy.levels[-1]
    assert start["built"] == pytest.approx(19.3714, abs=1e-3) and start["value"] >= start["built"]
    assert start["blind"] == pytest.approx(-20.0, abs=1e-6)
    assert result.value >= start["value"]
    assert result.policy.provenance["model_start"] == start
    assert cehmm.optimize_controller(tiger, max_iterations=1, model_nodes=0, progress=False).start is None
    sampled = cehmm.optimize_controller(TMaze(corridor=2), max_iterations=1, seed=0, progress=False)
    assert sampled.start is None


def test_tiger_reaches_the_sarsop_value_with_an_exact_value(tiger: cehmm.PomdpWorld) -> None:
    result = cehmm.optimize_controller(tiger, nodes=5, progress=False)
    # SARSOP's bounds are [19.3713, 19.3714] (data/pomdp/SOURCES.md).
    assert result.value > 19.37
    assert result.policy.levels == [5, 5]
    exact = result.policy.evaluate_exact(tiger, infinite=True, tolerance=1e-9)
    assert exact.value == pytest.approx(result.value, abs=2e-6)
    assert result.policy.provenance["method"] == "controller-ce"
    h = result.history
    assert set(h) == {
        "restart",
        "iteration",
        "mean",
        "best",
        "elite_threshold",
        "elite_mean",
        "successful",
        "best_so_far",
        "concentration",
        "evaluated",
        "episodes",
        "injected",
        "grown",
        "widened",
        "seconds",
        "env_steps",
    }
    assert result.kind == "exact" and result.evaluation is None
    assert len(h["best_so_far"]) == len(h["mean"]) and h["best_so_far"][-1] == result.value
    # The fields episode CE's records also have mean the same (an iteration's statistics).
    assert h["iteration"].dtype == np.int64 and h["successful"].dtype == np.bool_
    assert h["episodes"].dtype == np.int64 and not h["episodes"].any()  # exact values run none
    eps = 1e-9  # a mean of equal values may differ from them in the last bit
    assert np.all(h["mean"] <= h["elite_mean"] + eps) and np.all(h["elite_threshold"] <= h["elite_mean"] + eps)
    assert np.all(h["elite_mean"] <= h["best"] + eps)
    # Exact values: the best so far is the running maximum of the iterations' best.
    assert np.all(h["best_so_far"] >= np.maximum.accumulate(h["best"]) - 1e-9)
    assert np.all(np.diff(h["best_so_far"]) >= 0)
    assert result.stop_reason == "patience" and not result.interrupted


def test_results_do_not_depend_on_threads_and_restarts_keep_the_best(tiger: cehmm.PomdpWorld) -> None:
    settings = dict(nodes=3, samples=200, max_iterations=4, restarts=2, progress=False)
    one = cehmm.optimize_controller(tiger, threads=1, **settings)
    two = cehmm.optimize_controller(tiger, threads=2, **settings)
    assert one.value == two.value and one.run_values == two.run_values
    assert one.policy.graph(tiger, "json") == two.policy.graph(tiger, "json")
    assert one.value == max(one.run_values) == one.run_values[one.restart]


def test_what_cannot_be_searched_is_refused(tiger: cehmm.PomdpWorld) -> None:
    with pytest.raises(cehmm.InvalidArgumentError, match="exact values need a tabular world"):
        cehmm.optimize_controller(cehmm.TargetTracking(case=1), value="exact", progress=False)
    with pytest.raises(
        cehmm.InvalidArgumentError, match="exact values need a tabular world: a .pomdp file, a cehmm.PomdpWorld"
    ):
        cehmm.optimize_controller(TMaze(2), value="exact", progress=False)
    with pytest.raises(cehmm.InvalidArgumentError, match='value: "approximate"'):
        cehmm.optimize_controller(tiger, value="approximate", progress=False)
    with pytest.raises(cehmm.InvalidArgumentError, match='template: "latch"'):
        cehmm.optimize_controller(tiger, template="latch", progress=False)
    with pytest.raises(cehmm.InvalidArgumentError, match="template_weight: 1"):
        cehmm.optimize_controller(tiger, template_weight=1.0, progress=False)
    with pytest.raises(cehmm.InvalidArgumentError, match="episodes: 0"):
        cehmm.optimize_controller(tiger, value="sampled", episodes=0, progress=False)
    with pytest.raises(cehmm.InvalidArgumentError, match="candidates: 3000"):
        cehmm.optimize_controller(tiger, candidates=3000, progress=False)
    with pytest.raises(TypeError, match="invalid world"):
        cehmm.optimize_controller(42, progress=False)
    with pytest.raises(cehmm.InvalidArgumentError, match="rho: 2"):
        cehmm.optimize_controller(tiger, rho=2.0, progress=False)
    with pytest.raises(TypeError, match="nodes"):
        cehmm.optimize_controller(tiger, nodes="3", progress=False)  # type: ignore[arg-type]
    with pytest.raises(cehmm.InvalidArgumentError, match="nodes: 0"):
        cehmm.optimize_controller(tiger, nodes=0, progress=False)


def test_a_t_maze_is_solved_on_sampled_values_and_valued_on_fresh_episodes() -> None:
    maze = TMaze(corridor=4)
    result = cehmm.optimize_controller(
        maze, nodes=6, samples=500, rho=0.05, template="hold", progress=False, search="ce"
    )
    assert result.kind == "sampled"
    assert result.value == result.evaluation.mean == pytest.approx(maze.optimum)
    # Each iteration ran its 500 controllers' 20 episodes, and selection episodes.
    assert (result.history["episodes"] >= 500 * 20).all()
    # The evaluation is the policy's own, on the fresh episodes of Policy.evaluate.
    again = result.policy.evaluate(maze, episodes=result.evaluation.episodes, seed=0)
    assert again.mean == result.evaluation.mean
    assert result.policy.provenance["value"] == "sampled"
    assert result.policy.provenance["evaluation_mean"] == result.value
    # Without memory, the junction is a coin toss: the best memoryless policy gets 0.
    memoryless = cehmm.optimize(maze, levels=[3], samples=500, max_iterations=30, progress=False)
    assert memoryless.evaluation.mean < 0.2


def test_repeat_first_is_held_from_a_hold_template() -> None:
    # POPGym's RepeatFirst (the first suit held for 51 steps): the optimum, 1.
    result = cehmm.optimize_controller(
        RepeatFirst(),
        nodes=6,
        samples=500,
        rho=0.05,
        episodes=40,
        template="hold",
        patience=20,
        progress=False,
        search="ce",
    )
    assert result.value == pytest.approx(1.0)
    # Naming the current card: right at the first step, then when a card has the first's suit
    # (12 of the other 51).
    assert RepeatFirst().memoryless == pytest.approx(2 * (1 + 50 * 12 / 51) / 51 - 1)
    # The stage before the memory: the best memoryless policy, kept through the widening.
    history = result.history
    widened = int(np.flatnonzero(history["widened"])[0])
    assert widened >= 10 and int(history["widened"].sum()) == 1
    assert history["best_so_far"][widened] >= RepeatFirst().memoryless - 0.05
    assert result.policy.provenance["decisions"] == "mealy"
    assert result.policy.provenance["memoryless_patience"] == 10


def test_the_memoryless_stage_needs_mealy_decisions() -> None:
    assert cehmm.controller.CONTROLLER_DEFAULTS["sampled"]["decisions"] == "mealy"
    with pytest.raises(cehmm.InvalidArgumentError, match="memoryless_patience.*mealy"):
        cehmm.optimize_controller(RepeatFirst(), decisions="moore", max_iterations=1, progress=False, search="ce")
    # Moore machines without the stage, as on exact values.
    result = cehmm.optimize_controller(
        RepeatFirst(),
        decisions="moore",
        memoryless_patience=0,
        memory="nodes",
        samples=20,
        episodes=4,
        max_iterations=2,
        select_episodes=10,
        eval_episodes=10,
        progress=False,
        search="ce",
    )
    assert result.policy.levels == [8, 8] and not result.history["widened"].any()


class _Coin:
    """A deterministic world in both protocols: observe the step's parity, paid for naming it."""

    n_observations, n_decisions, horizon = 2, 2, 6

    def reset(self, seed: int) -> int:
        self.t = 0
        return 0

    def step(self, decision: int) -> tuple[int, float, bool]:
        reward = float(decision == self.t % 2)
        self.t += 1
        return self.t % 2, reward, False


class _CoinBatch(_Coin):
    batched = True
    max_batch = 5

    def reset(self, n: int, seed: int) -> np.ndarray:  # type: ignore[override]
        self.t = 0
        return np.zeros(n, dtype=np.int64)

    def step(self, decisions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # type: ignore[override]
        rewards = (decisions == self.t % 2).astype(float)
        self.t += 1
        n = len(decisions)
        return np.full(n, self.t % 2), rewards, np.zeros(n, dtype=bool)


def test_both_protocols_and_every_thread_count_give_the_same_search() -> None:
    settings = dict(nodes=2, samples=50, episodes=3, max_iterations=4, eval_episodes=20, select_episodes=10)
    results = [
        cehmm.optimize_controller(world, threads=threads, progress=False, **settings, search="ce")
        for world in (_Coin(), _CoinBatch())
        for threads in (1, 2)
    ]
    reference = results[0]
    for other in results[1:]:
        assert other.value == reference.value and other.run_values == reference.run_values
        assert np.array_equal(other.history["best_so_far"], reference.history["best_so_far"])
    assert reference.value == 6.0


def test_the_engines_worlds_are_searched_on_sampled_values() -> None:
    world = cehmm.TargetTracking(case=1)
    settings = dict(nodes=4, samples=300, episodes=2, max_iterations=6, eval_episodes=10, progress=False)
    one = cehmm.optimize_controller(world, threads=1, **settings, search="ce")
    two = cehmm.optimize_controller(world, threads=2, **settings, search="ce")
    assert one.kind == "sampled" and one.value == two.value
    assert np.array_equal(one.history["best"], two.history["best"])
    # Case 1 is deterministic: the value is the policy's, and no better than the optimum, 86.
    assert one.value == one.policy.evaluate(world, episodes=10).mean <= 86
    # A tabular world on sampled values: the value of fresh episodes, near its exact value.
    tiger = cehmm.PomdpWorld.from_file(DATA / "tiger.95.POMDP", horizon=100, reward="belief")
    sampled = cehmm.optimize_controller(
        tiger, nodes=2, samples=200, value="sampled", max_iterations=3, progress=False, search="ce"
    )
    exact = sampled.policy.evaluate_exact(tiger).value
    assert abs(sampled.value - exact) < 4 * sampled.evaluation.std_error + 1e-9


def test_a_worlds_exception_comes_back_as_itself() -> None:
    class Broken(_Coin):
        def step(self, decision: int) -> tuple[int, float, bool]:
            if self.t == 3:
                raise KeyError("the world broke")
            return super().step(decision)

    with pytest.raises(KeyError, match="the world broke") as raised:
        cehmm.optimize_controller(Broken(), nodes=2, samples=10, episodes=2, progress=False, search="ce")
    assert any("controller 0, episode 0" in note for note in raised.value.__notes__)


def test_repeat_previous_pays_only_the_memory_of_the_last_cards() -> None:
    world = RepeatPrevious()
    # A policy that names the current card is right by chance only (k = 4 looks 3 cards back).
    policy = cehmm.optimize_controller(
        world, nodes=1, samples=4, episodes=1, max_iterations=1, progress=False, search="ce"
    )
    assert -0.6 < policy.value < -0.4


def test_a_shift_register_of_registers_holds_the_last_cards() -> None:
    # k = 3: the suit dealt two cards before the current one, held by 2 registers of 4 (the
    # last two suits) that start as a shift register; the decision reads the older.
    world = RepeatPrevious(k=3)
    result = cehmm.optimize_controller(
        world, memory="registers", registers=2, template="window", target=1.0, seed=1, progress=False, search="ce"
    )
    assert result.value == pytest.approx(world.optimum)
    assert result.policy.provenance["memory"] == "registers"
    # Its Moore machine: a start node and (node reached, suit) pairs of the 16 register values.
    assert result.policy.levels[0] <= 1 + 16 * 4


def test_credit_within_episodes_learns_the_decisions_a_shift_register_needs() -> None:
    # The memory fixed as a shift register of the last three suits (template weight 0.999):
    # what is left to learn is the decision of 64 nodes × 4 suits. Credited by its steps, each
    # row finds the suit that pays; ranked as whole controllers, the laws barely move.
    settings = dict(
        memory="registers", template="window", template_weight=0.999, memoryless_patience=0, max_iterations=15
    )
    settings.update(seed=0, threads=1, eval_episodes=2000, progress=False)
    steps = cehmm.optimize_controller(RepeatPrevious(), **settings, search="ce")
    elite = cehmm.optimize_controller(RepeatPrevious(), credit="elite", **settings, search="ce")
    assert steps.policy.provenance["credit"] == "steps"
    assert steps.value > 0.3 > elite.value
    with pytest.raises(cehmm.InvalidArgumentError, match=r"credit: \"ranks\" \(expected \"steps\" or \"elite\"\)"):
        cehmm.optimize_controller(RepeatPrevious(), credit="ranks", progress=False, search="ce")


class Sweep:
    """A blind search: each of 12 steps names one of 12 cells, +1 for a cell not named before,
    −1 for one named again; the observation tells nothing. Only a time-indexed policy (a
    permutation) reaches 12; 8 flat nodes name 8 cells at most (4), a blind policy −10."""

    batched = True
    n_observations, n_decisions, horizon = 1, 12, 12

    def reset(self, n: int, seed: int) -> np.ndarray:
        self._named = np.zeros((n, self.n_decisions), dtype=bool)
        self._t = 0
        return np.zeros(n, dtype=np.int64)

    def step(self, decisions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        rows = np.arange(len(decisions))
        rewards = np.where(self._named[rows, decisions], -1.0, 1.0)
        self._named[rows, decisions] = True
        self._t += 1
        return np.zeros(len(decisions), dtype=np.int64), rewards, np.full(len(decisions), self._t >= self.horizon)


def test_a_clock_learns_the_time_indexed_policy_a_blind_search_needs() -> None:
    settings = dict(seed=0, threads=1, eval_episodes=100, progress=False)
    clock = cehmm.optimize_controller(Sweep(), memory="clock", max_iterations=25, **settings, search="ce")
    assert clock.value == 12.0 and clock.policy.levels == [64, 64]
    assert clock.policy.provenance["memory"] == "clock"
    # The default memory takes turns: flat nodes (8 name 8 cells at most: 4), registers, then
    # the clock, which names 11 cells of 12 at least here.
    turns = cehmm.optimize_controller(Sweep(), restarts=3, max_iterations=25, **settings, search="ce")
    assert turns.run_values[0] <= 4.0 < 10.0 <= turns.run_values[2] <= turns.value
    # A clock reads no observation: Moore decisions are its own, whatever is asked.
    moore = cehmm.optimize_controller(
        Sweep(), memory="clock", decisions="moore", memoryless_patience=0, max_iterations=1, **settings, search="ce"
    )
    assert moore.policy.levels == [64, 64]


def test_registers_are_refused_where_they_do_not_fit() -> None:
    with pytest.raises(cehmm.InvalidArgumentError, match=r"registers.*1 of register_size 4"):
        cehmm.optimize_controller(RepeatPrevious(), memory="registers", registers=1, progress=False, search="ce")
    with pytest.raises(cehmm.InvalidArgumentError, match=r"memory \"registers\" with decisions \"moore\""):
        cehmm.optimize_controller(
            RepeatPrevious(), memory="registers", decisions="moore", memoryless_patience=0, progress=False, search="ce"
        )
    with pytest.raises(cehmm.InvalidArgumentError, match=r"memory.*\"clock\" or \"alternate\""):
        cehmm.optimize_controller(RepeatPrevious(), memory="factored", progress=False, search="ce")


def test_a_search_resumes_from_its_checkpoint(tmp_path: Path) -> None:
    # Resuming mid-run is bit for bit (crates/ceworld/tests/controller_search.rs); here the
    # Python side: a checkpoint is written, a finished search resumed is the same search, a
    # missing checkpoint starts afresh, and other settings are refused.
    maze = TMaze(corridor=3)
    settings = dict(nodes=4, samples=60, episodes=4, max_iterations=6, restarts=2, progress=False)
    whole = cehmm.optimize_controller(maze, **settings, search="ce")
    path = tmp_path / "search.ckpt"
    first = cehmm.optimize_controller(maze, checkpoint=path, resume=True, **settings, search="ce")
    assert path.exists()
    again = cehmm.optimize_controller(maze, checkpoint=path, resume=True, **settings, search="ce")
    for result in (first, again):
        assert result.run_values == whole.run_values and result.value == whole.value
        assert np.array_equal(result.history["best_so_far"], whole.history["best_so_far"])
    with pytest.raises(cehmm.InvalidArgumentError, match="resume"):
        cehmm.optimize_controller(maze, resume=True, **settings, search="ce")
    with pytest.raises(cehmm.PolicyMismatchError, match="nodes 4, not 5"):
        cehmm.optimize_controller(maze, checkpoint=path, resume=True, **{**settings, "nodes": 5}, search="ce")


def test_growth_finds_the_nodes_a_too_small_controller_lacks(tiger: cehmm.PomdpWorld) -> None:
    # With 3 nodes the search stays at "always listen" (-20); grown twice it reaches SARSOP's
    # 19.3714 with 5 nodes (docs/benchmarks.md gives the measurements on other files).
    # (Without the model start, which would give the 5 nodes at once.)
    stuck = cehmm.optimize_controller(tiger, nodes=3, patience=20, model_nodes=0, progress=False)
    assert stuck.value < -19.9 and stuck.policy.levels == [3, 3]
    grown = cehmm.optimize_controller(tiger, nodes=3, patience=20, growths=2, model_nodes=0, progress=False)
    assert grown.policy.levels == [5, 5] and grown.value > 19.37
    assert int(grown.history["grown"].sum()) == 2
    assert grown.policy.provenance["growths"] == 2
    exact = grown.policy.evaluate_exact(tiger, infinite=True, tolerance=1e-9)
    assert exact.value == pytest.approx(grown.value, abs=2e-6)
