"""The module layering of the Rust core: a module uses only modules of its own layer or of a
lower one, and no two files use each other, directly or through others (no import circle).

Layers, lowest first (a module is placed by the longest prefix of its path listed here):

0. the base: ``error``, ``rng``, ``files``, ``memory``, ``control``, ``settings``
1. the policy and the file reader: ``policy`` (but ``policy::file``), ``world::cassandra``
2. the worlds: ``world``
3. where episodes come from and the policy files that record a world: ``episodes``,
   ``policy::file``
4. evaluation: ``evaluate``, ``exact``
5. the optimisers: ``ce``, ``qlearn``
6. what shows them: ``progress``, the crate root
7. the command line: ``cli``

The uses are read from the code (comments, doc links and ``#[cfg(test)]`` modules left out):
``crate::a::b`` paths, names re-exported at the crate root resolved to their module.

Run ``python3 tests/test_layering.py`` to print every file's layer and uses.
"""

from __future__ import annotations

import re
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "crates" / "ceworld" / "src"

LAYERS: dict[str, int] = {
    "error": 0,
    "rng": 0,
    "files": 0,
    "memory": 0,
    "control": 0,
    "settings": 0,
    "policy": 1,
    "world::cassandra": 1,
    "world": 2,
    "episodes": 3,
    "policy::file": 3,
    "evaluate": 4,
    "exact": 4,
    "ce": 5,
    "qlearn": 5,
    "progress": 6,
    "": 6,
    "cli": 7,
    # The constants the crate root defines itself (its version): a fact below everything.
    "(root constant)": 0,
}

_PATH = re.compile(r"\bcrate::((?:[A-Za-z_][A-Za-z0-9_]*::)*[A-Za-z_][A-Za-z0-9_]*)")
_GROUP = re.compile(r"\buse\s+crate::((?:[a-z_][a-z0-9_]*::)*)\{([^;]*)\};", re.S)


def module_of(file: Path) -> str:
    """``ce/controller/mod.rs`` -> ``ce::controller``; ``lib.rs`` -> ``""``."""
    parts = list(file.relative_to(SRC).with_suffix("").parts)
    if parts[-1] in ("mod", "lib"):
        parts.pop()
    return "::".join(parts)


def files() -> dict[str, Path]:
    """Every module of the library (the CLI binary is above it all and is left out)."""
    return {module_of(f): f for f in sorted(SRC.rglob("*.rs")) if "bin" not in f.relative_to(SRC).parts}


def code(text: str) -> str:
    """The text without comments and without the ``#[cfg(test)]`` module at its end."""
    cut = re.search(r"^#\[cfg\(test\)\]\s*\n\s*mod tests", text, re.M)
    if cut:
        text = text[: cut.start()]
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return "\n".join(line.split("//", 1)[0] for line in text.splitlines())


def root_names(modules: set[str]) -> dict[str, str]:
    """Names re-exported at the crate root (``pub use a::b::{X, Y};``) -> the module they come from,
    and the macros the crate exports -> the module that defines them."""
    names: dict[str, str] = {}
    text = code((SRC / "lib.rs").read_text())
    for path, group in re.findall(r"pub use ((?:[a-z_][a-z0-9_]*::)+)\{?([^;}]*)\}?;", text):
        for name in re.split(r"\s*,\s*", group.strip()):
            if name:
                names[name] = path.rstrip(":")
    for module, file in files().items():
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


def uses() -> dict[str, set[str]]:
    """Each module -> the modules its code uses (itself left out)."""
    modules = set(files())
    names = root_names(modules)
    graph: dict[str, set[str]] = {}
    for module, file in files().items():
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


def test_no_import_circle() -> None:
    graph = uses()
    # A parent module may name its children (`pub mod x;` is not a use); a child may use its
    # parent. Any other circle between files is a circle.
    state: dict[str, int] = {}
    circles: list[list[str]] = []

    def visit(m: str, path: list[str]) -> None:
        state[m] = 1
        for u in sorted(graph.get(m, ())):
            if state.get(u) == 1:
                circles.append(path[path.index(u) :] + [u])
            elif u not in state:
                visit(u, path + [u])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
    assert not circles, "\n".join(" -> ".join(c) for c in circles)


def test_the_check_sees_uses() -> None:
    # The checker reads real uses: a sample of known edges.
    graph = uses()
    assert "episodes" in graph["evaluate"]
    assert "ce::record" in graph["ce::checkpoint"]
    assert "policy::controller" in graph["episodes"]
    assert "world::registry" in graph["policy::file"]


if __name__ == "__main__":
    for m, us in sorted(uses().items()):
        print(f"{layer(m)} {m or '(root)'}: {', '.join(sorted(u or '(root)' for u in us))}")
