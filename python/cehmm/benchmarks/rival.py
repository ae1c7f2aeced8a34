"""The memory benchmark's rival: sb3-contrib's RecurrentPPO (an LSTM policy, ``MlpLstmPolicy``,
``n_steps=512``, sb3-contrib's defaults otherwise, on one CPU thread), trained once per task and
seed up to the largest budget in steps, its deterministic policy valued at each budget on the
benchmark's fresh episodes (training paused meanwhile: the seconds are training's alone).

A heavy optional extra (``pip install -e '.[rivals]'``: torch), never run in CI: the benchmark
runs it once and reuses its records.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from ..encoded import EnvAgent


def run_rival(
    make: Callable[[], Any],
    budgets: Mapping[str, tuple[int | None, float | None]],
    seed: int,
    value: Callable[[Callable[[], Any]], tuple[float, float]],
) -> list[dict[str, Any]]:
    """Trains RecurrentPPO on the environment ``make()`` gives, with ``seed``, until every budget
    of ``budgets`` (name: (steps, seconds), one of the two given) is reached, and values its
    policy at each with ``value`` (given a fresh agent's factory: its mean and standard error).
    One record per budget: ``budget``, ``value``, ``std_error``, ``env_steps``, ``seconds`` (of
    training), and the training curve so far (``curve``: env steps, seconds, mean return of the
    last 100 training episodes)."""
    import torch
    from sb3_contrib import RecurrentPPO
    from stable_baselines3.common.callbacks import BaseCallback

    torch.set_num_threads(1)
    pending = dict(budgets)
    records: list[dict[str, Any]] = []
    curve: list[list[float]] = []

    class Marks(BaseCallback):  # type: ignore[misc]
        """Values the policy where a budget is reached; stops once every budget is."""

        def __init__(self) -> None:
            super().__init__()
            self.training, self.since = 0.0, time.perf_counter()

        def _on_step(self) -> bool:
            now = time.perf_counter()
            self.training, self.since = self.training + now - self.since, now
            for name, (steps, seconds) in list(pending.items()):
                if (steps is not None and self.num_timesteps >= steps) or (
                    seconds is not None and self.training >= seconds
                ):
                    del pending[name]
                    mean, error = value(lambda: _Agent(self.model))
                    records.append(
                        {
                            "budget": name,
                            "value": mean,
                            "std_error": error,
                            "env_steps": int(self.num_timesteps),
                            "seconds": self.training,
                            "curve": list(curve),
                        }
                    )
                    self.since = time.perf_counter()
            return bool(pending)

        def _on_rollout_end(self) -> None:
            returns = [info["r"] for info in self.model.ep_info_buffer or ()]
            if returns:
                curve.append([int(self.num_timesteps), round(self.training, 2), round(float(np.mean(returns)), 4)])

    model = RecurrentPPO("MlpLstmPolicy", make(), n_steps=512, seed=seed, device="cpu", verbose=0)
    model.learn(total_timesteps=10**12, callback=Marks())
    return records


class _Agent(EnvAgent):
    """RecurrentPPO's deterministic policy as an agent that speaks the environment's spaces
    (``reset``, ``act``: :func:`cehmm.gym.play` plays it as it is), its LSTM state kept between
    steps."""

    def __init__(self, model: Any) -> None:
        self.model = model
        self.reset()

    def reset(self) -> None:
        self.state, self.start = None, np.ones((1,), dtype=bool)

    def act(self, observation: Any) -> Any:
        action, self.state = self.model.predict(
            observation, state=self.state, episode_start=self.start, deterministic=True
        )
        self.start = np.zeros((1,), dtype=bool)
        return action
