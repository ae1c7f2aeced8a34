"""A griffe extension for the API reference (mkdocs.yml): the package's docstrings are Google
style with two habits of Sphinx, read here as mkdocstrings reads Markdown.

* ``Example:`` (the heading every public docstring has, which tests/test_docstrings.py checks)
  is read as Google's ``Examples:`` section, so that its ``>>>`` lines show as code.
* A Sphinx role (``:class:`World```, ``:func:`~cehmm.plots.rollout```, ``:meth:`names```)
  becomes a cross-reference to the object it names, resolved in the docstring's scope: a link
  where the object has a page, else the name as code (an *optional* autoref: never a warning).
* Parameters documented together (``seed, episode: the episode``, numpy's way) become one entry
  each, the later ones pointing to the first, as Google's ``Args:`` lists them.
* A default read from the engine (``samples: int = CE_DEFAULTS["samples"]``, the defaults'
  one home) is shown as its value (``1000``): the expression is evaluated in its module, as
  imported (the installed package, engine included).
"""

from __future__ import annotations

import ast
import importlib
import re
from typing import Any

import griffe

_ROLE = re.compile(r":(?:py:)?(?:class|func|meth|attr|mod|data|exc|obj|const):`(~?)([\w.]+)(?:\(\))?`")
_EXAMPLE = re.compile(r"^(\s*)Example:[ \t]*$", re.M)
_ARGS = re.compile(r"^(\s*)(?:Args|Arguments|Parameters|Other parameters):[ \t]*$")
_TOGETHER = re.compile(r"^(\s+)(\w+(?:, \w+)+): (.*)$")


def _identifier(obj: griffe.Object, target: str) -> str:
    """The full path of ``target`` as named in ``obj``'s docstring (as given where unknown)."""
    head, _, rest = target.partition(".")
    if head == "cehmm":
        return target
    scope: Any = obj
    while scope is not None:
        try:
            found = scope.resolve(head)
        except (griffe.NameResolutionError, griffe.AliasResolutionError, griffe.CyclicAliasError):
            scope = scope.parent
            continue
        return f"{found}.{rest}" if rest else found
    return target


def _rewrite(obj: griffe.Object, text: str) -> str:
    def role(match: re.Match[str]) -> str:
        short, target = match.group(1), match.group(2)
        shown = target.rsplit(".", 1)[-1] if short else target
        return f'<autoref identifier="{_identifier(obj, target)}" optional>`{shown}`</autoref>'

    return _EXAMPLE.sub(r"\1Examples:", _ROLE.sub(role, _one_per_entry(text)))


def _one_per_entry(text: str) -> str:
    """``text`` with each ``a, b: what`` entry of an ``Args:`` section as ``a: what`` and
    ``b: see a``."""
    lines: list[str] = []
    section: str | None = None  # the indentation of the current Args section's heading
    entry: str | None = None  # the indentation of its entries
    for line in text.split("\n"):
        indent = line[: len(line) - len(line.lstrip())]
        if (heading := _ARGS.match(line)) is not None:
            section, entry = heading.group(1), None
        elif section is not None and line.strip():
            if len(indent) <= len(section):
                section = None
            elif entry is None:
                entry = indent
        together = _TOGETHER.match(line) if section is not None and indent == entry else None
        if together is None:
            lines.append(line)
            continue
        names, what = together.group(2), together.group(3)
        first, *others = names.split(", ")
        lines.append(f"{indent}{first}: {what}")
        lines.extend(f"{indent}{name}: see ``{first}``." for name in others)
    return "\n".join(lines)


class CehmmDocstrings(griffe.Extension):
    """Rewrites every docstring of the package once it is loaded (see the module's docstring)."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        seen: set[int] = set()
        stack: list[griffe.Object] = [pkg]
        while stack:
            obj = stack.pop()
            if id(obj) in seen:
                continue
            seen.add(id(obj))
            if obj.docstring is not None:
                obj.docstring.value = _rewrite(obj, obj.docstring.value)
            if obj.is_function:
                _show_values(obj)
            stack.extend(member for member in obj.members.values() if not member.is_alias)


def _show_values(function: griffe.Function) -> None:
    """Each default of ``function`` that names something (``CE_DEFAULTS["samples"]``,
    ``_core.GRAPH_PRUNE``) replaced by the value it has, where that is a plain literal."""
    module: Any = None
    for parameter in function.parameters:
        if parameter.default is None or not isinstance(parameter.default, griffe.Expr):
            continue
        expression = str(parameter.default)
        try:
            ast.literal_eval(expression)
            continue  # a literal already (-1.0, (1, 2)): shown as written
        except (ValueError, SyntaxError):
            pass
        if module is None:
            try:
                module = importlib.import_module(function.module.path)
            except ImportError as e:
                raise ImportError(
                    f"the API reference shows the engine's defaults ({function.path}: {parameter.name}={expression}), "
                    f"read from the installed package: pip install -e . ({e})"
                ) from e
        try:
            value = eval(expression, vars(module))  # noqa: S307 - the package's own source, as Python runs it
        except (NameError, AttributeError):
            continue  # a name of a scope other than the module's: shown as written
        if value is None or isinstance(value, (bool, int, float, str)):
            parameter.default = repr(value)
