"""Every figure of cehmm.plots, drawn from real (short) optimisations with Agg into files, and
the facts the figures are made of: the memory's use per step, the policy graph's arrows, its
DOT text, the animation's frames, and what ``cehmm plot`` draws of a policy file."""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from worlds import Corridor

import cehmm
from cehmm import cli, plots

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


# -- what the figures say: their artists, not their pixels ---------------------------------------


def test_best_so_far_has_a_colour_and_a_style_of_its_own_and_a_legend_entry(tracking, controller) -> None:
    from matplotlib.colors import to_rgba

    _, result = tracking
    ax = plots.learning_curve(result, controller, labels=["ce", "search"]).axes[0]
    lines = {line.get_label(): line for line in ax.get_lines()}
    for run in ("ce", "search"):
        mean, best = lines[f"{run}: mean"], lines[f"{run}: best so far"]
        assert to_rgba(best.get_color()) != to_rgba(mean.get_color())
        assert best.get_linestyle() in ("-", "--") and best.get_linestyle() != mean.get_linestyle()
    # No two runs share a colour, and every line is in the legend.
    colours = [
        to_rgba(lines[f"{run}: {what}"].get_color()) for run in ("ce", "search") for what in ("mean", "best so far")
    ]
    assert len(set(colours)) == 4
    assert {t.get_text() for t in ax.get_legend().get_texts()} == set(lines)


def test_every_panel_of_the_decision_law_names_its_axes(tracking, controller, tiger) -> None:
    world, result = tracking
    one = cehmm.Policy.uniform(world, [3])
    for figure in (
        plots.decision_law(result.policy, world),
        plots.decision_law(one),
        plots.decision_law(controller.policy),
    ):
        left, right = figure.axes[:2]
        assert (left.get_xlabel(), left.get_ylabel()) == ("decision d", "m₁")
        assert right.get_xlabel() and right.get_ylabel() == "observation y"


def test_an_episode_is_titled_by_its_world_and_its_time_labels_do_not_overlap(tracking) -> None:
    world, result = tracking
    episode = result.policy.rollout(world, seed=3)
    assert plots.rollout(episode).axes[0].get_title().startswith("episode of target tracking (reward ")
    figure = episode.plot(world=world)
    ax = figure.axes[0]
    assert ax.get_title().startswith(f"episode of target tracking, case 3 (reward {episode.reward:g}): steps 1–100")
    figure.set_dpi(130)  # another dpi than the one the labels were thinned at, laid out again
    figure.draw_without_rendering()
    shown = [t for t in ax.texts if t.get_visible() and t.get_text()]
    # 100 steps of three mobiles: some labels left out, and those shown clear of one another.
    assert 10 <= len(shown) < len(ax.texts) and len(shown) <= 150
    boxes = [t.get_window_extent().padded(-1.0) for t in shown]
    overlaps = [
        (a.get_text(), b.get_text())
        for i, a in enumerate(shown)
        for j, b in enumerate(shown[:i])
        if boxes[i].overlaps(boxes[j])
    ]
    assert not overlaps, overlaps
    # A short stretch keeps every label (the paper's figure).
    stretch = plots.trajectory(result.policy, world, length=8).axes[0]
    assert all(t.get_visible() for t in stretch.texts)
    assert stretch.get_title().startswith("episode ") and " of target tracking, case 3 (reward " in stretch.get_title()


def test_a_policy_graph_labels_every_arrow_and_loops_have_arrowheads(controller, tiger) -> None:
    from matplotlib.patches import ArrowStyle, FancyArrowPatch

    def drawn(figure):
        ax = figure.axes[0]
        arrows = {p.get_gid(): p for p in ax.patches if isinstance(p, FancyArrowPatch) and p.get_gid()}
        labels = {t.get_gid(): t.get_text() for t in ax.texts if t.get_gid()}
        return ax, arrows, labels

    # One node that stays itself on every observation: a loop, with its arrowhead and its label.
    ax, arrows, labels = drawn(plots.policy_graph(cehmm.Policy.uniform(tiger, [1]), tiger))
    assert isinstance(arrows["edge 0->0"].get_arrowstyle(), ArrowStyle.CurveFilledB)
    assert labels["label 0->0"].split("\n") == ["tiger-left", "tiger-right"]
    assert ax.get_title() == "policy graph of tiger.95.POMDP: 1 node (laws ≤ 0.001 left out)"
    # A found controller: an arrow and a label per pair of nodes, the observations that take it.
    graph = controller.policy.graph(tiger, form="json")
    ax, arrows, labels = drawn(plots.policy_graph(controller.policy, title="t.json"))
    for a, b, label in plots.graph.edges(graph):
        assert f"edge {a}->{b}" in arrows and labels[f"label {a}->{b}"] == label != ""
    assert ax.get_title().startswith("t.json\npolicy graph of tiger.95.POMDP: ")
    # Arrows too many for names: the observations' indices, the key in the title.
    ax, arrows, labels = drawn(plots.policy_graph(cehmm.Policy.uniform(tiger, [4]), tiger, prune=0.0))
    assert len(arrows) == len(labels) == 16
    assert all(set(label.split(",")) == {"0 (0.25)", "1 (0.25)"} for label in labels.values()), labels
    assert ax.get_title().endswith("observations by index, 0 tiger-left, 1 tiger-right")


def test_cehmm_plot_titles_a_policy_by_its_file_and_its_world(controller, tracking, tmp_path: Path) -> None:
    import argparse

    from cehmm import cli

    _, result = tracking
    tiger, case3 = str(tmp_path / "tiger.json"), str(tmp_path / "case3.json")
    controller.policy.save(tiger)
    result.policy.save(case3)
    options = dict(x="iteration", prune=0.001, episodes=5)
    of_tiger = f"{tiger}: a policy of tiger.95.POMDP (levels {controller.policy.levels})"
    for path, what, title in [
        (tiger, None, of_tiger + "\npolicy graph: "),  # the world named once
        (tiger, "law", of_tiger),
        (case3, None, f"{case3}: a policy of target tracking, case 3 (levels [4, 3])"),
    ]:
        figure = cli._figure_of(argparse.Namespace(files=[path], what=what, **options))
        shown = figure.axes[0].get_title() if path == tiger and what is None else figure.get_suptitle()
        assert shown.startswith(title) and "case ?" not in shown, shown


def ticks(axis) -> list[str]:
    """An axis's tick labels, as shown."""
    return [label.get_text() for label in axis.get_ticklabels()]


class Dial(gym.Env):
    """A Gymnasium environment with values of its own: observations 100..115, actions pairs of
    bits; episodes of 5 steps show 100, 101, ..., 104."""

    observation_space = gym.spaces.Discrete(16, start=100)
    action_space = gym.spaces.MultiDiscrete([2, 2])

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[int, dict]:
        super().reset(seed=seed)
        self.t = 0
        return 100, {}

    def step(self, action: object) -> tuple[int, float, bool, bool, dict]:
        self.t += 1
        return 100 + self.t, float(action[0]), False, self.t >= 5, {}


PAIRS = ["(0, 0)", "(0, 1)", "(1, 0)", "(1, 1)"]


def test_a_policy_of_a_gymnasium_environment_or_a_python_world_is_drawn_from_its_file(tmp_path: Path) -> None:
    # Refused ("pass the world itself"), which the command line cannot do: drawn from what the
    # file holds, its decisions and observations named by the spaces it records.
    from cehmm.spaces import Bins, Grid

    pendulum = cehmm.PythonWorld("Pendulum-v1", observations=Bins(2, fit="bounds"), actions=Grid(3))
    worlds = {"pendulum": pendulum, "dial": cehmm.PythonWorld(Dial(), horizon=5), "corridor": Corridor()}
    for name, world in worlds.items():
        cehmm.Policy.random(world, [2], seed=0).save(tmp_path / f"{name}.json")
    law = plots.decision_law(cehmm.Policy.load(tmp_path / "pendulum.json"))
    assert ticks(law.axes[0].xaxis) == ["-2", "0", "2"]  # the torques of its grid
    assert ticks(law.axes[1].yaxis) == [str(k) for k in range(8)]  # cells of bins: no value, their index
    law = plots.decision_law(cehmm.Policy.load(tmp_path / "dial.json"))
    assert ticks(law.axes[0].xaxis) == PAIRS
    assert ticks(law.axes[1].yaxis) == [str(100 + k) for k in range(16)]
    law = plots.decision_law(cehmm.Policy.load(tmp_path / "corridor.json"))
    assert ticks(law.axes[0].xaxis) == ["0", "1"] and ticks(law.axes[1].yaxis) == [str(k) for k in range(6)]
    for name, title in [("pendulum", "Pendulum-v1"), ("dial", "Dial"), ("corridor", "Corridor")]:
        done = subprocess.run(
            [sys.executable, "-m", "cehmm.cli", "plot", f"{name}.json", "--out", f"{name}.png"],
            capture_output=True,
            text=True,
            cwd=tmp_path,
        )
        assert done.returncode == 0, done.stderr
        assert (tmp_path / f"{name}.png").stat().st_size > 1000
        path = str(tmp_path / f"{name}.json")
        options = argparse.Namespace(files=[path], what=None, x="iteration", prune=0.001, episodes=5)
        assert cli._figure_of(options).get_suptitle() == f"{path}: a policy of {title} (levels [2])"
    # Its memory's use needs its episodes, which only Python can run: refused, saying how.
    refused = subprocess.run(
        [sys.executable, "-m", "cehmm.cli", "plot", "dial.json", "--what", "memory", "--out", "m.png"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert refused.returncode == 2, refused.stderr
    assert "a policy of Dial, a world written in Python" in refused.stderr, refused.stderr
    assert "cehmm.plots.memory_use(policy, world)" in refused.stderr, refused.stderr
    with pytest.raises(cehmm.InvalidArgumentError, match=r"Dial, written in Python \(a policy graph needs a tabular"):
        plots.policy_graph(cehmm.Policy.load(tmp_path / "dial.json"))


def test_decisions_and_observations_are_named_on_the_figures_where_the_world_names_them(controller, tiger) -> None:
    # They were bare indices: an episode of a Gymnasium environment, and the observations of
    # the memory's visits.
    dial = cehmm.PythonWorld(Dial(), horizon=5)
    episode = cehmm.Policy.random(dial, [2], seed=1).rollout(dial)
    observations, decisions = episode.plot(world=dial).axes[:2]
    assert ticks(decisions.yaxis) == PAIRS
    # More names than fit (16): those the episode shows, 100 to 104.
    assert ticks(observations.yaxis) == [str(100 + k) for k in range(5)]
    assert list(observations.get_yticks()) == list(range(5))
    visits = plots.memory_heatmap(controller.policy, tiger, episodes=5)
    assert ticks(visits.axes[0].xaxis) == ["tiger-left", "tiger-right", "start"]
