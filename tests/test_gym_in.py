"""Gymnasium in (cehmm.gym_adapt): finite spaces flattened to one index both ways (continuous ones
are cut into bins: tests/test_spaces.py); environments, ids, factories and vector environments optimised and
evaluated; a real package's environment that needs memory (popgym) in a short run."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces
from worlds import Shows

import cehmm
import cehmm.gym
from cehmm.gym_adapt import flat
from cehmm.world import core_world


@pytest.mark.parametrize(
    ("space", "size"),
    [
        (spaces.Discrete(5, start=-2), 5),
        (spaces.MultiDiscrete([3, 4]), 12),
        (spaces.MultiDiscrete([[2, 3], [2, 2]]), 24),
        (spaces.MultiBinary(3), 8),
        (spaces.Tuple((spaces.Discrete(2), spaces.MultiDiscrete([3, 2]), spaces.Discrete(3, start=1))), 36),
    ],
)
def test_finite_spaces_flatten_to_one_index_both_ways(space: gym.Space, size: int) -> None:
    f = flat(space)
    assert f.size == size
    values = [f.value(i) for i in range(size)]
    assert all(space.contains(v) for v in values)
    assert [f.index(v) for v in values] == list(range(size))
    space.seed(0)
    for _ in range(50):
        sample = space.sample()
        assert same(f.value(f.index(sample)), sample)


def same(a: object, b: object) -> bool:
    if isinstance(a, tuple) and isinstance(b, tuple):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    return bool(np.array_equal(a, b))


def test_the_flattening_is_row_major() -> None:
    f = flat(spaces.MultiDiscrete([3, 4]))
    assert f.index(np.array([1, 2])) == 1 * 4 + 2
    assert flat(spaces.Tuple((spaces.Discrete(2), spaces.Discrete(3)))).index((1, 0)) == 3


def test_spaces_too_large_to_index_are_refused_with_their_exact_size() -> None:
    # numpy's int64 product wrapped: the first was taken as 2 values, the second as negative.
    for space, size in [
        (spaces.MultiDiscrete([3, (2**64 + 2) // 3]), 3 * ((2**64 + 2) // 3)),
        (spaces.MultiBinary(63), 2**63),
        (spaces.Tuple((spaces.MultiBinary(40), spaces.MultiBinary(40))), 2**80),
    ]:
        with pytest.raises(cehmm.InvalidArgumentError, match=f"has {size} values"):
            flat(space)
    assert flat(spaces.MultiBinary(62)).size == 2**62


def test_continuous_spaces_are_not_flattened_and_other_spaces_are_refused_with_a_hint() -> None:
    with pytest.raises(cehmm.InvalidArgumentError, match=r"observation space: Box.*is continuous.*cehmm.spaces.Bins"):
        flat(gym.make("CartPole-v1").observation_space)
    with pytest.raises(cehmm.InvalidArgumentError, match=r"expected Discrete, MultiDiscrete"):
        flat(spaces.Dict({"a": spaces.Discrete(2)}))


def test_an_environment_an_id_and_a_factory_are_the_same_world() -> None:
    worlds = [
        cehmm.PythonWorld(gym.make("FrozenLake-v1", is_slippery=False)),
        cehmm.PythonWorld("FrozenLake-v1"),
        cehmm.PythonWorld(lambda: gym.make("FrozenLake-v1")),
    ]
    for w in worlds:
        assert (w.n_observations, w.n_decisions, w.horizon) == (16, 4, 100)
        assert w.description["id"] == "FrozenLake-v1"
    # Options given later wrap what was given, not its adapter: the id is kept.
    assert core_world(worlds[0], discount=0.9).description["id"] == "FrozenLake-v1"


def test_a_short_run_learns_a_gymnasium_environment() -> None:
    env = gym.make("FrozenLake-v1", is_slippery=False)
    result = cehmm.optimize(
        env, levels=[16], samples=500, rho=0.05, smoothing=0.3, max_iterations=20, progress=False, eval_episodes=1000
    )
    # The uniform random policy reaches the goal in about 1.5 % of episodes.
    assert result.evaluation.mean > 0.5, result
    assert result.policy.world["id"] == "FrozenLake-v1"


def test_a_vector_environment_is_the_batched_path_with_the_same_episodes_in_distribution() -> None:
    policy = cehmm.Policy.random(cehmm.PythonWorld(gym.make("FrozenLake-v1")), [4], seed=2)
    single = policy.evaluate(gym.make("FrozenLake-v1"), episodes=3000, seed=1)
    vector = gym.make_vec("FrozenLake-v1", num_envs=8, vectorization_mode="sync")
    world = cehmm.PythonWorld(vector)
    assert world.batch == 8 and world.horizon == 100
    batched = policy.evaluate(world, episodes=3000, seed=1)
    z = (batched.mean - single.mean) / math.hypot(batched.std_error, single.std_error)
    assert abs(z) < 4, (single, batched)
    assert policy.evaluate(world, episodes=200, seed=4) == policy.evaluate(world, episodes=200, seed=4)


def test_battleship_from_popgym_learns_a_firing_plan_in_a_short_run() -> None:
    pytest.importorskip("popgym")
    world = cehmm.PythonWorld(gym.make("popgym-BattleshipEasy-v0"), horizon=64)
    assert (world.n_observations, world.n_decisions) == (2, 64)  # MultiDiscrete([8, 8]) flattened
    result = cehmm.optimize(
        world,
        levels=[64, 64],
        init="clock",
        samples=300,
        rho=0.1,
        smoothing=0.5,
        max_iterations=25,
        progress=False,
        eval_episodes=1000,
    )
    # Uniform random firing scores -0.45 (examples/gym_memory.py learns -0.01 in 300 iterations).
    means = result.history["mean"]
    assert means[-3:].mean() > means[:3].mean() + 0.02, means
    assert result.evaluation.mean > -0.44
    # Back out as an agent in a Gymnasium loop: actions unflattened to MultiDiscrete([8, 8]).
    returns = cehmm.gym.play(gym.make("popgym-BattleshipEasy-v0"), result.policy.agent(seed=1), episodes=400)
    z = (returns.mean() - result.evaluation.mean) / math.hypot(returns.std() / 20, result.evaluation.std_error)
    assert abs(z) < 4, (returns.mean(), result.evaluation)


def test_a_memory_task_from_popgym_is_optimised() -> None:
    popgym = pytest.importorskip("popgym")
    assert popgym is not None
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make("popgym-RepeatPreviousEasy-v0", k=2)
        # 51 steps, then the environment ends the episode: a longer horizon is cut short.
        world = cehmm.PythonWorld(env, horizon=60)
        result = cehmm.optimize(
            world, levels=[16, 4], samples=300, max_iterations=3, progress=False, init="random", eval_episodes=300
        )
    assert result.iterations == 3 and -1.0 <= result.evaluation.mean <= 1.0
    assert len(result.policy.rollout(world)) == 51
    assert result.policy.world["id"] == "popgym-RepeatPreviousEasy-v0"


@pytest.mark.parametrize(
    ("space", "bad"),
    [
        (spaces.Discrete(3), 1.7),
        (spaces.Discrete(3), "2"),
        (spaces.Discrete(3), 3),
        (spaces.Discrete(3, start=1), 0),
        (spaces.MultiDiscrete([3, 4]), np.array([1])),
        (spaces.MultiDiscrete([3, 4]), np.array([1, 4])),
        (spaces.MultiBinary(3), np.array([0, 2, 1])),
        (spaces.Tuple((spaces.Discrete(2), spaces.Discrete(2))), (0, 1, 1)),
        (spaces.Tuple((spaces.Discrete(2), spaces.Discrete(2))), (0, 2)),
        (spaces.Tuple((spaces.Discrete(2),)), None),
    ],
)
def test_an_observation_outside_its_space_is_named(space: gym.Space, bad: object) -> None:
    # It was cast (1.7 -> 1, '2' -> 2), broadcast ([1] -> 5) or raised numpy's own errors.
    policy = cehmm.Policy.uniform(cehmm.PythonWorld(Shows(space, space.sample()), horizon=3), [1])
    with pytest.raises(cehmm.WorldError, match=r"observation .* is not in the space") as raised:
        policy.evaluate(cehmm.PythonWorld(Shows(space, bad), horizon=3), episodes=2)
    assert any("episode 0 (evaluate), reset" in note for note in raised.value.__notes__)


def test_a_tuple_of_nothing_is_one_observation() -> None:
    world = cehmm.PythonWorld(Shows(spaces.Tuple(()), ()), horizon=3)
    assert world.n_observations == 1
    assert cehmm.Policy.uniform(world, [1]).evaluate(world, episodes=4).mean == 1


class Countdown(gym.Env):
    """Observes the steps left (Discrete(4)); reward 1 for action 1; ends after 1 to 3 steps
    (drawn at reset)."""

    observation_space, action_space = spaces.Discrete(4), spaces.Discrete(2)

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[int, dict]:
        super().reset(seed=seed)
        self.left = int(self.np_random.integers(1, 4))
        return self.left, {}

    def step(self, action: object) -> tuple[int, float, bool, bool, dict]:
        self.left -= 1
        return self.left, float(action == 1), self.left == 0, False, {}


def test_vector_environments_in_every_autoreset_mode_and_with_tuple_observations() -> None:
    # AutoresetMode.DISABLED failed on Gymnasium's assertion (a sub-environment that had ended
    # was stepped again while others went on): its ended ones are now reset at once. The same
    # episodes in every mode.
    policy = cehmm.Policy.random(cehmm.PythonWorld(Countdown(), horizon=5), [2], seed=3)
    evaluations = []
    for mode in gym.vector.AutoresetMode:
        vector = gym.vector.SyncVectorEnv([Countdown] * 4, autoreset_mode=mode)
        evaluations.append(policy.evaluate(cehmm.PythonWorld(vector, horizon=5), episodes=40, seed=1))
    assert evaluations[0].std > 0 and all(e == evaluations[0] for e in evaluations), evaluations
    # Blackjack's observations are a Tuple: a TypeError from Gymnasium's iterate before.
    blackjack = gym.make_vec("Blackjack-v1", num_envs=4, vectorization_mode="sync")
    world = cehmm.PythonWorld(blackjack, horizon=10)
    assert world.n_observations == 32 * 11 * 2
    evaluation = cehmm.Policy.uniform(world, [1]).evaluate(world, episodes=200)
    assert -1 <= evaluation.mean <= 1


def test_an_environments_reward_and_flags_are_checked_as_any_worlds() -> None:
    class Says(Countdown):
        def __init__(self, reward: object, terminated: object) -> None:
            self.reward, self.terminated = reward, terminated

        def step(self, action: object) -> tuple[int, object, object, bool, dict]:
            left, _, _, truncated, info = super().step(action)
            return left, self.reward, self.terminated, truncated, info

    policy = cehmm.Policy.uniform(cehmm.PythonWorld(Countdown(), horizon=5), [1])
    with pytest.raises(cehmm.WorldError, match="done"):
        policy.evaluate(cehmm.PythonWorld(Says(0.0, "False"), horizon=5), episodes=2)
    with pytest.raises(cehmm.WorldError, match="reward"):
        policy.evaluate(cehmm.PythonWorld(Says(1 + 0j, False), horizon=5), episodes=2)


class Walk(gym.Env):
    """A corridor of six cells and no ``max_episode_steps``: step right (1) or left (0) from
    cell 0; reaching cell 5 ends the episode with reward 1."""

    observation_space, action_space = spaces.Discrete(6), spaces.Discrete(2)

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[int, dict]:
        super().reset(seed=seed)
        self.cell = 0
        return self.cell, {}

    def step(self, action: object) -> tuple[int, float, bool, bool, dict]:
        self.cell = max(0, self.cell + (1 if action == 1 else -1))
        return self.cell, float(self.cell == 5), self.cell == 5, False, {}


def test_an_environment_without_a_horizon_is_told_the_one_it_gets_and_how_to_choose() -> None:
    # It got horizon=1000 silently: on a six-step corridor, a minute's search for less than the
    # optimum that horizon=12 finds in seconds.
    with pytest.warns(cehmm.gym_adapt.HorizonWarning) as warned:
        world = cehmm.PythonWorld(Walk())
    (warning,) = warned
    assert world.horizon == cehmm.gym_adapt.DEFAULT_HORIZON == 1000
    assert issubclass(warning.category, UserWarning)
    message = str(warning.message)
    assert "test_gym_in.Walk" in message and "no max_episode_steps" in message, message
    assert "cut at 1000 steps" in message and "horizon=" in message, message
    assert warning.filename == __file__  # the line that made the world, not the package's
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert cehmm.PythonWorld(Walk(), horizon=12).horizon == 12
        assert cehmm.PythonWorld(gym.make("FrozenLake-v1")).horizon == 100
    with pytest.warns(cehmm.gym_adapt.HorizonWarning, match="cut at 1000 steps"):
        policy = cehmm.Policy.uniform(Walk(), [1])
    assert policy.world["horizon"] == 1000
