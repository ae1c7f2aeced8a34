"""Worlds: the base class :class:`World`, which reaches every world registered in the engine by
its name (model §1), and the lookup of a policy file's ``"world"`` object."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import PurePath
from typing import Any, ClassVar

from . import _core
from .outside import PythonWorld


class World:
    """A world registered in the engine, with its parameters (model §1).

    ``World(name, **params)`` makes any registered world (:meth:`names` lists them); worlds with
    a class of their own (:class:`~cehmm.TargetTracking`) are made by it and come back as it
    from :meth:`from_dict`. Worlds are immutable, compare by name and parameters, and pickle.

    Raises:
        InvalidArgumentError: an unknown name or parameter (the message lists the valid ones),
            or a value out of its range.
        TypeError: a parameter of the wrong type (a string for a number, ...).

    Example:
        >>> world = World("target-tracking", case=1, horizon=50)
        >>> world
        World('target-tracking', case=1, horizon=50)
        >>> world.n_observations, world.n_decisions, world.horizon
        (16, 16, 50)
        >>> World.from_dict(world.to_dict())  # a class of its own comes back as it
        TargetTracking(case=1, horizon=50)
    """

    __slots__ = ("_core",)

    #: The registered name of the worlds of this class ("" for the generic class).
    registered_name: ClassVar[str] = ""
    _classes: ClassVar[dict[str, type[World]]] = {}

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if cls.registered_name:
            World._classes[cls.registered_name] = cls

    def __init__(self, name: str, **params: Any) -> None:
        self._core = _core.World(name, **params)

    @staticmethod
    def names() -> list[str]:
        """The names of the registered worlds.

        Example:
            >>> World.names()
            ['target-tracking', 'pomdp']
        """
        return _core.World.names()

    @classmethod
    def from_dict(cls, world: Mapping[str, Any]) -> World:
        """The world described by a policy file's ``"world"`` object (``{"name": ..., **params}``;
        a class with a name of its own fills it in when it is missing)."""
        if not isinstance(world, Mapping):
            raise TypeError(f"invalid world: {world!r} (expected a dict of world parameters)")
        described = dict(world)
        if cls.registered_name:
            name = described.setdefault("name", cls.registered_name)
            if name != cls.registered_name:
                raise _core.InvalidArgumentError(
                    f"invalid world.name: {name!r} (expected {cls.registered_name!r}, or use cehmm.World.from_dict)"
                )
        return _wrap(_core.World.from_dict(described))

    @property
    def name(self) -> str:
        """The registered name, as written in policy files and on the command line."""
        return self._core.name

    @property
    def n_observations(self) -> int:
        """Number of observations ``Y``."""
        return self._core.n_observations

    @property
    def n_decisions(self) -> int:
        """Number of decisions ``D``."""
        return self._core.n_decisions

    @property
    def horizon(self) -> int:
        """Steps per episode ``T``."""
        return self._core.horizon

    @property
    def params(self) -> dict[str, Any]:
        """Every parameter (a fresh dict, without the name)."""
        return self._core.params

    @property
    def state_labels(self) -> list[str]:
        """Names of the columns of a rollout's ``x``."""
        return self._core.state_labels()

    def to_dict(self) -> dict[str, Any]:
        """The world as stored in policy files: ``{"name": ..., **params}``."""
        return self._core.to_dict()

    def optimum(self) -> float:
        """The best mean reward any policy can reach, where the world knows it exactly.

        Raises:
            InvalidArgumentError: the world knows no exact optimum.

        Example:
            >>> World("target-tracking", case=1).optimum()
            86.0
        """
        return self._core.exact_optimum()

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, World):
            return NotImplemented
        return self._core == other._core

    def __hash__(self) -> int:
        return hash((self.name, _frozen(self.params)))

    def __reduce__(self) -> tuple[Any, ...]:
        return (_rebuild, (self.to_dict(),))

    def __repr__(self) -> str:
        defaults = _core.World.defaults(self.name)
        changed = [f"{k}={v!r}" for k, v in self.params.items() if v != defaults.get(k)]
        return f"World({', '.join([repr(self.name), *changed])})"


def _frozen(value: Any) -> Any:
    if isinstance(value, dict):
        return tuple(sorted((k, _frozen(v)) for k, v in value.items()))
    if isinstance(value, list):
        return tuple(_frozen(v) for v in value)
    return value


def _wrap(core: _core.World) -> World:
    """The world object of the class registered for ``core``'s name (else :class:`World`)."""
    world = object.__new__(World._classes.get(core.name, World))
    world._core = core
    return world


def _rebuild(world: dict[str, Any]) -> World:
    return World.from_dict(world)


def core_world(world: Any, **options: Any) -> Any:
    """The engine's world behind ``world`` (a ``_core.World``, or a ``_core.OutsideWorld`` for a
    world written in Python: ``options`` are :class:`~cehmm.PythonWorld`'s), or a ``TypeError``."""
    if isinstance(world, (_core.World, _core.OutsideWorld)) and not options:
        return world
    if isinstance(world, World):
        if options:
            raise TypeError(
                f"invalid world options {sorted(options)}: they apply to worlds written in Python; "
                f"{world!r} has its own reward"
            )
        return world._core
    if isinstance(world, PythonWorld) and not options:
        return world._core
    return PythonWorld(world.world if isinstance(world, PythonWorld) else world, **options)._core


def world_title(world: Any) -> str:
    """A world as a figure's title names it: a ``.pomdp`` file by its file's name, target
    tracking with its case, a Python world by its class, any other by its registered name;
    ``world``: a world object or a policy file's ``"world"`` dict ("" for ``None``); a
    Gymnasium environment by its id."""
    if world is None:
        return ""
    if isinstance(world, Mapping):
        described = dict(world)
    elif hasattr(world, "to_dict"):
        described = world.to_dict()
    else:  # a Python world: its class (a wrapped one's, the object it wraps)
        return type(getattr(world, "world", world) if type(world).__name__ == "PythonWorld" else world).__name__
    name = str(described.get("name", "?"))
    if name == "pomdp" and described.get("file"):
        return PurePath(str(described["file"])).name
    if name == "target-tracking":
        return "target tracking" + (f", case {described['case']}" if "case" in described else "")
    if name == "outside" and described.get("id"):
        return str(described["id"])
    if name == "outside" and described.get("class"):
        return str(described["class"]).rsplit(".", 1)[-1]
    return name
