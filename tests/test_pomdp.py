"""Tabular POMDPs from Cassandra files (model §7): the world, exact values by hand and against
sampling, and the errors a bad or changed file gives."""

from __future__ import annotations

import json
import os
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

import cehmm

DATA = Path(__file__).resolve().parents[1] / "data" / "pomdp"
TIGER = DATA / "tiger.95.POMDP"
LISTEN, OPEN_LEFT, OPEN_RIGHT = 0, 1, 2


@pytest.fixture(scope="module")
def tiger() -> cehmm.PomdpWorld:
    return cehmm.PomdpWorld.from_file(TIGER, horizon=20)


def blind(world: cehmm.PomdpWorld, action_probs: list[float]) -> cehmm.Policy:
    """The 1-node policy: the same action distribution at every step, whatever is observed."""
    h0 = np.array([action_probs])
    h1 = np.ones((world.n_observations, 1, 1))
    return cehmm.Policy.from_tables({"h0": h0, "h1": h1, "upper": []}, world=world)


def test_the_world_of_a_file(tiger: cehmm.PomdpWorld) -> None:
    assert tiger.states == ["tiger-left", "tiger-right"]
    assert tiger.actions == ["listen", "open-left", "open-right"]
    assert tiger.observations == ["tiger-left", "tiger-right"]
    # One more observation than the file's: the start symbol, before the first action.
    assert (tiger.n_observations, tiger.n_decisions, tiger.horizon, tiger.discount) == (3, 3, 20, 0.95)
    assert tiger.transition.shape == (3, 2, 2) and tiger.observation.shape == (3, 2, 2)
    np.testing.assert_allclose(tiger.transition.sum(axis=2), 1.0)
    np.testing.assert_allclose(tiger.observation[LISTEN], [[0.85, 0.15], [0.15, 0.85]])
    np.testing.assert_allclose(tiger.reward, [[-1, -1], [-100, 10], [10, -100]])
    np.testing.assert_allclose(tiger.start, [0.5, 0.5])
    assert len(tiger.sha256) == 64 and tiger.file.endswith("tiger.95.POMDP")
    rollout = blind(tiger, [1, 0, 0]).rollout(tiger, seed=1)
    assert rollout.x_labels == ["state", "observation"]
    assert rollout.y[0] == 2, "the start symbol comes first"
    assert set(rollout.y[1:]) <= {0, 1}


def test_a_one_node_policy_on_tiger_by_hand(tiger: cehmm.PomdpWorld) -> None:
    # Listening costs 1; opening a door finds the tiger half of the time (the tiger is
    # reset after each opening): 0.5·10 + 0.5·(−100) = −45. A blind policy that listens with
    # probability p earns −p − 45 (1 − p) a step, −(p + 45 (1 − p)) / (1 − γ) in all.
    for probs in ([1, 0, 0], [0, 1, 0], [0.5, 0.25, 0.25], [0.9, 0.1, 0.0]):
        per_step = -probs[0] - 45 * (1 - probs[0])
        policy = blind(tiger, probs)
        assert policy.evaluate_exact(infinite=True, tolerance=1e-9).value == pytest.approx(per_step / 0.05, abs=1e-8)
        assert policy.evaluate_exact(horizon=3).value == pytest.approx(per_step * (1 + 0.95 + 0.95**2), abs=1e-9)


@pytest.mark.parametrize("name", ["tiger.95.POMDP", "4x3.95.POMDP", "cheese.95.POMDP", "network.POMDP"])
def test_sampling_agrees_with_the_exact_value(name: str) -> None:
    world = cehmm.PomdpWorld.from_file(DATA / name, horizon=12)
    policy = cehmm.Policy.random(world, [3, 2], seed=5)
    exact = policy.evaluate_exact().value
    sampled = policy.evaluate(episodes=100_000, seed=2)
    assert abs(sampled.mean - exact) < 4.5 * sampled.std_error, (exact, sampled)
    # The belief reward has the same expectation, and less noise.
    belief = cehmm.PomdpWorld.from_file(DATA / name, horizon=12, reward="belief")
    assert policy.evaluate_exact(belief).value == pytest.approx(exact, rel=1e-12, abs=1e-12)
    b = policy.evaluate(belief, episodes=100_000, seed=2)
    assert abs(b.mean - exact) < 4.5 * b.std_error and b.std <= sampled.std * 1.0001


def test_optimising_tiger_beats_the_uniform_policy(tiger: cehmm.PomdpWorld) -> None:
    uniform = cehmm.Policy.uniform(tiger, [2, 2]).evaluate_exact().value
    result = cehmm.optimize(tiger, levels=[2, 2], samples=500, max_iterations=30, progress=False, eval_episodes=1000)
    exact = result.policy.evaluate_exact().value
    assert uniform < -300 and exact > -25, (uniform, exact)
    assert result.policy.world["name"] == "pomdp" and result.policy.world["sha256"] == tiger.sha256
    slow = cehmm.optimize(tiger, levels=[2, 2], samples=200, max_iterations=3, progress=False, decision_smoothing=0.05)
    assert slow.policy.provenance["decision_smoothing"] == 0.05 and "decision_smoothing" not in result.policy.provenance


def test_a_policy_remembers_its_model(tmp_path: Path, tiger: cehmm.PomdpWorld) -> None:
    copy = tmp_path / "tiger.POMDP"
    shutil.copy(TIGER, copy)
    world = cehmm.PomdpWorld.from_file(copy, horizon=5)
    policy = blind(world, [1, 0, 0])
    policy.save(tmp_path / "p.json")
    loaded = cehmm.Policy.load(tmp_path / "p.json")
    assert loaded.evaluate_exact().value == pytest.approx(-(1 - 0.95**5) / 0.05)
    copy.write_text(copy.read_text().replace("0.85 0.15", "0.80 0.20"))
    with pytest.raises(cehmm.PolicyMismatchError, match="SHA-256"):
        loaded.evaluate_exact()
    doc = json.loads(loaded.to_json())
    assert doc["world"]["file"] == str(copy)


def test_bad_files_are_refused_by_line_and_column(tmp_path: Path) -> None:
    with pytest.raises(cehmm.ModelFormatError, match=r"ejs7\.POMDP:22:1: O: a=1 s'=1 sums to 1\.1"):
        cehmm.PomdpWorld.from_file(DATA / "ejs7.POMDP")
    bad = tmp_path / "bad.pomdp"
    bad.write_text("discount: 0.9\nvalues: reward\nstates: 2\nactions: go\nobservations: 1\nT: stop : 0 : 1 1.0\n")
    with pytest.raises(cehmm.ModelFormatError, match=r"bad\.pomdp:6:4: .*stop"):
        cehmm.PomdpWorld.from_file(bad)
    with pytest.raises(FileNotFoundError):
        cehmm.PomdpWorld.from_file(tmp_path / "missing.pomdp")
    with pytest.raises(cehmm.InvalidArgumentError, match="horizon"):
        cehmm.PomdpWorld.from_file(TIGER, horizon=0)
    with pytest.raises(cehmm.InvalidArgumentError, match="discount"):
        cehmm.PomdpWorld.from_file(TIGER, discount=1.5)
    with pytest.raises(cehmm.InvalidArgumentError, match="reward"):
        cehmm.PomdpWorld.from_file(TIGER, reward="lucky")


def test_exact_evaluation_needs_a_tabular_world(case1: cehmm.TargetTracking, tiger: cehmm.PomdpWorld) -> None:
    with pytest.raises(cehmm.InvalidArgumentError, match="tabular"):
        cehmm.Policy.uniform(case1, [2]).evaluate_exact()
    ejs = cehmm.PomdpWorld.from_file(DATA / "ejs1.POMDP", horizon=4)
    with pytest.raises(cehmm.InvalidArgumentError, match="discount"):
        cehmm.Policy.uniform(ejs, [1]).evaluate_exact(infinite=True)


def listen_twice(world: cehmm.PomdpWorld) -> cehmm.Policy:
    """Tiger's five-node controller, levels [5, 5] with m_2[t] = m_1[t-1]: listen; open the
    door opposite to two agreeing observations in a row, else listen again."""
    nodes, y_count = 5, 3
    h0 = np.zeros((nodes, 3))
    h0[[0, 1, 2], LISTEN] = 1
    h0[3, OPEN_RIGHT] = h0[4, OPEN_LEFT] = 1
    h1 = np.zeros((y_count, nodes, nodes))  # h1[y, previous node, node]
    moves = {0: (1, 2), 1: (3, 0), 2: (0, 4), 3: (0, 0), 4: (0, 0)}  # on (tiger-left, tiger-right)
    for previous, (on_left, on_right) in moves.items():
        h1[0, previous, on_left] = h1[1, previous, on_right] = h1[2, previous, 0] = 1
    start = np.eye(nodes)[[0]]
    step = np.eye(nodes)[:, None, :]
    return cehmm.Policy.from_tables({"h0": h0, "h1": h1, "upper": [{"start": start, "step": step}]}, world=world)


def test_tigers_five_node_controller_reaches_the_sarsop_value(tiger: cehmm.PomdpWorld) -> None:
    policy = listen_twice(tiger)
    value = policy.evaluate_exact(infinite=True, tolerance=1e-9)
    assert value.value == pytest.approx(19.3714, abs=1e-4)  # SARSOP's bound: 19.37 (SOURCES.md)
    assert policy.graph(form="pg") == "0 0 1 2\n1 0 3 0\n2 0 0 4\n3 2 0 0\n4 1 0 0\n"
    text = policy.graph()
    assert text.startswith("initial: node 0 (1.000)\nnode 0 (memory [0, 0]): listen 1.000\n")
    assert "  on tiger-left -> node 3 (1.000)" in text
    graph = policy.graph(form="json")
    assert graph["initial"] == [[0, 1.0]] and graph["nodes"][3]["decision"] == {"open-right": 1.0}
    assert graph["nodes"][1]["next"] == {"tiger-left": [[3, 1.0]], "tiger-right": [[0, 1.0]]}
    with pytest.raises(cehmm.InvalidArgumentError, match="not deterministic"):
        cehmm.Policy.uniform(tiger, [2]).graph(form="pg")
    stochastic = cehmm.Policy.uniform(tiger, [2]).graph(form="json")
    assert len(stochastic["nodes"]) == 2 and stochastic["nodes"][0]["decision"]["listen"] == pytest.approx(1 / 3)


def test_appls_pomdpx_tiger_is_tiger_95(tiger: cehmm.PomdpWorld) -> None:
    """APPL's factored XML Tiger, flattened: tiger.95's tables, so every policy's exact value."""
    tiger_x = cehmm.PomdpWorld.from_file(DATA.parent / "pomdpx" / "Tiger.pomdpx", horizon=20)
    assert tiger_x.states == tiger.states and tiger_x.actions == tiger.actions
    assert tiger_x.observations == ["obs-left", "obs-right"]
    for table in ("transition", "observation", "reward", "start"):
        np.testing.assert_array_equal(getattr(tiger_x, table), getattr(tiger, table))
    value = listen_twice(tiger_x).evaluate_exact(infinite=True, tolerance=1e-9).value
    assert value == pytest.approx(listen_twice(tiger).evaluate_exact(infinite=True, tolerance=1e-9).value, abs=1e-12)
    assert value == pytest.approx(19.3714, abs=1e-4)


@pytest.mark.skipif(sys.platform == "win32" or sys.getfilesystemencoding() != "utf-8", reason="POSIX byte paths")
def test_a_path_that_is_not_utf8_is_refused_by_name(tmp_path: Path) -> None:
    # It raised UnicodeEncodeError (as a str with surrogates) or TypeError (as bytes); a world's
    # parameters are recorded as text, so such a path is refused, as in the CLI.
    raw = os.fsencode(tmp_path) + b"/tiger\xff.pomdp"
    shutil.copy(TIGER, raw)
    for path in [os.fsdecode(raw), raw, Path(os.fsdecode(raw))]:
        with pytest.raises(cehmm.InvalidArgumentError, match=r"tiger\\udcff.pomdp' is not valid UTF-8"):
            cehmm.PomdpWorld.from_file(path)


def _mixed(table: np.ndarray, eps: float) -> np.ndarray:
    """Each row mixed with the uniform law by `eps`, as long refits leave a learned table."""
    return (1 - eps) * table + eps / table.shape[-1]


def test_a_learned_policys_graph_drops_negligible_laws_and_its_most_likely_controller_is_one(
    tiger: cehmm.PomdpWorld,
) -> None:
    # A learned tiger policy drew every memory, with edges of probability 1e-12; pruned at 0.001
    # (the default) it shows what the policy does, and its most likely controller is a graph.
    exact = listen_twice(tiger)
    t = exact.tables
    tables = {
        "h0": _mixed(t["h0"], 1e-9),
        "h1": _mixed(t["h1"], 1e-9),
        "upper": [{k: _mixed(v, 1e-9) for k, v in level.items()} for level in t["upper"]],
    }
    policy = cehmm.Policy.from_tables(tables, world=tiger)
    full, shown = policy.graph(form="json", prune=0.0), policy.graph(form="json")
    assert len(full["nodes"]) > len(shown["nodes"]) == 5
    assert policy.graph() == exact.graph()
    with pytest.raises(cehmm.InvalidArgumentError, match="not deterministic"):
        policy.graph(form="pg", prune=0.0)
    assert policy.graph(form="pg") == exact.graph(form="pg")  # deterministic once pruned
    likely = policy.most_likely()
    assert likely.provenance["derived"].startswith("most likely")
    assert likely.graph(form="pg") == exact.graph(form="pg")
    with pytest.raises(cehmm.InvalidArgumentError, match="prune"):
        policy.graph(prune=1.5)
