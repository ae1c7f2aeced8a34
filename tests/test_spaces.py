"""Any Gymnasium space in (cehmm.spaces): Box observations cut into bins (at quantiles of a warm-up,
at the bounds, or given), Box actions a grid, large finite observations hashed; each encoding
recorded in the policy file, so that the agent takes what the environment returns and answers
what its action space holds; all 42 POPGym environments learnt and played."""

from __future__ import annotations

import pickle
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces

import cehmm
import cehmm.gym
from cehmm.encoded import EnvAgent, from_record
from cehmm.pyworlds import TrackingEpisodes
from cehmm.spaces import Bins, Flat, Grid, Hashed, encoding, space_of, space_record


class Line(gym.Env):
    """A 2-d Box observation ``(x, 0)`` with ``x`` uniform in [0, 10) at each step, the reward 1
    when the action (a Box in [-1, 1]) has the sign of ``x - 5``; 20 steps."""

    observation_space = spaces.Box(np.array([-np.inf, 0.0]), np.array([np.inf, 1.0]), dtype=np.float64)
    action_space = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)

    def reset(self, *, seed: int | None = None, options: Any = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        self.t = 0
        return self._observe(), {}

    def _observe(self) -> np.ndarray:
        self.x = float(self.np_random.uniform(0, 10))
        return np.array([self.x, 0.0])

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict]:
        assert self.action_space.contains(action), action
        reward = float(np.sign(float(action[0])) == np.sign(self.x - 5))
        self.t += 1
        return self._observe(), reward, False, self.t >= 20, {}


def test_box_observations_are_cut_at_quantiles_of_a_warm_up_by_default() -> None:
    world = cehmm.PythonWorld(Line())
    record = world.description["spaces"]["observation"]
    assert record["encoding"] == "bins"
    # 2 dimensions: 8 bins each at most (8² = 64 cells); x uniform in [0, 10): its 7 edges near
    # 10·k/8; the constant second dimension gives one edge, collapsed.
    x_edges, flat_edges = record["edges"]
    assert len(x_edges) == 7 and np.allclose(x_edges, [10 * k / 8 for k in range(1, 8)], atol=0.4)
    assert flat_edges == [0.0]
    assert world.n_observations == 8 * 2
    # The warm-up is seeded: the same edges again; a copy (for a backend's workers) keeps them.
    assert cehmm.PythonWorld(Line()).description["spaces"] == world.description["spaces"]
    assert pickle.loads(pickle.dumps(world)).description == world.description
    # Box actions: 5 values a dimension between the bounds.
    assert world.description["spaces"]["action"]["values"] == [[-1.0, -0.5, 0.0, 0.5, 1.0]]
    assert world.n_decisions == 5


def test_bins_at_the_bounds_and_given_edges_index_by_hand() -> None:
    box = spaces.Box(np.array([0.0, -1.0]), np.array([4.0, 1.0]), dtype=np.float64)
    bins = encoding(box, "observation", Bins(4, fit="bounds"))
    assert isinstance(bins, Bins) and bins.size == 16
    # x = 2.5 in bin 2 ([2, 3)), y = -0.9 in bin 0: row-major 2·4 + 0; a value on an edge goes up.
    assert bins.index(np.array([2.5, -0.9])) == 8
    assert bins.index(np.array([3.0, 0.5])) == 3 * 4 + 3
    # Outside the bounds: the end bins.
    assert bins.index(np.array([-5.0, 7.0])) == 3
    given = encoding(box, "observation", Bins(edges=[[1.0], [0.0, 0.5]]))
    assert given.size == 2 * 3 and given.index(np.array([1.0, 0.2])) == 1 * 3 + 1
    with pytest.raises(cehmm.WorldError, match=r"observation array\(\[1\.\].*is not in the space"):
        bins.index(np.array([1.0]))
    with pytest.raises(cehmm.WorldError, match="nan"):
        bins.index(np.array([np.nan, 0.0]))


@pytest.mark.parametrize(
    ("choice", "match"),
    [
        (Bins(0, fit="bounds"), r"invalid Bins bins: 0 \(expected a positive int"),
        (Bins(fit="bounds"), r'fit="bounds"\) of Box.*not all finite'),
        (Bins(edges=[[1.0]]), r"1 lists for Box.*expected one per dimension, 2"),
        (Grid(), r"invalid observation encoding: Grid"),
        ("bins", r"invalid observations: 'bins' \(expected None, 'flat' or a cehmm.spaces encoding"),
    ],
)
def test_bad_encodings_are_refused_naming_the_value(choice: Any, match: str) -> None:
    with pytest.raises((cehmm.InvalidArgumentError, TypeError), match=match):
        cehmm.PythonWorld(Line(), observations=choice)


def test_other_bad_values_are_refused() -> None:
    with pytest.raises(
        cehmm.InvalidArgumentError, match=r"edges\[0\]: \[1\.0, 0\.5\] \(expected finite numbers in increasing"
    ):
        Bins(edges=[[1.0, 0.5], [0.0]])
    with pytest.raises(cehmm.InvalidArgumentError, match=r"invalid Bins fit: 'median'"):
        Bins(fit="median")
    with pytest.raises(cehmm.InvalidArgumentError, match=r"invalid Hashed size: 0"):
        Hashed(0)
    with pytest.raises(cehmm.InvalidArgumentError, match=r"invalid action encoding: Hashed"):
        encoding(spaces.Discrete(3), "action", Hashed(8))
    with pytest.raises(TypeError, match=r"invalid observations: .*encodings apply to Gymnasium environments"):
        cehmm.PythonWorld(TrackingEpisodes(), observations=Bins(2))
    unbounded = spaces.Box(-np.inf, np.inf, shape=(1,))
    with pytest.raises(cehmm.InvalidArgumentError, match=r"bounds that are not finite.*Grid\(values="):
        encoding(unbounded, "action")


def test_a_grid_answers_actions_of_the_space() -> None:
    box = spaces.Box(np.array([-2.0, 0.0], np.float32), np.array([2.0, 1.0], np.float32), dtype=np.float32)
    grid = encoding(box, "action", Grid(3))
    assert isinstance(grid, Grid) and grid.size == 9
    action = grid.value(5)  # row-major: first dimension 1 (0.0), second 2 (1.0)
    assert action.dtype == np.float32 and box.contains(action)
    assert action.tolist() == [0.0, 1.0]
    assert [grid.index(grid.value(i)) for i in range(9)] == list(range(9))
    given = encoding(box, "action", Grid(values=[[-1.0, 1.0], [0.5]]))
    assert given.size == 2 and given.value(1).tolist() == [1.0, 0.5]


def test_large_finite_observations_are_hashed_into_a_bounded_table() -> None:
    board = spaces.MultiDiscrete([3] * 52)
    hashed = encoding(board, "observation")
    assert isinstance(hashed, Hashed) and hashed.size == 256
    board.seed(0)
    values = [board.sample() for _ in range(2000)]
    cells = [hashed.index(v) for v in values]
    # Deterministic (BLAKE2b, not Python's hash), spread over the table.
    assert cells == [hashed.index(v.copy()) for v in values]
    assert min(cells) >= 0 and max(cells) < 256 and len(set(cells)) == 256
    assert encoding(spaces.MultiDiscrete([13, 13]), "observation").size == 169  # small: flattened
    with pytest.raises(cehmm.WorldError, match="is not in the space"):
        hashed.index(np.full(52, 3))


@pytest.mark.parametrize(
    "space",
    [
        spaces.Discrete(5, start=-2),
        spaces.MultiDiscrete([[2, 3], [2, 2]]),
        spaces.MultiBinary(3),
        spaces.Tuple((spaces.Discrete(2), spaces.MultiDiscrete([3, 2]))),
        spaces.Box(np.array([-np.inf, 0.0], np.float32), np.array([np.inf, 1.0], np.float32), dtype=np.float32),
    ],
)
def test_spaces_and_encodings_round_trip_through_their_records(space: gym.Space) -> None:
    again = space_of(space_record(space))
    assert again == space
    if isinstance(space, spaces.Box):
        fitted = encoding(space, "observation", Bins(edges=[[0.0, 1.5], [0.5]]))
    else:
        fitted = encoding(space, "observation")
    back = from_record(fitted.record(), "observation")
    space.seed(1)
    for _ in range(20):
        value = space.sample()
        assert back.index(value) == fitted.index(value)
    with pytest.raises(cehmm.PolicyFormatError, match="expected an encoding flat, hashed, bins or grid"):
        from_record({**fitted.record(), "encoding": "tiles"}, "observation")


def test_the_agent_takes_what_the_environment_returns_and_answers_its_action_space(tmp_path: Any) -> None:
    env = Line()
    result = cehmm.optimize_controller(
        env, nodes=2, samples=50, episodes=5, select_episodes=50, eval_episodes=200, max_iterations=10, progress=False
    )
    path = tmp_path / "line.json"
    result.policy.save(path)
    loaded = cehmm.Policy.load(path)
    agent, again = result.policy.agent(seed=3), loaded.agent(seed=3)
    assert isinstance(agent, EnvAgent)
    observation, _ = env.reset(seed=0)
    agent.reset()
    again.reset()
    for _ in range(20):
        action = agent.act(observation)
        assert env.action_space.contains(action)
        assert np.array_equal(action, again.act(observation))
        observation, *_ = env.step(action)
    # The policy learnt the sign: gym.play and evaluate on the environment (its recorded
    # encodings) agree with the result's evaluation.
    played = cehmm.gym.play(Line(), loaded.agent(seed=1), episodes=200)
    assert played.mean() > 18
    assert loaded.evaluate(Line(), episodes=200).mean == pytest.approx(result.evaluation.mean, abs=0.5)


def test_an_agent_of_a_finite_world_keeps_taking_indices() -> None:
    policy = cehmm.Policy.uniform(cehmm.TargetTracking(case=1), [2])
    assert not isinstance(policy.agent(), EnvAgent)
    # A Discrete environment's policy: the values are the indices (start 0).
    frozen = cehmm.optimize_controller(
        "FrozenLake-v1", nodes=1, samples=20, max_iterations=1, eval_episodes=10, select_episodes=10, progress=False
    )
    assert frozen.policy.agent().act(np.int64(0)) in range(4)


def _popgym_envs() -> list[Any]:
    popgym = pytest.importorskip("popgym")
    from popgym.envs import ALL

    assert popgym is not None
    return list(ALL)


@pytest.mark.parametrize("make", _popgym_envs(), ids=lambda c: c.__name__)
def test_every_popgym_environment_is_learnt_and_played(make: Any) -> None:
    env = make()
    short = dict(max_iterations=1, progress=False, eval_episodes=4)
    controller = cehmm.optimize_controller(env, samples=10, episodes=2, select_episodes=4, **short)
    hhmm = cehmm.optimize(env, samples=20, **short)
    for policy in (controller.policy, hhmm.policy):
        assert set(policy.world["spaces"]) == {"observation", "action"}
        returns = cehmm.gym.play(make(), policy.agent(seed=0), episodes=2)
        assert returns.shape == (2,) and np.all(np.isfinite(returns))


def test_flat_stays_the_encoding_of_small_finite_spaces() -> None:
    assert isinstance(encoding(spaces.Tuple((spaces.Discrete(2), spaces.Discrete(4))), "observation"), Flat)
    assert isinstance(encoding(spaces.MultiDiscrete([8, 8]), "action"), Flat)


def test_a_vector_environment_of_box_spaces_is_binned_and_stepped_as_a_batch() -> None:
    vector = gym.vector.SyncVectorEnv([Line, Line, Line])
    world = cehmm.PythonWorld(vector)
    assert world.batch == 3 and world.description["spaces"]["observation"]["encoding"] == "bins"
    result = cehmm.optimize_controller(
        vector, nodes=2, samples=20, episodes=3, select_episodes=20, eval_episodes=50, max_iterations=3, progress=False
    )
    assert cehmm.gym.play(Line(), result.policy.agent(), episodes=5).mean() > 10


class Board(gym.Env):
    """A 52-part board of 3 values each and 104 decisions (Concentration's shape), never stepped."""

    observation_space = spaces.MultiDiscrete([3] * 52)
    action_space = spaces.Discrete(104)


def test_a_controller_whose_policy_file_may_not_fit_is_refused_before_the_search() -> None:
    # 64 Mealy nodes (the registers' turn) on 1024 cells and 104 decisions: up to 6656 pairs,
    # 437 million entries; refused naming the nodes and what to change, before any episode.
    big = cehmm.PythonWorld(Board(), observations=Hashed(1024), horizon=10)
    with pytest.raises(cehmm.InvalidArgumentError, match=r"invalid nodes: 64 with Mealy decisions.*Hashed\(k\)"):
        cehmm.optimize_controller(big, max_iterations=1, progress=False)
