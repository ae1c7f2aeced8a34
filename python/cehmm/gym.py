"""Every world of the engine as a Gymnasium environment: ``cehmm/World-v0`` (any registered world,
``gymnasium.make("cehmm/World-v0", name="target-tracking", case=3)``), ``cehmm/Pomdp-v0`` (a
``.pomdp`` file, ``gymnasium.make("cehmm/Pomdp-v0", file="tiger.95.POMDP", horizon=100)``) and
``cehmm/TargetTracking-v0`` (model §4, with its drawings), all one :class:`WorldEnv`: ``Discrete``
observations and decisions (the world's ``y`` and ``d``; a ``.pomdp`` world's first observation is
its start symbol), the reward of each step, ``terminated`` where the world ends an episode early,
``truncated`` after the horizon.

The target-tracking world as a Gymnasium environment, ``cehmm/TargetTracking-v0`` (model §4).

``gymnasium.make("cehmm/TargetTracking-v0", case=3)`` (any :class:`cehmm.TargetTracking` keyword
is taken) steps the engine's own world one decision at a time: ``Discrete(16)`` observations and
decisions (model §4's ``y`` and ``d``), the reward of a step is 1 when it is rewarded (the
episode's return is the world's ``V``), never ``terminated``, ``truncated`` after the horizon.
``render_mode="ansi"`` draws the grid as text, ``"rgb_array"`` as an image. A learned policy acts
in such a loop through :meth:`cehmm.Policy.agent`.

Gymnasium is an optional dependency (``pip install cehmm[gym]``): importing this module needs it,
and registers the environment; ``gymnasium.make("cehmm.gym:cehmm/TargetTracking-v0")`` imports it
first (Gymnasium 1.x no longer loads plugins by itself).
"""

from __future__ import annotations

import os
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from . import _core
from .tracking import TargetTracking
from .world import World, core_world

ENV_ID = "cehmm/TargetTracking-v0"
WORLD_ENV_ID = "cehmm/World-v0"
POMDP_ENV_ID = "cehmm/Pomdp-v0"

#: Colours of the rgb_array drawing: empty cell, target rows, B, C, the target.
_COLOURS = {
    "empty": (245, 245, 245),
    "rows": (225, 232, 245),
    "B": (31, 119, 180),
    "C": (44, 160, 44),
    "target": (214, 39, 40),
}
_CELL = 12


class WorldEnv(gymnasium.Env[np.int64, np.int64]):
    """A world of the engine (``name`` and its parameters, as :class:`cehmm.World` takes them) as
    a Gymnasium environment (module docs); ``render_mode="ansi"`` prints the state's numbers.

    Example:
        >>> env = gymnasium.make(WORLD_ENV_ID, name="pomdp", file="data/pomdp/tiger.95.POMDP", horizon=10)
        >>> env.observation_space, env.action_space
        (Discrete(3), Discrete(3))
        >>> observation, info = env.reset(seed=0)
        >>> int(observation), info
        (2, {'t': 1})
        >>> observation, reward, terminated, truncated, info = env.step(0)  # listen
        >>> reward, terminated, truncated
        (-1.0, False, False)
    """

    metadata: dict[str, Any] = {"render_modes": ["ansi"], "render_fps": 4}

    def __init__(self, name: str, render_mode: str | None = None, **params: Any) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"invalid render_mode: {render_mode!r} (expected one of {self.metadata['render_modes']})")
        if not isinstance(name, str):
            raise TypeError(
                f"invalid name: {name!r} is not a str (expected a world's registered name, e.g. "
                'name="target-tracking")'
            )
        self.world = World.from_dict({"name": name, **params})
        self.render_mode = render_mode
        self.observation_space = spaces.Discrete(self.world.n_observations)
        self.action_space = spaces.Discrete(self.world.n_decisions)
        self._params = self.world.to_dict()
        self._session: _core.Session | None = None

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.int64, dict]:
        super().reset(seed=seed)
        # Each episode's draws come from the environment's generator: the same seed, the same episodes.
        episode_seed = int(self.np_random.integers(0, 2**63))
        self._session = _core.Session(core_world(self.world), episode_seed, 0)
        return np.int64(self._session.observation), {"t": self._session.t}

    def step(self, action: Any) -> tuple[np.int64, float, bool, bool, dict]:
        if self._session is None:
            raise gymnasium.error.ResetNeeded("call reset() before step()")
        observation, reward, over = self._session.step(int(action))
        # Over before the horizon: the world ended the episode; at it: the horizon cut it.
        truncated = over and self._session.t > self.world.horizon
        return np.int64(observation), float(reward), over and not truncated, truncated, {"t": self._session.t}

    def render(self) -> str | np.ndarray | None:
        if self.render_mode is None or self._session is None:
            return None
        labels = ", ".join(f"{k} {v}" for k, v in zip(self.world.state_labels, self._session.describe()))
        return f"t = {self._session.t}: {labels}; reward so far {self._session.reward:g}\n"


class PomdpEnv(WorldEnv):
    """A ``.pomdp`` file as a Gymnasium environment (``cehmm/Pomdp-v0``; ``file=``, ``horizon=``,
    ``discount=``, ``reward=`` as :class:`cehmm.PomdpWorld` takes them).

    Example:
        >>> env = PomdpEnv("data/pomdp/tiger.95.POMDP", horizon=2, render_mode="ansi")
        >>> _ = env.reset(seed=0)
        >>> print(env.render(), end="")
        t = 1: state 0, observation 2; reward so far 0
        >>> [env.step(0)[2:4] for _ in range(2)]  # terminated, truncated: the horizon cuts the second
        [(False, False), (False, True)]
    """

    def __init__(self, file: str, render_mode: str | None = None, **params: Any) -> None:
        if not isinstance(file, (str, bytes, os.PathLike)):
            raise TypeError(
                f"invalid file: {file!r} is not a path (expected the path of a .pomdp file: a str, bytes or an "
                "os.PathLike)"
            )
        # The engine reads it (a regular file only, of bounded size: ceworld::files::read_limited).
        super().__init__("pomdp", render_mode=render_mode, file=os.fsdecode(file), **params)


class TargetTrackingEnv(WorldEnv):
    """The paper's target-tracking world (model §4) as a Gymnasium environment (module docs).

    Example:
        >>> env = gymnasium.make(ENV_ID, case=1, width=5, height=5, start_b=[0, 4], start_c=[4, 4],
        ...                      target_rows=[0, 2], target_cell=[2, 2], render_mode="ansi")
        >>> _ = env.reset(seed=0)
        >>> env.render().splitlines()  # B and C: the mobiles; R: the target
        ['.....', '.....', '..R..', '.....', 'B...C', 't = 1, reward so far 0']
        >>> env.observation_space, env.action_space
        (Discrete(16), Discrete(16))
    """

    metadata = {"render_modes": ["ansi", "rgb_array"], "render_fps": 4}

    def __init__(self, render_mode: str | None = None, **params: Any) -> None:
        super().__init__(TargetTracking.registered_name, render_mode=render_mode, **params)

    def render(self) -> str | np.ndarray | None:
        if self.render_mode is None or self._session is None:
            return None
        return self._ansi() if self.render_mode == "ansi" else self._rgb()

    def _cells(self) -> tuple[int, int, dict[tuple[int, int], str]]:
        assert self._session is not None
        b_i, b_j, _, c_i, c_j, _, r_i, r_j = self._session.describe()
        marks = {(r_i, r_j): "target", (c_i, c_j): "C", (b_i, b_j): "B"}
        return int(self._params["width"]), int(self._params["height"]), marks

    def _ansi(self) -> str:
        width, height, marks = self._cells()
        symbol = {"B": "B", "C": "C", "target": "R"}
        lines = ["".join(symbol.get(marks.get((i, j), ""), ".") for i in range(width)) for j in range(height)]
        assert self._session is not None
        return "\n".join(lines) + f"\nt = {self._session.t}, reward so far {self._session.reward:g}\n"

    def _rgb(self) -> np.ndarray:
        width, height, marks = self._cells()
        image = np.empty((height * _CELL, width * _CELL, 3), dtype=np.uint8)
        image[:] = _COLOURS["empty"]
        low, high = self._params.get("target_rows", [0, -1])
        image[low * _CELL : (high + 1) * _CELL] = _COLOURS["rows"]
        for (i, j), what in marks.items():
            image[j * _CELL + 1 : (j + 1) * _CELL - 1, i * _CELL + 1 : (i + 1) * _CELL - 1] = _COLOURS[what]
        return image


def play(env: gymnasium.Env, agent: Any, episodes: int, seed: int = 0) -> np.ndarray:
    """The return of each of ``episodes`` episodes of ``agent`` (e.g. :meth:`cehmm.Policy.agent`)
    in ``env``: episode ``k`` resets the environment with ``seed + k`` and the agent, then steps
    until it is terminated or truncated. An agent of a policy learnt on a Gymnasium environment
    (:class:`cehmm.encoded.EnvAgent`) takes the environment's values as they are; any other's
    observations and actions go through the flattening of the environment's finite spaces
    (:class:`cehmm.spaces.Flat`).

    Example:
        >>> env = gymnasium.make(ENV_ID, case=1)
        >>> agent = cehmm.Policy.uniform(cehmm.TargetTracking(case=1), [2]).agent()
        >>> play(env, agent, episodes=3).shape
        (3,)
    """
    from .encoded import EnvAgent
    from .spaces import Flat

    if not isinstance(agent, EnvAgent):
        agent = EnvAgent(agent, Flat(env.observation_space, "observation"), Flat(env.action_space, "action"))
    returns = np.empty(episodes)
    for k in range(episodes):
        observation, _ = env.reset(seed=seed + k)
        agent.reset()
        total, done = 0.0, False
        while not done:
            observation, reward, terminated, truncated, _ = env.step(agent.act(observation))
            total += float(reward)
            done = terminated or truncated
        returns[k] = total
    return returns


def register_envs() -> None:
    """Registers the environments with Gymnasium (once).

    Example:
        >>> register_envs()  # importing cehmm.gym did it: again, nothing changes
        >>> sorted(env_id for env_id in gymnasium.registry if env_id.startswith("cehmm/"))
        ['cehmm/Pomdp-v0', 'cehmm/TargetTracking-v0', 'cehmm/World-v0']
    """
    for env_id, entry in [(ENV_ID, "TargetTrackingEnv"), (WORLD_ENV_ID, "WorldEnv"), (POMDP_ENV_ID, "PomdpEnv")]:
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point=f"cehmm.gym:{entry}")


register_envs()
