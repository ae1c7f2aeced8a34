"""Any Gymnasium space in (cehmm.spaces): Box observations cut into bins (at quantiles of a warm-up,
at the bounds, or given), Box actions a grid, large finite observations hashed; each encoding
recorded in the policy file, so that the agent takes what the environment returns and answers
what its action space holds; all 42 POPGym environments learnt and played."""

from __future__ import annotations

import copy
import json
import pickle
import time
import tracemalloc
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces
from gymnasium.envs.registration import EnvSpec

import cehmm
import cehmm.gym
from cehmm import _core
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
    # 2 dimensions: 16 bins each at most (16² = 256 cells); x uniform in [0, 10): its 15 edges
    # near 10·k/16; the constant second dimension gives one edge, collapsed.
    x_edges, flat_edges = record["edges"]
    assert len(x_edges) == 15 and np.allclose(x_edges, [10 * k / 16 for k in range(1, 16)], atol=0.4)
    assert flat_edges == [0.0]
    assert world.n_observations == 16 * 2
    # The cells' parts, for a learner that looks at some of them (model §10).
    assert record["radices"] == [16, 2]
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
    # Outside the bounds: not in the space (Box.contains), refused naming it.
    with pytest.raises(cehmm.WorldError, match=r"observation array\(\[-5\., +7\.\]\) is not in the space"):
        bins.index(np.array([-5.0, 7.0]))
    given = encoding(box, "observation", Bins(edges=[[1.0], [0.0, 0.5]]))
    assert given.size == 2 * 3 and given.index(np.array([1.0, 0.2])) == 1 * 3 + 1
    with pytest.raises(cehmm.WorldError, match=r"observation array\(\[1\.\].*is not in the space"):
        bins.index(np.array([1.0]))
    with pytest.raises(cehmm.WorldError, match="nan"):
        bins.index(np.array([np.nan, 0.0]))


@pytest.mark.parametrize(
    ("choice", "match"),
    [
        (lambda: Bins(0, fit="bounds"), r"invalid Bins bins: 0 \(expected a positive int"),
        (lambda: Bins(fit="bounds"), r'fit="bounds"\) of Box.*not all finite'),
        (lambda: Bins(edges=[[1.0]]), r"1 lists for Box.*expected one per dimension, 2"),
        (lambda: Grid(), r"invalid observation encoding: Grid"),
        (lambda: "bins", r"invalid observations: 'bins' \(expected None, 'flat' or a cehmm.spaces encoding"),
    ],
)
def test_bad_encodings_are_refused_naming_the_value(choice: Any, match: str) -> None:
    with pytest.raises((cehmm.InvalidArgumentError, TypeError), match=match):
        cehmm.PythonWorld(Line(), observations=choice())


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
    assert isinstance(hashed, Hashed) and hashed.size == 128
    board.seed(0)
    values = [board.sample() for _ in range(2000)]
    cells = [hashed.index(v) for v in values]
    # Deterministic (BLAKE2b, not Python's hash), spread over the table.
    assert cells == [hashed.index(v.copy()) for v in values]
    assert min(cells) >= 0 and max(cells) < 128 and len(set(cells)) == 128
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
        env,
        nodes=2,
        samples=50,
        episodes=5,
        select_episodes=50,
        eval_episodes=200,
        max_iterations=10,
        progress=False,
        search="ce",
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
        "FrozenLake-v1",
        nodes=1,
        samples=20,
        max_iterations=1,
        eval_episodes=10,
        select_episodes=10,
        progress=False,
        search="ce",
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
        vector,
        nodes=2,
        samples=20,
        episodes=3,
        select_episodes=20,
        eval_episodes=50,
        max_iterations=3,
        progress=False,
        search="ce",
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
    with pytest.raises(
        cehmm.InvalidArgumentError,
        match=r"invalid registers: registers 3 of register_size 4 \(64 nodes\) with Mealy decisions.*Hashed\(k\)",
    ):
        cehmm.optimize_controller(big, max_iterations=1, progress=False, search="ce")


# -- issue 45: values checked against their space, sizes from arithmetic, records against their policy --------------


def test_grid_values_outside_the_action_space_are_refused_naming_the_value_and_the_bounds() -> None:
    box = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
    with pytest.raises(
        cehmm.InvalidArgumentError, match=r"invalid Grid values\[0\]: 5\.0 \(expected .*\[-1\.0, 1\.0\]"
    ):
        encoding(box, "action", Grid(values=[[5, -5], [0]]))
    pixels = spaces.Box(0, 255, shape=(2,), dtype=np.uint8)
    with pytest.raises(cehmm.InvalidArgumentError, match=r"invalid Grid values\[0\]: -1\.0 \(expected .*\[0, 255\]"):
        encoding(pixels, "action", Grid(values=[[-1, 300], [0]]))
    with pytest.raises(cehmm.InvalidArgumentError, match=r"invalid Grid values\[1\]: 300\.0"):
        encoding(pixels, "action", Grid(values=[[0], [7, 300]]))
    # An integer space takes integers only (no silent rounding), a float32 space float32's range.
    with pytest.raises(cehmm.InvalidArgumentError, match=r"invalid Grid values\[0\]: 0\.5 \(expected an integer"):
        encoding(pixels, "action", Grid(values=[[0.5], [0]]))
    unbounded = spaces.Box(-np.inf, np.inf, shape=(1,), dtype=np.float32)
    with pytest.raises(cehmm.InvalidArgumentError, match=r"invalid Grid values\[0\]: 1e\+40"):
        encoding(unbounded, "action", Grid(values=[[1e40]]))
    grid = encoding(pixels, "action", Grid(values=[[0, 255], [7]]))
    assert grid.value(1).tolist() == [255, 7] and pixels.contains(grid.value(1))
    # The default grid of an integer Box: integers, each action in the space.
    ints = spaces.Box(0, 10, shape=(1,), dtype=np.int64)
    default = encoding(ints, "action")
    assert all(ints.contains(default.value(i)) for i in range(default.size))
    assert sorted({int(default.value(i)[0]) for i in range(default.size)}) == [0, 2, 5, 8, 10]


class Cube(gym.Env):
    """A 3-d Box observation in [-1, 1], a Box action; 5 steps of reward 1."""

    spec = EnvSpec("cehmm-tests/Cube-v0", max_episode_steps=5)
    observation_space = spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float32)
    action_space = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)

    def reset(self, *, seed: int | None = None, options: Any = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        self.t = 0
        return self.observation_space.sample(), {}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict]:
        self.t += 1
        return self.observation_space.sample(), 1.0, False, self.t >= 5, {}


def _cube_policy() -> dict[str, Any]:
    """The document of a policy of 27 observations (3 bins of each of Cube's 3 dimensions) and 3 decisions."""
    world = cehmm.PythonWorld(Cube(), observations=Bins(3, fit="bounds"), actions=Grid(3), horizon=5)
    policy = cehmm.Policy.uniform(world, [2])
    assert (policy.n_obs, policy.n_actions) == (27, 3)
    return json.loads(policy.to_json())


def _edited(document: dict[str, Any], edit: str) -> dict[str, Any]:
    document = copy.deepcopy(document)
    spaces_record = document["world"]["spaces"]
    if edit == "two edge lists":
        spaces_record["observation"]["edges"].pop()
    elif edit == "no observation":
        del spaces_record["observation"]
    elif edit == "huge n":
        spaces_record["action"] = {"encoding": "flat", "space": {"type": "Discrete", "n": 10**20, "start": 0}}
    elif edit == "fewer actions":
        spaces_record["action"] = {
            "encoding": "flat",
            "space": {"type": "MultiDiscrete", "nvec": [2], "start": [0], "dtype": "int64"},
        }
    elif edit == "grid outside":
        spaces_record["action"]["values"] = [[-5.0, 0.0, 5.0]]
    elif edit == "grid of a count":  # Grid(3), unfitted (the fuzzer's find)
        spaces_record["action"]["values"] = 3
    elif edit == "not a dict":
        document["world"]["spaces"] = ["observation", "action"]
    return document


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        ("two edge lists", r"world\.spaces\.observation.*2 lists for Box\(-1\.0, 1\.0, \(3,\), float32\).*one per dim"),
        ("no observation", r"world\.spaces\.observation: missing"),
        ("huge n", r"world\.spaces\.action"),
        ("fewer actions", r"world\.spaces\.action.*2 decisions.*expected the policy's n_actions, 3"),
        ("grid outside", r"world\.spaces\.action.*invalid Grid values\[0\]: -5\.0"),
        ("grid of a count", r"world\.spaces\.action: .*expected the values of each dimension, a list"),
        ("not a dict", r"world\.spaces: \['observation', 'action'\]"),
    ],
)
def test_a_policy_whose_recorded_spaces_disagree_with_it_is_refused_naming_the_field(
    tmp_path: Any, edit: str, match: str
) -> None:
    document = _edited(_cube_policy(), edit)
    path = tmp_path / "edited.json"
    path.write_text(json.dumps(document))
    with pytest.raises(cehmm.PolicyFormatError, match=match):
        cehmm.Policy.load(path)
    with pytest.raises(cehmm.PolicyFormatError, match=match):
        cehmm.Policy.from_json(json.dumps(document))
    # A policy that came in some other way: its agent, evaluation and play refuse it the same.
    policy = cehmm.Policy(_core.Policy.load(str(path)))
    with pytest.raises(cehmm.PolicyFormatError, match=match):
        policy.agent()
    with pytest.raises(cehmm.PolicyFormatError, match=match):
        policy.evaluate(Cube(), episodes=2)
    with pytest.raises(cehmm.PolicyFormatError, match=match):
        cehmm.gym.play(Cube(), policy.agent(), episodes=1)


def test_the_untouched_policy_of_recorded_spaces_loads_acts_and_evaluates(tmp_path: Any) -> None:
    path = tmp_path / "cube.json"
    path.write_text(json.dumps(_cube_policy()))
    policy = cehmm.Policy.load(path)
    assert cehmm.gym.play(Cube(), policy.agent(), episodes=2).tolist() == [5.0, 5.0]
    assert policy.evaluate(Cube(), episodes=4).mean == 5.0


class Image(gym.Env):
    """An 84×84×3 image observation, never to be stepped."""

    observation_space = spaces.Box(0, 255, shape=(84, 84, 3), dtype=np.uint8)
    action_space = spaces.Discrete(2)

    def reset(self, *, seed: int | None = None, options: Any = None) -> tuple[np.ndarray, dict]:
        raise AssertionError("the warm-up should not have started")


def _refused_at_once(make: Any, match: str) -> None:
    """``make()`` raises InvalidArgumentError matching ``match`` within a second, having allocated under 20 MB."""
    tracemalloc.start()
    started = time.perf_counter()
    try:
        with pytest.raises(cehmm.InvalidArgumentError, match=match):
            make()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert time.perf_counter() - started < 1.0
    assert peak < 20e6, peak


def test_sizes_are_refused_from_their_arithmetic_before_anything_is_built() -> None:
    box = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
    _refused_at_once(lambda: Grid(10**8), r"invalid Grid values: 100000000 \(expected .*at most 65535")
    _refused_at_once(lambda: Grid(10**9), r"invalid Grid values: 1000000000")
    _refused_at_once(lambda: Bins(10**7, fit="bounds"), r"invalid Bins bins: 10000000 \(expected .*at most 65535")
    _refused_at_once(lambda: encoding(spaces.Box(-1.0, 1.0, shape=(3,)), "action", Grid(300)), r"27000000 actions")
    _refused_at_once(lambda: encoding(box, "observation", Bins(edges=[range(70000)])), r"70001 cells.*at most 65535")
    _refused_at_once(
        lambda: cehmm.PythonWorld(Image(), horizon=10),
        r"invalid observation encoding: .*21168 dimensions.*more than 65535 cells",
    )
    # Sizes past 4300 digits are never written out (Python refuses to), nor computed.
    _refused_at_once(lambda: Flat(spaces.MultiDiscrete([10] * 5000)), r"more than 2\*\*63 - 1 values")
    _refused_at_once(lambda: Flat(spaces.MultiBinary([10**5, 10**5])), r"more than 2\*\*63 - 1 values")
    _refused_at_once(
        lambda: cehmm.PythonWorld(Image(), observations=Bins(2, fit="bounds"), horizon=10), r"more than 65535 cells"
    )
    # Many components, most of one value: exact, past numpy's 64 dimensions.
    many = Flat(spaces.MultiDiscrete([2] * 10 + [1] * 90))
    assert many.size == 1024 and many.index(np.array([1] * 10 + [0] * 90)) == 1023
    assert many.value(5).tolist() == [0] * 7 + [1, 0, 1] + [0] * 90


def test_multibinary_observations_given_as_floats_are_indexed_as_their_bits() -> None:
    bits = spaces.MultiBinary(3)
    value = np.array([0.0, 1.0, 1.0])
    assert bits.contains(value)
    assert Flat(bits).index(value) == Flat(bits).index(np.array([0, 1, 1], dtype=np.int8)) == 3
    assert Flat(spaces.Tuple((bits, spaces.Discrete(2)))).index((value, 1)) == 7


class Warm(gym.Env):
    """Observes ``values[t]`` (cycling) in ``space``, for the warm-up of a quantile fit."""

    action_space = spaces.Discrete(2)

    def __init__(self, space: gym.Space, values: list[Any]) -> None:
        self.observation_space, self.values = space, values

    def reset(self, *, seed: int | None = None, options: Any = None) -> tuple[Any, dict]:
        super().reset(seed=seed)
        self.t = 0
        return self.values[0], {}

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        self.t += 1
        return self.values[self.t % len(self.values)], 0.0, False, self.t >= 10, {}


UNBOUNDED = spaces.Box(-np.inf, np.inf, shape=(2,), dtype=np.float64)


@pytest.mark.parametrize(
    ("values", "match"),
    [
        ([np.array([0.0, 1.0]), np.array([np.nan, 1.0])], r"warm-up observation array\(\[nan, +1\.\]\) is not in the"),
        (
            [np.array([0.0, 1.0]), np.array([0.0, 1.0, 2.0])],
            r"warm-up observation array\(\[0\., 1\., 2\.\]\) is not in",
        ),
        ([np.array([0.0, 1.0]), "up"], r"warm-up observation 'up' is not in the space"),
    ],
)
def test_warm_up_observations_outside_the_space_are_refused_naming_them(values: list[Any], match: str) -> None:
    with pytest.raises(cehmm.WorldError, match=match):
        cehmm.PythonWorld(Warm(UNBOUNDED, values), horizon=10)


def test_infinite_warm_up_observations_of_an_unbounded_box_fall_in_the_end_bins() -> None:
    values = [np.array([x, -x]) for x in [0.0, 1.0, 2.0, 3.0, np.inf]]
    world = cehmm.PythonWorld(Warm(UNBOUNDED, values), observations=Bins(4), horizon=10)
    edges = world.description["spaces"]["observation"]["edges"]
    assert all(np.all(np.isfinite(e)) for e in edges)
    bins = from_record(world.description["spaces"]["observation"], "observation")
    assert bins.index(np.array([np.inf, -np.inf])) == (len(edges[0])) * (len(edges[1]) + 1)


def test_bins_check_observations_against_their_space() -> None:
    bins = encoding(spaces.Box(0.0, 4.0, shape=(2,), dtype=np.float32), "observation", Bins(4, fit="bounds"))
    for value in ["ab", np.array([1.0, 2.0, 3.0], dtype=np.float32), np.array([5.0, 1.0], dtype=np.float32), None]:
        with pytest.raises(cehmm.WorldError, match="is not in the space"):
            bins.index(value)
    assert bins.index([1.5, 3.5]) == bins.index(np.array([1.5, 3.5], dtype=np.float32)) == 1 * 4 + 3
    # float64 values for a float32 Box (which Box.contains refuses, and Gymnasium's checker only
    # warns of) are read as the numbers they are; NaN is not a number in the space.
    assert bins.index(np.array([1.5, 3.5])) == 1 * 4 + 3
    with pytest.raises(cehmm.WorldError, match="is not in the space"):
        bins.index(np.array([np.nan, 1.0]))


def test_a_box_of_no_dimensions_has_one_cell_and_one_action() -> None:
    empty = spaces.Box(-1.0, 1.0, shape=(0,), dtype=np.float32)
    for choice in (None, Bins(fit="bounds"), Bins(edges=[])):
        bins = encoding(empty, "observation", choice, lambda steps, seed: [empty.sample() for _ in range(steps)])
        assert bins.size == 1 and bins.index(np.zeros(0, dtype=np.float32)) == 0
    grid = encoding(empty, "action")
    assert grid.size == 1 and empty.contains(grid.value(0))


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: Grid(True), r"invalid Grid values: True \(expected a positive int"),
        (lambda: Grid(2.5), r"invalid Grid values: 2\.5 \(expected a positive int"),
        (lambda: Grid(values=[[0.0], "ab"]), r"invalid Grid values\[1\]: 'ab'"),
        (lambda: Bins(2.5), r"invalid Bins bins: 2\.5 \(expected a positive int"),
        (lambda: Bins([2, True]), r"invalid Bins bins: \[2, True\]"),
        (lambda: Bins(edges=5), r"invalid Bins edges: 5 \(expected a list of lists"),
        (lambda: Bins(edges=[[0.0], "ab"]), r"invalid Bins edges\[1\]: 'ab'"),
    ],
)
def test_bad_encoding_arguments_are_refused_naming_them(make: Any, match: str) -> None:
    with pytest.raises(cehmm.InvalidArgumentError, match=match):
        make()


def test_records_keep_the_bounds_of_an_integer_box_exactly_and_refuse_bounds_beside_its_dtype() -> None:
    info = np.iinfo(np.int64)
    wide = spaces.Box(info.min, info.max, shape=(2,), dtype=np.int64)
    assert space_of(json.loads(json.dumps(space_record(wide)))) == wide
    record = space_record(spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32))
    with pytest.raises(ValueError, match=r"high 1e\+308 is not a bound of float32"):
        space_of({**record, "high": [1e308]})
    with pytest.raises(cehmm.PolicyFormatError, match=r"high 1e\+308 is not a bound of float32"):
        from_record({"encoding": "bins", "edges": [[0.0]], "space": {**record, "high": [1e308]}}, "observation")
