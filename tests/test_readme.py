"""The README runs: every ``sh`` and ``python`` block of README.md, in a scratch copy of the
repository, each command and statement in turn, so that a README command can no longer fail.

* A comment ``# -> TEXT`` is what that line prints: a Python statement's whole output, a shell
  command's output contains it; ``...`` stands for any text.
* Long runs are cut by the documented options of :data:`SHORTER` (each must still match the
  README, so that an edit cannot silently lengthen the test); a command so cut is run, its
  ``# ->`` not checked (nor those of the Python statements after it in its block).
* :data:`NOT_RUN` lists the commands not run here, each with the reason and where it is run.

``python3 tests/test_readme.py --images DIR`` runs the blocks and copies the figures the README
embeds (``docs/img/readme/``) to DIR.
"""

from __future__ import annotations

import argparse
import ast
import contextlib
import io
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
IMAGES = "docs/img/readme/"

#: Target tracking on a 10 x 10 grid (its Q table is 6.5 MB).
SMALL_GRID = "--param width=10 --param height=10 " + " ".join(
    f"--param {k}={v}"
    for k, v in [("start_b", "[0,9]"), ("start_c", "[9,9]"), ("target_cell", "[5,5]"), ("target_rows", "[0,4]")]
)

#: README text -> what the test runs instead (documented options that cut a long run), and why.
SHORTER: list[tuple[str, str, str]] = [
    (
        "python3 -m pip install . && ",
        "",
        "the package is installed where the tests run (test_wheel.py installs a wheel)",
    ),
    ("--patience 500 --out strong.json", "--patience 500 --max-iterations 20 --out strong.json", "minutes"),
    ("shuttle.95.POMDP --nodes 8 --out", "shuttle.95.POMDP --nodes 8 --max-iterations 5 --out", "30 s"),
    ("--resume --out c2.json", "--resume --max-iterations 3 --out c2.json", "40 s"),
    # The 20 x 20 grid's table is 2.6 GB on disk: a 10 x 10 grid, and the CE policy (of the 20 x 20
    # grid) left out of the comparison.
    ("qlearn --iterations 1e9", f"qlearn --iterations 1e5 {SMALL_GRID}", "2.6 GB, hours"),
    ("qlearn-eval q.bin --ce-policy p16.json", "qlearn-eval q.bin", "the 10 x 10 grid of the table above"),
    ("python3 -m cehmm.reproduce                        #", "python3 -m cehmm.reproduce --quick  #", "hours"),
    (
        "--img-dir docs/img/tuned",
        "--img-dir docs/img/tuned --rows c3-16-weak --seeds 1 --set max_iterations=3",
        "hours",
    ),
    ("--jobs 2 --time-limit 6", "--jobs 2 --time-limit 0.2 --quick", "an hour"),
    ("benchmarks.memory --jobs 2 ", "benchmarks.memory --quick --methods random model-search ", "hours"),
    ("benchmarks.anchors --jobs 2 ", "benchmarks.anchors --files tiger.95 --time-limit 1 ", "hours"),
    ("benches/controller_speed.py ", "benches/controller_speed.py --iterations 1 --repeats 1 ", "a minute"),
]

#: Commands not run here: why, and where they are run instead.
NOT_RUN: dict[str, str] = {
    "python3 -m pip install -e '.[test]' && cargo test && python3 -m pytest": "the test suite itself: .ci/run runs it",
    "python3 -m pip install -e '.[plot]'": "an install (matplotlib: in '.[test]', which .ci/run installs)",
    "python3 -m pip install -e '.[gym]'": "an install (gymnasium: in '.[test]', which .ci/run installs)",
    "python3 -m pip install -e '.[ray]'": "an install (ray: in '.[test]', which .ci/run installs)",
    "python3 -m pip install sb3-contrib": "an install of a heavy rival, kept out of CI (docs/memory-benchmark.md)",
    "cargo install cargo-mutants && cargo mutants": "70 minutes; .ci/run runs cargo mutants on two model files",
    "python3 -m pip install -e '.[docs]' && python3 -m mkdocs serve": "an install, then a server running until stopped",
    "python3 -m mkdocs build --strict": "mkdocs is the docs extra's, not the test extra's: .ci/run builds the site",
}


@dataclass
class Block:
    language: str
    code: str
    line: int  # of the README, where the block's code starts


def blocks(text: str) -> list[Block]:
    """The README's fenced ``sh`` and ``python`` blocks, in order."""
    found = []
    for match in re.finditer(r"^```(sh|python)\n(.*?)^```", text, re.S | re.M):
        found.append(Block(match.group(1), match.group(2), text[: match.start()].count("\n") + 2))
    return found


def expected(line: str) -> str | None:
    """The TEXT of a ``# -> TEXT`` comment at the end of a line."""
    match = re.search(r"#\s*(?:[^#]*?:\s*)?-> (.*)$", line)
    return match.group(1).rstrip() if match else None


def matches(output: str, pattern: str, whole: bool) -> bool:
    """Whether ``output`` is (``whole``) or contains ``pattern``, ``...`` matching any text."""
    regex = ".*".join(re.escape(part) for part in pattern.split("..."))
    return re.fullmatch(regex, output, re.S) is not None if whole else re.search(regex, output, re.S) is not None


def shorten(code: str, used: set[str]) -> tuple[str, set[int]]:
    """``code`` with the cuts of :data:`SHORTER`, and the (1-based) lines they changed."""
    lines = code.split("\n")
    changed = set()
    for old, new, _ in SHORTER:
        for k, line in enumerate(lines):
            if old in line:
                lines[k] = line.replace(old, new)
                changed.add(k + 1)
                used.add(old)
    return "\n".join(lines), changed


def scratch(into: Path) -> Path:
    """A scratch copy of what the README's commands read and write: data (linked), docs,
    benches, examples."""
    work = into / "repo"
    work.mkdir()
    (work / "data").symlink_to(ROOT / "data")
    for folder in ("docs", "benches", "examples"):
        shutil.copytree(ROOT / folder, work / folder)
    return work


#: (seconds, where) of each command and statement run, for the report of the slowest.
TIMES: list[tuple[float, str]] = []


def run_shell(block: Block, work: Path, used: set[str], ran: set[str]) -> None:
    code, changed = shorten(block.code, used)
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}")
    env.pop("CEHMM_THREADS", None)
    for k, (original, line) in enumerate(zip(block.code.split("\n"), code.split("\n")), start=1):
        command, written = _command(line), _command(original)
        if not command:
            continue
        if written in NOT_RUN:
            ran.add(written)
            continue
        where = f"README.md line {block.line + k - 1}: {command}"
        started = time.perf_counter()
        done = subprocess.run(
            [
                "bash",
                "-c",
                command.replace("python3 ", f"{sys.executable} ", 1) if command.startswith("python3 ") else command,
            ],
            cwd=work,
            env=env,
            capture_output=True,
            text=True,
            timeout=600,
        )
        TIMES.append((time.perf_counter() - started, where))
        assert done.returncode == 0, f"{where}\nexit {done.returncode}\n{done.stdout[-2000:]}\n{done.stderr[-3000:]}"
        want = expected(original)
        if want is not None and k not in changed:
            assert matches(done.stdout + done.stderr, want, whole=False), f"{where}\nprints:\n{done.stdout[-2000:]}"


def _command(line: str) -> str:
    """A shell line without its trailing comment."""
    return re.sub(r"\s+#.*$", "", line).strip()


def run_python(block: Block, namespace: dict, used: set[str]) -> None:
    code, changed = shorten(block.code, used)
    lines = code.split("\n")
    cut = False  # a statement cut short: what follows in the block depends on it
    for statement in ast.parse(code).body:
        first, last = statement.lineno, statement.end_lineno or statement.lineno
        cut = cut or bool(changed & set(range(first, last + 1)))
        where = f"README.md line {block.line + first - 1}: {lines[first - 1].strip()}"
        out = io.StringIO()
        started = time.perf_counter()
        with contextlib.redirect_stdout(out):
            try:
                exec(compile(ast.Module([statement], type_ignores=[]), "README.md", "exec"), namespace)
            except Exception as e:
                raise AssertionError(f"{where}\nraised {type(e).__name__}: {e}") from e
        TIMES.append((time.perf_counter() - started, where))
        want = expected(block.code.split("\n")[last - 1])
        if want is not None and not cut:
            printed = out.getvalue().rstrip("\n")
            assert matches(printed, want, whole=True), f"{where}\nprints:\n{printed}\nREADME says:\n{want}"


def run_readme(work: Path) -> tuple[set[str], set[str]]:
    """Runs every block in ``work``; returns the cuts used and the commands not run."""
    used: set[str] = set()
    skipped: set[str] = set()
    namespace: dict = {"__name__": "__readme__"}
    cwd = Path.cwd()
    os.chdir(work)
    try:
        for block in blocks(README.read_text()):
            if block.language == "sh":
                run_shell(block, work, used, skipped)
            else:
                run_python(block, namespace, used)
    finally:
        os.chdir(cwd)
        for seconds, where in sorted(TIMES, reverse=True)[:8]:
            print(f"{seconds:6.1f} s  {where[:110]}")
    return used, skipped


def test_every_block_of_the_readme_runs_and_prints_what_its_comments_say(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    pytest.importorskip("gymnasium")
    pytest.importorskip("popgym")
    work = scratch(tmp_path)
    used, skipped = run_readme(work)
    # Every cut and every exception still matches the README: none is stale.
    assert {old for old, _, _ in SHORTER} == used
    assert set(NOT_RUN) == skipped
    # The figures the README embeds are what its blocks draw.
    for name in re.findall(re.escape(IMAGES) + r"([\w.-]+)", README.read_text()):
        assert (work / name).stat().st_size > 1000, name
        assert (ROOT / IMAGES / name).exists(), f"{IMAGES}{name}: run python3 tests/test_readme.py --images {IMAGES}"


def test_the_readme_installs_only_extras_the_package_has() -> None:
    import tomllib

    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    named = re.findall(r"'\.\[(\w+)\]'", README.read_text())
    assert named and set(named) <= set(extras), set(named) - set(extras)


def test_the_readme_installs_extras_as_test_it_installs_the_package() -> None:
    # `pip install '.[plot]'` after "Test it" (`pip install -e '.[test]'`) silently replaced the
    # editable install with a copy: edits no longer ran.
    installs = re.findall(r"pip install (?:(-e) )?'\.\[(\w+)\]'", README.read_text())
    assert installs and all(editable for editable, _ in installs), installs


def test_the_readmes_command_list_is_every_command() -> None:
    # It left out `run`.
    helped = subprocess.run([sys.executable, "-m", "cehmm.cli", "--help"], capture_output=True, text=True)
    listed = helped.stdout.split("Commands:\n")[1].split("\n\n")[0].splitlines()
    commands = {line.split()[0] for line in listed} - {"help"}
    text = " ".join(README.read_text().split())
    named = text.split("The `cehmm` command is the whole command line (")[1].split("`cehmm --help`")[0]
    assert set(re.findall(r"`([a-z-]+)`", named)) == commands


def test_the_readme_says_which_horizon_an_environment_without_one_gets() -> None:
    from cehmm.gym_adapt import DEFAULT_HORIZON

    text = " ".join(README.read_text().split())
    assert f"cut at {DEFAULT_HORIZON} steps" in text and "`cehmm.gym_adapt.HorizonWarning`" in text


def test_the_readmes_test_command_is_what_ci_runs() -> None:
    command = next(c for c in NOT_RUN if "pytest" in c)
    assert command in README.read_text().split("**Test it**")[1].split("```")[1]
    assert command in (ROOT / ".ci" / "run").read_text()


def test_a_comment_says_what_a_line_prints() -> None:
    assert expected("print(x)  # -> 86") == "86"
    assert expected("cehmm c --out s.json  # model §8: -> ...value 32.88...") == "...value 32.88..."
    assert expected("print(x)  # the mean") is None
    assert matches("Evaluation(mean=1.0, episodes=3)", "Evaluation(mean=1.0, ...)", whole=True)
    assert not matches("Evaluation(mean=1.5, episodes=3)", "Evaluation(mean=1.0, ...)", whole=True)
    assert matches("line\nsaved p.json\n", "...saved p.json", whole=False)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description="Run the README's blocks; keep the figures it embeds.")
    parser.add_argument("--images", type=Path, required=True, help=f"where to copy the figures ({IMAGES})")
    options = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = scratch(Path(tmp))
        run_readme(work)
        options.images.mkdir(parents=True, exist_ok=True)
        for name in sorted(set(re.findall(re.escape(IMAGES) + r"([\w.-]+)", README.read_text()))):
            shutil.copyfile(work / name, options.images / name)
            print(f"{options.images / name}: {(options.images / name).stat().st_size} bytes")
