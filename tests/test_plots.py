"""Every figure of cehmm.plots, drawn from real (short) optimisations with Agg into files, and
the facts the figures are made of: the memory's use per step, the policy graph's arrows, its
DOT text, the animation's frames, and what ``cehmm plot`` draws of a policy file."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import cehmm
from cehmm import plots

pytest.importorskip("matplotlib")

TIGER = Path(__file__).resolve().parents[1] / "data" / "pomdp" / "tiger.95.POMDP"


@pytest.fixture(scope="module")
def tiger() -> cehmm.PomdpWorld:
    return cehmm.PomdpWorld.from_file(TIGER, horizon=30, reward="belief")


@pytest.fixture(scope="module")
def controller(tiger: cehmm.PomdpWorld) -> cehmm.ControllerResult:
    """A tabular controller found by the search (exact values)."""
    return cehmm.optimize_controller(tiger, nodes=4, max_iterations=10, seed=0, progress=False)


@pytest.fixture(scope="module")
def tracking() -> tuple[cehmm.TargetTracking, cehmm.OptimizeResult]:
    """A two-level policy of target tracking, case 3."""
    world = cehmm.TargetTracking(case=3)
    return world, cehmm.optimize(world, levels=[4, 3], samples=200, max_iterations=8, eval_episodes=100, progress=False)


def saved(figure, path: Path) -> Path:
    figure.savefig(path, dpi=60)
    assert path.stat().st_size > 1000
    return path


def test_memory_use_is_the_share_of_running_episodes_in_each_state_at_each_step(tracking, tmp_path: Path) -> None:
    world, result = tracking
    shares = plots.memory_by_step(result.policy, world, episodes=30)
    assert [s.shape for s in shares] == [(4, 100), (3, 100)]
    for s in shares:
        assert np.allclose(s.sum(axis=0), 1.0)
    # Step by step, the visits of 30 rollouts counted by hand.
    rollouts = [result.policy.rollout(world, seed=0, episode=k) for k in range(30)]
    assert shares[1][2, 7] == pytest.approx(np.mean([r.memory[7, 1] == 2 for r in rollouts]))
    saved(plots.memory_use(result.policy, world, episodes=30, title="case 3"), tmp_path / "memory.png")
    saved(plots.memory_heatmap(result.policy, world, episodes=30), tmp_path / "heat.png")


def test_memory_use_counts_only_the_episodes_still_running(tmp_path: Path) -> None:
    from worlds import Corridor

    world = Corridor()
    result = cehmm.optimize(world, levels=[2], samples=100, max_iterations=3, eval_episodes=20, progress=False)
    shares = plots.memory_by_step(result.policy, world, episodes=20)
    lengths = [len(result.policy.rollout(world, episode=k)) for k in range(20)]
    assert shares[0].shape[1] == max(lengths)
    assert np.allclose(shares[0].sum(axis=0), 1.0)
    saved(plots.memory_use(result.policy, world, episodes=20), tmp_path / "m.png")
    with pytest.raises(cehmm.InvalidArgumentError, match="invalid episodes: 0"):
        plots.memory_by_step(result.policy, world, episodes=0)


def test_the_decision_law_is_drawn_for_one_level_and_for_several(tracking, controller, tiger, tmp_path) -> None:
    world, result = tracking
    saved(plots.decision_law(result.policy, world), tmp_path / "law2.png")
    one = cehmm.optimize(world, levels=[3], samples=100, max_iterations=3, eval_episodes=20, progress=False)
    saved(plots.decision_law(one.policy), tmp_path / "law1.png")  # the stored world
    saved(plots.decision_law(controller.policy, tiger), tmp_path / "law_tiger.png")


def test_the_policy_graph_has_an_arrow_per_pair_of_nodes_with_their_observations(controller, tiger, tmp_path) -> None:
    graph = controller.policy.graph(tiger, form="json")
    arrows = plots.graph.edges(graph)
    # Every observation of every node is on exactly one arrow (a deterministic controller).
    for k, node in enumerate(graph["nodes"]):
        out = [label for a, _, label in arrows if a == k]
        assert sorted("\n".join(out).split("\n")) == sorted(node["next"])
    saved(plots.policy_graph(controller.policy, tiger), tmp_path / "graph.png")
    stochastic = cehmm.optimize(tiger, levels=[3], samples=100, max_iterations=3, eval_episodes=20, progress=False)
    saved(plots.policy_graph(stochastic.policy, tiger, prune=0.0), tmp_path / "stochastic.png")
    with pytest.raises(cehmm.InvalidArgumentError, match="tabular"):
        plots.policy_graph(cehmm.Policy.uniform(cehmm.TargetTracking(case=1), [2]))
    big = cehmm.Policy.uniform(tiger, [50])
    with pytest.raises(cehmm.InvalidArgumentError, match=r"50 nodes at prune=0.001 \(expected at most 40"):
        plots.policy_graph(big, tiger)


def test_the_dot_export_names_every_node_and_observation(controller, tiger) -> None:
    graph = controller.policy.graph(tiger, form="json")
    dot = controller.policy.graph(tiger, form="dot")
    assert dot.startswith("digraph policy {") and dot.rstrip().endswith("}")
    for k, node in enumerate(graph["nodes"]):
        (decision,) = node["decision"]
        assert f'n{k} [label="{k}: {decision}"];' in dot
    # One line per arrow, as the figure draws them, and one from the start.
    assert sum(" -> n" in line and not line.strip().startswith("start") for line in dot.splitlines()) == len(
        plots.graph.edges(graph)
    )
    assert dot.count("start -> ") == 1
    with pytest.raises(cehmm.InvalidArgumentError, match='"dot" or "pg"'):
        controller.policy.graph(tiger, form="svg")


def test_a_rollout_plots_itself_on_the_grid_or_as_a_timeline(tracking, controller, tiger, tmp_path) -> None:
    world, result = tracking
    episode = result.policy.rollout(world, seed=2)
    saved(episode.plot(), tmp_path / "grid.png")
    saved(episode.plot(world=world, start=10, length=20, zoom=False), tmp_path / "stretch.png")
    saved(controller.policy.rollout(tiger, seed=0).plot(world=tiger), tmp_path / "timeline.png")
    with pytest.raises(cehmm.InvalidArgumentError, match="invalid stretch: start 100"):
        episode.plot(start=100)
    saved(plots.trajectory(result.policy, world, title="case 3"), tmp_path / "trajectory.png")


def test_an_episode_animates_as_a_gif_with_a_frame_per_step(tracking, controller, tiger, tmp_path) -> None:
    from PIL import Image

    world, result = tracking
    path = result.policy.rollout(world, seed=1).animate(tmp_path / "episode.gif", steps=12, fps=6)
    with Image.open(path) as gif:
        assert gif.n_frames == 12
    with pytest.raises(cehmm.InvalidArgumentError, match="expected a target-tracking rollout"):
        controller.policy.rollout(tiger).animate(tmp_path / "no.gif")


def test_cehmm_plot_draws_a_policy_file(controller, tracking, tmp_path: Path) -> None:
    _, result = tracking
    controller.policy.save(tmp_path / "tiger.json")
    result.policy.save(tmp_path / "case3.json")
    runs = [
        ["tiger.json", "--out", "graph.png"],  # a tabular world: its graph
        ["tiger.json", "--what", "law", "--out", "law_tiger.png"],
        ["case3.json", "--out", "law.png"],  # any other world: its decision law
        ["case3.json", "--what", "memory", "--episodes", "20", "--out", "memory.png"],
    ]
    for run in runs:
        done = subprocess.run(
            [sys.executable, "-m", "cehmm.cli", "plot", *run], capture_output=True, text=True, cwd=tmp_path
        )
        assert done.returncode == 0, done.stderr
        assert (tmp_path / run[-1]).stat().st_size > 1000
    refused = subprocess.run(
        [sys.executable, "-m", "cehmm.cli", "plot", "case3.json", "--what", "graph", "--out", "g.png"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert refused.returncode == 2 and "tabular" in refused.stderr, refused.stderr


def test_evaluations_print_to_the_precision_of_their_standard_error(tracking) -> None:
    _, result = tracking
    e = result.evaluation
    # Two significant digits of the standard error: 10^(1-d) <= s.e. < 10^(2-d).
    d = next(d for d in range(13) if 10.0 ** (1 - d) <= e.std_error)
    assert repr(e).startswith(f"Evaluation(mean={e.mean:.{d}f} ± {e.std_error:.{d}f}, episodes={e.episodes}, ")
    assert f"max={e.max:.{d}f}" in repr(e)
