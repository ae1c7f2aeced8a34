"""The docstrings' examples run, and every public name has one (the API reference, mkdocs.yml,
shows them: docs/api/).

* Every ``>>>`` example of every module of the package runs (``doctest``, ``...`` matching any
  text), in its module's namespace with ``cehmm`` and the names of ``cehmm.__all__`` added, in a
  scratch folder that has the repository's ``data/`` (so ``data/pomdp/tiger.95.POMDP`` is found
  and the files an example writes stay out of the repository). An example marked
  ``# doctest: +SKIP`` is shown, not run. The engine's stub ``cehmm/_core.pyi`` (the reference's
  source for the engine's exceptions) has its examples run the same way.
* Every public name (:func:`public_names`) has an ``Example:`` section with at least one example
  that runs; :data:`WITHOUT_EXAMPLE` lists those that have none yet.
"""

from __future__ import annotations

import ast
import doctest
import importlib
import inspect
import pkgutil
import re
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

import cehmm

ROOT = Path(__file__).resolve().parents[1]
STUB = Path(cehmm.__file__).parent / "_core.pyi"

#: The modules a user imports beside ``cehmm`` (the pages of docs/api/), whose public names must
#: have examples too.
USER_MODULES = [
    "cehmm.backend",
    "cehmm.callbacks",
    "cehmm.gym",
    "cehmm.gym_adapt",
    "cehmm.memory_tasks",
    "cehmm.plots",
    "cehmm.pyworlds",
    "cehmm.spaces",
    "cehmm.encoded",
]

#: Public names without a runnable example yet (none since issue 32 gave the last ones theirs).
#: A name leaves this list when its example is written (the test says so).
WITHOUT_EXAMPLE: set[str] = set()

#: Every module of the package whose examples run (a ``__main__`` runs a command when imported;
#: the compiled engine's examples are its stub's).
MODULES = sorted(
    m.name
    for m in pkgutil.walk_packages(cehmm.__path__, "cehmm.")
    if not m.name.endswith(".__main__") and m.name != "cehmm._core"
)

_HEADING = re.compile(r"^\s*Examples?:\s*$", re.M)


def _module(name: str) -> ModuleType:
    """The module ``name``; skipped where it needs an optional dependency that is missing."""
    try:
        return importlib.import_module(name)
    except ImportError as e:  # pragma: no cover - the test extra installs every optional dependency
        pytest.skip(f"{name}: {e}")


def _globals() -> dict[str, Any]:
    """What an example sees beside its module's own names."""
    return {"cehmm": cehmm, **{name: getattr(cehmm, name) for name in cehmm.__all__}}


def _stub_docstrings() -> dict[str, tuple[str, int]]:
    """The stub's docstrings, by qualified name (``"Policy.load"``), with their line."""
    found: dict[str, tuple[str, int]] = {}

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
                doc = ast.get_docstring(child)
                if doc is not None:
                    found[prefix + child.name] = (doc, child.lineno)
                visit(child, f"{prefix}{child.name}.")

    tree = ast.parse(STUB.read_text(encoding="utf-8"))
    if (doc := ast.get_docstring(tree)) is not None:
        found[""] = (doc, 1)
    visit(tree, "")
    return found


def _run(tests: list[doctest.DocTest], where: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Runs ``tests`` in ``where`` (with the repository's ``data/``); fails with their report."""
    (where / "data").symlink_to(ROOT / "data", target_is_directory=True)
    monkeypatch.chdir(where)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    report: list[str] = []
    for test in tests:
        runner.run(test, out=report.append, clear_globs=True)
    failed, attempted = runner.summarize(verbose=False)
    assert failed == 0, f"{failed} of {attempted} examples failed:\n" + "".join(report)


@pytest.mark.parametrize("name", MODULES)
def test_the_examples_of_each_module_run(name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    module = _module(name)
    tests = doctest.DocTestFinder(exclude_empty=True).find(module, name, extraglobs=_globals())
    _run([t for t in tests if t.examples], tmp_path, monkeypatch)


def test_the_examples_of_the_engines_stub_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    parser = doctest.DocTestParser()
    globs = {**_globals(), "_core": cehmm._core}
    tests = [
        parser.get_doctest(doc, dict(globs), f"cehmm._core.{name}".rstrip("."), str(STUB), line)
        for name, (doc, line) in _stub_docstrings().items()
    ]
    _run([t for t in tests if t.examples], tmp_path, monkeypatch)


def public_names() -> dict[str, Any]:
    """The classes, functions and modules of ``cehmm.__all__`` (as ``cehmm.X``) and the public
    classes and functions of :data:`USER_MODULES` (their ``__all__``, else those they define)."""
    names = {f"cehmm.{n}": getattr(cehmm, n) for n in cehmm.__all__}
    for name in USER_MODULES:
        module = _module(name)
        listed = getattr(module, "__all__", None)
        if listed is None:
            listed = [
                n
                for n, obj in vars(module).items()
                if not n.startswith("_")
                and (inspect.isclass(obj) or inspect.isfunction(obj))
                and obj.__module__ == module.__name__
            ]
        names.update({f"{name}.{n}": getattr(module, n) for n in listed})
    return {
        name: obj
        for name, obj in names.items()
        if inspect.isclass(obj) or inspect.isroutine(obj) or inspect.ismodule(obj)
    }


def _docstring(obj: Any) -> str:
    """The docstring the reference shows: the stub's for the engine's own classes."""
    stub = _stub_docstrings()
    name = getattr(obj, "__name__", "")
    if getattr(cehmm._core, name, None) is obj and name in stub:
        return stub[name][0]
    return inspect.getdoc(obj) or ""


def _has_example(doc: str) -> bool:
    """Whether ``doc`` has an ``Example:`` section with an example that is not skipped."""
    heading = _HEADING.search(doc)
    if heading is None:
        return False
    examples = doctest.DocTestParser().get_examples(doc[heading.end() :])
    return any(not example.options.get(doctest.SKIP, False) for example in examples)


def test_every_public_name_has_an_example_that_runs() -> None:
    missing = {name for name, obj in public_names().items() if not _has_example(_docstring(obj))}
    assert missing <= WITHOUT_EXAMPLE, f"no Example: section with an example that runs: {sorted(missing)}"
    written = WITHOUT_EXAMPLE - missing
    assert not written, f"these have an example now: remove them from WITHOUT_EXAMPLE: {sorted(written)}"


def test_an_example_section_counts_only_examples_that_run() -> None:
    assert _has_example("Text.\n\nExample:\n    >>> 1 + 1\n    2\n")
    assert not _has_example("Text.\n\n    >>> 1 + 1\n    2\n")
    assert not _has_example("Example:\n    >>> f()  # doctest: +SKIP\n")
