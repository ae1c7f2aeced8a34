"""The module layering of the Rust core: a module uses only modules of its own layer or of a
lower one, and no two files use each other, directly or through others (no import circle). The
bindings (``crates/cehmm-py``) and the Python package (``python/cehmm``) have no circle either,
and the compiled module imports nothing of the Python package (it only translates).

Layers, lowest first (a module is placed by the longest prefix of its path listed here):

0. the base: ``error``, ``rng``, ``files``, ``memory``, ``control``, ``settings``
1. the policy and the file readers: ``policy`` (but ``policy::file``), ``world::cassandra``,
   ``world::pomdpx``
2. the worlds: ``world``
3. where episodes come from and the policy files that record a world: ``episodes``,
   ``policy::file``
4. evaluation: ``evaluate``, ``exact``
5. the optimisers: ``ce``, ``qlearn``
6. what shows and runs them: ``progress``, ``run``, the crate root
7. the command line: ``cli``

The uses are read from the code (comments, doc links and ``#[cfg(test)]`` modules left out):
``crate::a::b`` paths, names re-exported at the crate root resolved to their module.

Run ``python3 tests/test_layering.py`` to print every file's layer and uses.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "crates" / "ceworld" / "src"
BINDINGS = ROOT / "crates" / "cehmm-py" / "src"
PACKAGE = ROOT / "python" / "cehmm"

LAYERS: dict[str, int] = {
    "error": 0,
    "rng": 0,
    "files": 0,
    "memory": 0,
    "control": 0,
    "settings": 0,
    "policy": 1,
    "world::cassandra": 1,
    "world::pomdpx": 1,
    "world": 2,
    "episodes": 3,
    "policy::file": 3,
    "evaluate": 4,
    "exact": 4,
    "pointbased": 4,
    "ce": 5,
    "qlearn": 5,
    "progress": 6,
    "run": 6,
    "": 6,
    "cli": 7,
    # The constants the crate root defines itself (its version): a fact below everything.
    "(root constant)": 0,
}

_PATH = re.compile(r"\bcrate::((?:[A-Za-z_][A-Za-z0-9_]*::)*[A-Za-z_][A-Za-z0-9_]*)")
_GROUP = re.compile(r"\buse\s+crate::((?:[a-z_][a-z0-9_]*::)*)\{([^;]*)\};", re.S)


def module_of(file: Path, src: Path = SRC) -> str:
    """``ce/controller/mod.rs`` -> ``ce::controller``; ``lib.rs`` -> ``""``."""
    parts = list(file.relative_to(src).with_suffix("").parts)
    if parts[-1] in ("mod", "lib"):
        parts.pop()
    return "::".join(parts)


def files(src: Path = SRC) -> dict[str, Path]:
    """Every module of the library (the CLI binary is above it all and is left out)."""
    return {module_of(f, src): f for f in sorted(src.rglob("*.rs")) if "bin" not in f.relative_to(src).parts}


def code(text: str) -> str:
    """The text without comments and without the ``#[cfg(test)]`` module at its end."""
    cut = re.search(r"^#\[cfg\(test\)\]\s*\n\s*mod tests", text, re.M)
    if cut:
        text = text[: cut.start()]
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return "\n".join(line.split("//", 1)[0] for line in text.splitlines())


def root_names(src: Path = SRC) -> dict[str, str]:
    """Names re-exported at the crate root (``pub use a::b::{X, Y};``) -> the module they come from,
    and the macros the crate exports -> the module that defines them."""
    names: dict[str, str] = {}
    text = code((src / "lib.rs").read_text())
    for path, group in re.findall(r"pub use ((?:[a-z_][a-z0-9_]*::)+)\{?([^;}]*)\}?;", text):
        for name in re.split(r"\s*,\s*", group.strip()):
            if name:
                names[name] = path.rstrip(":")
    for module, file in files(src).items():
        for macro in re.findall(r"macro_rules!\s+([a-z_]+)", file.read_text()):
            names[macro] = module
    for constant in re.findall(r"^pub const ([A-Z_]+)", text, re.M):
        names[constant] = "(root constant)"
    return names


def resolve(path: str, modules: set[str], names: dict[str, str]) -> str:
    """The longest module that ``path`` (after ``crate::``) starts with."""
    parts = path.split("::")
    for n in range(len(parts), 0, -1):
        candidate = "::".join(parts[:n])
        if candidate in modules:
            return candidate
    return names.get(parts[0], "")


def uses(src: Path = SRC) -> dict[str, set[str]]:
    """Each module of the crate at ``src`` -> the modules its code uses (itself left out)."""
    modules = set(files(src))
    names = root_names(src)
    graph: dict[str, set[str]] = {}
    for module, file in files(src).items():
        text = code(file.read_text())
        paths = set(_PATH.findall(text))
        for prefix, group in _GROUP.findall(text):
            paths |= {prefix + item.strip().split("::")[0] for item in group.split(",") if item.strip()}
        graph[module] = {resolve(p, modules, names) for p in paths} - {module}
    return graph


def layer(module: str) -> int:
    parts = module.split("::") if module else []
    for n in range(len(parts), -1, -1):
        prefix = "::".join(parts[:n])
        if prefix in LAYERS:
            return LAYERS[prefix]
    raise AssertionError(f"{module} has no layer")


def test_no_module_uses_a_higher_layer() -> None:
    bad = [
        f"{m} (layer {layer(m)}) uses {u or 'the crate root'} (layer {layer(u)})"
        for m, us in uses().items()
        for u in sorted(us)
        if layer(u) > layer(m)
    ]
    assert not bad, "\n".join(bad)


def circles(graph: dict[str, set[str]]) -> list[str]:
    """The circles of ``graph`` (module -> modules it uses), each as ``a -> b -> a``."""
    state: dict[str, int] = {}
    found: list[str] = []

    def visit(m: str, path: list[str]) -> None:
        state[m] = 1
        for u in sorted(graph.get(m, ())):
            if state.get(u) == 1:
                found.append(" -> ".join(path[path.index(u) :] + [u]))
            elif u not in state:
                visit(u, path + [u])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
    return found


def python_uses() -> dict[str, set[str]]:
    """Each module of the Python package -> the package's modules it imports (``cehmm.plots`` for
    ``from .plots.curves import x`` inside ``cehmm`` counts its subpackage), wherever the import
    stands (a deferred import inside a function is a use all the same)."""
    modules = {
        ".".join(f.relative_to(PACKAGE.parent).with_suffix("").parts).removesuffix(".__init__"): f
        for f in sorted([*PACKAGE.rglob("*.py"), PACKAGE / "_core.pyi"])
    }
    graph: dict[str, set[str]] = {}
    for module, file in modules.items():
        package = module if file.name == "__init__.py" else module.rsplit(".", 1)[0]
        used: set[str] = set()
        for node in _run_time_nodes(ast.parse(file.read_text())):
            if isinstance(node, ast.ImportFrom):
                base = package.split(".")
                if node.level:
                    base = base[: len(base) - node.level + 1]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                names = [f"{target}.{a.name}" for a in node.names] + [target]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            for name in names:
                while name and name not in modules:
                    name = name.rpartition(".")[0]
                # A module may name its own package (``from . import x``): the package's
                # ``__init__`` importing its children is not a circle through them.
                if name and name != module and not module.startswith(name + "."):
                    used.add(name)
        graph[module] = used
    return graph


def _run_time_nodes(tree: ast.AST) -> list[ast.AST]:
    """The nodes of ``tree`` but those under ``if TYPE_CHECKING:`` (imported for annotations only)."""
    found: list[ast.AST] = []
    todo = [tree]
    while todo:
        node = todo.pop()
        found.append(node)
        if isinstance(node, ast.If) and ast.unparse(node.test) in ("TYPE_CHECKING", "typing.TYPE_CHECKING"):
            todo.extend(node.orelse)
            continue
        todo.extend(ast.iter_child_nodes(node))
    return found


def test_no_import_circle() -> None:
    # A parent module may name its children (`pub mod x;` is not a use); a child may use its
    # parent. Any other circle between files is a circle.
    found = circles(uses())
    assert not found, "\n".join(found)


def test_no_import_circle_in_the_bindings() -> None:
    found = circles(uses(BINDINGS))
    assert not found, "\n".join(found)


def test_no_import_circle_in_the_python_package() -> None:
    found = circles(python_uses())
    assert not found, "\n".join(found)


def test_the_compiled_module_imports_nothing_of_the_package() -> None:
    # The bindings translate: they never call up into the Python layer (`py.import("cehmm...")`).
    bad = [
        f"{f.name}: {m}"
        for f in sorted(BINDINGS.rglob("*.rs"))
        for m in re.findall(r'import\(\s*"(cehmm[^"]*)"', code(f.read_text()))
    ]
    assert not bad, "\n".join(bad)


def test_the_check_sees_uses() -> None:
    # The checker reads real uses: a sample of known edges.
    graph = uses()
    assert "episodes" in graph["evaluate"]
    assert "ce::record" in graph["ce::checkpoint"]
    assert "policy::controller" in graph["episodes"]
    assert "world::registry" in graph["policy::file"]
    bindings = uses(BINDINGS)
    assert "errors" in bindings["remote"]
    package = python_uses()
    assert "cehmm._core" in package["cehmm.policy"]
    assert "cehmm.plots" in package["cehmm.results"]  # a deferred import
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a -> b -> c -> a"]


if __name__ == "__main__":
    for m, us in sorted(uses().items()):
        print(f"{layer(m)} {m or '(root)'}: {', '.join(sorted(u or '(root)' for u in us))}")
