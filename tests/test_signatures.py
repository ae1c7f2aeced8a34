"""Every optimiser's Python signature against the engine's settings: a setting is declared once,
in its Rust config (its field, default and the line of ``Settings::set`` that reads it), and
reaches Python through ``_core.CE_DEFAULTS``, ``_core.CONTROLLER_DEFAULTS``, ``_core.Q_DEFAULTS``
and ``_core.WINDOW_DEFAULTS`` (each serialised from its config). The Python functions repeat the
names as keywords (for help, completion and type checking), so this test checks that they
repeat them all, with the engine's defaults: a setting added to a config and not to the Python
signature fails here, naming the function and the setting."""

from __future__ import annotations

import dataclasses
import inspect
from pathlib import Path
from typing import Any, Callable

import pytest

import cehmm
from cehmm import _core
from cehmm.qlearning import QLearner

#: Parameters that are not settings of an engine config: how a run is driven, on what, and what
#: it reports (each with why it is not a config's setting). A parameter of an optimiser that is
#: neither a core setting nor named here fails the test.
RUN_OPTIONS: dict[str, str] = {
    "self": "the object a method is called on",
    "cls": "the class a class method is called on",
    "world": "the world optimised in (or evaluated on)",
    "policy": "the policy evaluated",
    "levels": "the HHMM's shape, given by the initial policy (optimize)",
    "init": "the initial policy (optimize)",
    "value": "how a controller is valued: exact or sampled (optimize_controller)",
    "search": "which search runs: the CE over controllers or the model search (optimize_controller)",
    "iterations": "the number of Q-learning updates, the run's length, not a learning setting",
    "progress": "a live progress line",
    "callback": "called after every iteration with its record (cehmm.callbacks), may stop the run",
    "tensorboard_log": "a folder for a TensorBoard event file of every iteration's scalars",
    "checkpoint": "the checkpoint file",
    "checkpoint_every": "seconds between checkpoints (a setting of CE_DEFAULTS and Q_DEFAULTS, where checked)",
    "resume": "whether to continue the checkpoint",
    "score": "a Python world's score function",
    "discount": "a Python world's discount",
    "horizon": "a Python world's horizon",
    "backend": "where a Python world's episodes run (local or Ray)",
    "workers": "the number of Python world workers",
    "address": "the Ray cluster's address",
    "seed": "the window evaluation's seed (a setting of every learning config, where checked)",
    "threads": "the window evaluation's thread count (a setting of CE and controller configs, where checked)",
    "reference": "the reward counted as 100 % in window reports",
    "ties": "the greedy policy's tie rule in window evaluation (a Q setting, where checked)",
}

#: Parameters whose Python default is ``None`` although the engine's is not, by design.
NONE_BY_DESIGN: dict[tuple[str, str], str] = {
    ("cehmm.QLearner.train", "checkpoint_every"): "None: no periodic checkpoint, only on a stop and at the end",
}


def _without(defaults: dict[str, Any], *names: str) -> dict[str, Any]:
    return {k: v for k, v in defaults.items() if k not in names}


def _entry_points() -> list[tuple[str, Callable[..., Any], dict[str, Any], dict[str, Any]]]:
    """Each optimiser's public function: its name, the function, the core settings it must take
    (name: the engine's default) and those whose default depends on the kind of value (the
    controller's sampled values), which it must default to ``None``."""
    controller = dict(_core.CONTROLLER_DEFAULTS)
    sampled = controller.pop("sampled")
    # A setting of the CE over controllers alone, or the model search's default of another value,
    # depends on the search (optimize_controller's `search`) as the others on the kind of value.
    model = dict(_core.OPTIMISERS)["model-search"]
    by_search = {k: model.get(k, "(none)") for k, v in controller.items() if k not in model or model[k] != v}
    by_kind = {**by_search, **sampled}
    return [
        ("cehmm.optimize", cehmm.optimize, dict(_core.CE_DEFAULTS), {}),
        ("cehmm.optimize_controller", cehmm.optimize_controller, controller, by_kind),
        ("cehmm.qlearning", cehmm.qlearning, dict(_core.Q_DEFAULTS), {}),
        ("cehmm.QLearner.new", QLearner.new, _without(_core.Q_DEFAULTS, "checkpoint_every"), {}),
        ("cehmm.QLearner.train", QLearner.train, {"checkpoint_every": _core.Q_DEFAULTS["checkpoint_every"]}, {}),
        ("cehmm.QLearner.evaluate_windows", QLearner.evaluate_windows, dict(_core.WINDOW_DEFAULTS), {}),
        ("cehmm.evaluate_windows", cehmm.evaluate_windows, dict(_core.WINDOW_DEFAULTS), {}),
    ]


ENTRY_POINTS = _entry_points()


def signature_problems(
    name: str, function: Callable[..., Any], settings: dict[str, Any], by_kind: dict[str, Any]
) -> list[str]:
    """What is wrong with `function`'s signature against the engine's `settings`, one sentence
    each, naming the function and the setting or parameter."""
    params = inspect.signature(function).parameters
    problems = []
    for setting, default in settings.items():
        if setting not in params:
            problems.append(f"{name} has no parameter for the engine's setting {setting!r} (default {default!r})")
            continue
        given = params[setting].default
        if given is inspect.Parameter.empty:
            problems.append(f"{name}({setting}) has no default (the engine's is {default!r})")
        elif setting in by_kind:
            if given is not None:
                problems.append(
                    f"{name}({setting}={given!r}): the engine's default depends on the kind of value "
                    f"or the search ({default!r}, or {by_kind[setting]!r}), so it must be None"
                )
        elif (name, setting) in NONE_BY_DESIGN:
            if given is not None:
                problems.append(f"{name}({setting}={given!r}): expected None ({NONE_BY_DESIGN[name, setting]})")
        elif given != default or type(given) is not type(default):
            problems.append(f"{name}({setting}={given!r}) differs from the engine's default {default!r}")
    for param in params.values():
        if param.kind in (param.VAR_POSITIONAL, param.VAR_KEYWORD):
            problems.append(f"{name} takes {param} (expected every setting by name, checked here)")
        elif param.name not in settings and param.name not in RUN_OPTIONS:
            problems.append(
                f"{name}({param.name}) is neither a setting of the engine's config nor a run option "
                f"listed in tests/test_signatures.py RUN_OPTIONS"
            )
    return problems


@pytest.mark.parametrize(("name", "function", "settings", "by_kind"), ENTRY_POINTS, ids=[e[0] for e in ENTRY_POINTS])
def test_signature_takes_every_core_setting_with_its_default(
    name: str, function: Callable[..., Any], settings: dict[str, Any], by_kind: dict[str, Any]
) -> None:
    problems = signature_problems(name, function, settings, by_kind)
    assert not problems, "\n".join(problems)


def test_the_core_defaults_are_the_configs() -> None:
    # Serialised from each config, so these are the configs' field names (the keywords the bindings take).
    assert {"gamma", "alpha", "seed", "ties"} <= set(_core.Q_DEFAULTS)
    assert (_core.Q_DEFAULTS["gamma"], _core.Q_DEFAULTS["alpha"], _core.Q_DEFAULTS["ties"]) == (0.99, 0.1, "random")
    assert set(_core.WINDOW_DEFAULTS) == {"window", "episodes", "chains", "burn_in", "windows_per_chain"}
    by_kind = {"samples", "rho", "smoothing", "template", "decisions", "memoryless_patience", "memory"}
    assert set(_core.CONTROLLER_DEFAULTS["sampled"]) == by_kind
    for defaults in (_core.CE_DEFAULTS, _core.Q_DEFAULTS, _core.WINDOW_DEFAULTS):
        assert defaults and all(isinstance(k, str) for k in defaults)


def test_a_missing_or_stray_setting_is_named() -> None:
    # The check itself: a function without a core setting, with a wrong default, with a parameter
    # nobody listed, or with **kwargs, is reported with its name and the setting's.
    def fake(world: Any, gamma: float = 0.5, extra: int = 1, **rest: Any) -> None: ...

    problems = signature_problems("fake", fake, {"gamma": 0.99, "alpha": 0.1}, {})
    text = "\n".join(problems)
    assert "fake has no parameter for the engine's setting 'alpha'" in text
    assert "fake(gamma=0.5) differs from the engine's default 0.99" in text
    assert "fake(extra)" in text and "RUN_OPTIONS" in text
    assert "fake takes **rest" in text
    assert len(problems) == 4

    def by_kind(samples: int = 3) -> None: ...

    (problem,) = signature_problems("by_kind", by_kind, {"samples": 2000}, {"samples": 1000})
    assert "by_kind(samples=3)" in problem and "must be None" in problem


def test_a_result_has_the_fields_the_engine_hands_on(monkeypatch: pytest.MonkeyPatch) -> None:
    # A result's fields are named in the engine's summary struct (serialised by name) and in the
    # Python class a user reads: the dict each optimiser's binding returns has exactly the class's
    # fields (a field added on one side only fails here, named), its evaluation Evaluation's.
    raw: dict[str, dict[str, Any]] = {}

    def spy(name: str) -> Callable[..., Any]:
        original = getattr(_core, name)

        def call(*args: Any, **kwargs: Any) -> Any:
            raw[name] = original(*args, **kwargs)
            return raw[name]

        return call

    for name in ("optimize", "optimize_controller", "run"):
        monkeypatch.setattr(_core, name, spy(name))
    tiger = cehmm.PomdpWorld(Path(__file__).parents[1] / "data" / "pomdp" / "tiger.95.POMDP", horizon=20)
    small = {"max_iterations": 1, "seed": 0, "eval_episodes": 10, "progress": False}
    cehmm.optimize(tiger, levels=[2], samples=20, **small)
    cehmm.optimize_controller(tiger, nodes=2, value="sampled", search="ce", samples=20, episodes=5, **small)
    raw["ce"] = raw["optimize_controller"]
    # The model search's result is a ControllerResult too.
    cehmm.optimize_controller(tiger, nodes=4, value="sampled", samples=2, episodes=2, **small)
    cehmm.run("random-search", tiger, samples=5, **small)
    for name, cls in (
        ("optimize", cehmm.OptimizeResult),
        ("ce", cehmm.ControllerResult),
        ("optimize_controller", cehmm.ControllerResult),
        ("run", cehmm.RunResult),
    ):
        declared = {f.name for f in dataclasses.fields(cls)}
        assert set(raw[name]) == declared, f"{name}: {set(raw[name]) ^ declared}"
        assert {"stop_reason", "seconds", "env_steps", "eval_env_steps"} <= declared
        assert set(raw[name]["evaluation"]) == {f.name for f in dataclasses.fields(cehmm.Evaluation)}
