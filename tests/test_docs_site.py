"""The API reference as mkdocstrings reads the package (mkdocs.yml, docs/griffe_cehmm.py): every
default shown as its value, not as the expression that reads it from the engine.

Runs where the docs extra is installed (``pip install -e '.[docs]'``: griffe comes with
mkdocstrings); .ci/run builds the whole site with ``--strict``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import cehmm

griffe = pytest.importorskip("griffe")

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def package() -> Any:
    """The package as the site reads it: statically, through the site's griffe extension."""
    extensions = griffe.load_extensions(f"{ROOT / 'docs' / 'griffe_cehmm.py'}:CehmmDocstrings")
    return griffe.load("cehmm", search_paths=[str(ROOT / "python")], extensions=extensions, resolve_aliases=False)


def _functions(obj: Any) -> list[Any]:
    """Every function and method below ``obj`` (aliases left out: they are shown where defined)."""
    found, stack, seen = [], [obj], set()
    while stack:
        here = stack.pop()
        if id(here) in seen:
            continue
        seen.add(id(here))
        if here.is_function:
            found.append(here)
        stack.extend(member for member in here.members.values() if not member.is_alias)
    return found


def test_the_api_reference_shows_the_engines_defaults_as_their_values(package: Any) -> None:
    # It showed `samples: int = CE_DEFAULTS["samples"]`: what the engine's default is, a reader
    # could not tell.
    defaults = {p.name: p.default for p in package["optimizer.optimize"].parameters}
    assert defaults["samples"] == repr(cehmm._core.CE_DEFAULTS["samples"])
    assert defaults["rho"] == repr(cehmm._core.CE_DEFAULTS["rho"])
    assert defaults["memory_update"] == repr(cehmm._core.CE_DEFAULTS["memory_update"])
    controller = {p.name: p.default for p in package["controller.optimize_controller"].parameters}
    assert controller["eval_episodes"] == repr(cehmm._core.CONTROLLER_DEFAULTS["eval_episodes"])
    prune = {p.name: p.default for p in package["policy.Policy.graph"].parameters}["prune"]
    assert prune == repr(cehmm._core.GRAPH_PRUNE)
    shown = [
        f"{function.path}({parameter.name}={parameter.default})"
        for function in _functions(package)
        for parameter in function.parameters
        if "DEFAULTS" in str(parameter.default) or "_core." in str(parameter.default)
    ]
    assert not shown, shown
