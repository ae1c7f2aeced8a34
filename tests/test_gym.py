"""Gymnasium both ways, first half: the target-tracking world as ``cehmm/TargetTracking-v0``
(passing Gymnasium's own checker, rendering ``ansi`` and ``rgb_array``), and learned policies as
agents in any loop, scoring there what the engine's evaluation says they score."""

from __future__ import annotations

import math
import os
import re
import warnings
from pathlib import Path

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import cehmm
import cehmm.gym


def test_the_environment_passes_gymnasiums_checker() -> None:
    for mode in ("ansi", "rgb_array"):
        env = gymnasium.make(cehmm.gym.ENV_ID, case=3, render_mode=mode)
        with warnings.catch_warnings():
            # The checker warns about what it cannot test; the checks themselves must pass.
            warnings.simplefilter("ignore", UserWarning)
            check_env(env.unwrapped)
    small = dict(width=8, height=6, start_b=[0, 5], start_c=[7, 5], target_cell=[4, 3], target_rows=[0, 2])
    env = gymnasium.make("cehmm.gym:cehmm/TargetTracking-v0", case=1, render_mode="rgb_array", **small)
    assert env.observation_space == gymnasium.spaces.Discrete(16)
    assert env.action_space == gymnasium.spaces.Discrete(16)
    env.reset(seed=0)
    image = env.render()
    assert isinstance(image, np.ndarray) and image.shape == (6 * 12, 8 * 12, 3) and image.dtype == np.uint8


def test_episodes_follow_the_world() -> None:
    env = cehmm.gym.TargetTrackingEnv(case=1, render_mode="ansi")
    first, info = env.reset(seed=4)
    assert info == {"t": 1}
    again, _ = env.reset(seed=4)
    assert first == again
    total, steps, truncated = 0.0, 0, False
    while not truncated:
        _, reward, terminated, truncated, info = env.step(env.action_space.sample())
        assert not terminated and reward in (0.0, 1.0)
        total += reward
        steps += 1
    assert steps == 100 and info["t"] == 101
    text = env.render()
    assert isinstance(text, str) and text.count("\n") == 21 and "B" in text and "R" in text
    assert f"reward so far {total:g}" in text
    with pytest.raises(cehmm.InvalidArgumentError, match="after the last step"):
        env.step(0)
    env.reset(seed=1)
    with pytest.raises(cehmm.InvalidArgumentError, match="decision: 16"):
        env.step(16)


def test_a_learned_agent_scores_in_a_gymnasium_loop_what_the_engine_says(case1: cehmm.TargetTracking) -> None:
    result = cehmm.optimize(case1, levels=[8, 4], samples=300, rho=0.1, max_iterations=15, progress=False)
    engine = result.policy.evaluate(case1, episodes=4000, seed=2)
    env = gymnasium.make(cehmm.gym.ENV_ID, case=1)
    agent = result.policy.agent(seed=9)
    returns = cehmm.gym.play(env, agent, episodes=400)
    assert returns.shape == (400,) and np.all((returns >= 0) & (returns <= 100))
    mean, sd = float(np.mean(returns)), float(np.std(returns, ddof=1))
    z = (mean - engine.mean) / math.hypot(sd / math.sqrt(len(returns)), engine.std_error)
    assert abs(z) < 4, (mean, engine.mean, z)
    with pytest.raises(cehmm.InvalidArgumentError, match="observation: 16"):
        agent.act(16)
    with pytest.raises(TypeError, match="observation"):
        agent.act("3")  # type: ignore[arg-type]


TIGER = str(Path(__file__).resolve().parents[1] / "data" / "pomdp" / "tiger.95.POMDP")


@pytest.mark.parametrize(
    "make",
    [
        dict(id=cehmm.gym.WORLD_ENV_ID, name="target-tracking", case=2),
        dict(id=cehmm.gym.WORLD_ENV_ID, name="pomdp", file=TIGER, horizon=20),
        dict(id=cehmm.gym.POMDP_ENV_ID, file=TIGER, horizon=20),
    ],
)
def test_every_world_is_an_environment_that_passes_gymnasiums_checker(make: dict) -> None:
    env = gymnasium.make(**make)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # check_env's notes on an env made through make()
        check_env(env.unwrapped, skip_render_check=True)
    world = env.unwrapped.world
    assert (env.observation_space.n, env.action_space.n) == (world.n_observations, world.n_decisions)


def test_a_pomdp_environment_scores_what_the_engine_says() -> None:
    world = cehmm.PomdpWorld.from_file(TIGER, horizon=10)
    policy = cehmm.Policy.random(world, [2, 2], seed=1)
    env = gymnasium.make(cehmm.gym.POMDP_ENV_ID, file=TIGER, horizon=10, render_mode="ansi")
    returns = cehmm.gym.play(env, policy.agent(seed=3), episodes=2000)
    engine = policy.evaluate(world, episodes=20_000, seed=2)
    z = (returns.mean() - engine.mean) / math.hypot(returns.std() / math.sqrt(len(returns)), engine.std_error)
    assert abs(z) < 4, (returns.mean(), engine)
    env.reset(seed=0)
    assert env.render().startswith("t = 1: state ")


def test_a_name_that_is_not_a_str_and_a_file_that_is_not_a_path_say_so() -> None:
    for name in (3, None, ["target-tracking"]):
        with pytest.raises(TypeError, match=rf"invalid name: {re.escape(repr(name))} is not a str \(expected a"):
            gymnasium.make(cehmm.gym.WORLD_ENV_ID, name=name)
    with pytest.raises(TypeError, match=r"invalid file: 3 is not a path \(expected the path of a \.pomdp file"):
        gymnasium.make(cehmm.gym.POMDP_ENV_ID, file=3)


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="needs /dev/zero and FIFOs (a Unix system)")
def test_a_pomdp_file_that_is_not_a_regular_file_or_too_large_is_refused_at_once(tmp_path: Path) -> None:
    from test_readers import at_once

    fifo = tmp_path / "fifo.POMDP"
    os.mkfifo(fifo)
    zero = tmp_path / "zero.POMDP"
    zero.symlink_to("/dev/zero")
    big = tmp_path / "big.POMDP"
    with open(big, "wb") as f:
        f.truncate(1 << 34)  # sparse: nothing is written
    refusals = {
        Path("/dev/zero"): "is not a regular file",
        Path("/dev/urandom"): "is not a regular file",
        zero: "(a link to /dev/zero) is not a regular file",
        fifo: "is not a regular file",
        tmp_path: "is a directory",
        big: f"has {1 << 34} bytes (at most",
    }
    for path, said in refusals.items():
        e = at_once(gymnasium.make, cehmm.gym.POMDP_ENV_ID, file=path, horizon=10, fifo=fifo if path == fifo else None)
        assert isinstance(e, cehmm.InvalidArgumentError), e
        assert f"invalid pomdp.file: {path} {said}" in str(e), e
