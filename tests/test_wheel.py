"""The user's path, as issue 20's "done when" states it: a wheel built from this tree, installed in
a fresh virtual environment with no cargo on the PATH, gives the whole command line as ``cehmm``:
an optimisation with its history, its evaluation, a controller search and a learning curve.
(The venv sees the site-packages of the Python running the tests for numpy and matplotlib, so
that no download is needed, whether that Python is itself a venv or not; the ``cehmm`` it
imports is the wheel's, which the test checks.) Without numpy, ``import cehmm`` says what is
missing and how to install it."""

from __future__ import annotations

import os
import shutil
import site
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TIGER = ROOT / "data" / "pomdp" / "tiger.95.POMDP"


def _site_packages() -> list[str]:
    """Where this Python finds its installed packages (a venv's own, or the interpreter's and the
    user's): what ``--system-site-packages`` gives only where this Python is no venv."""
    places = [sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"], *site.getsitepackages()]
    if site.ENABLE_USER_SITE:
        places.append(site.getusersitepackages())
    return list(dict.fromkeys(p for p in places if os.path.isdir(p)))


# Building the wheel compiles the engine (minutes on a fresh clone of two cores).
@pytest.mark.timeout(1800)
@pytest.mark.skipif(sys.platform == "win32", reason="POSIX paths of a venv")
def test_a_built_wheel_gives_the_whole_command_line_without_cargo(tmp_path: Path) -> None:
    wheels = tmp_path / "wheels"
    built = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps", "-q", "-w", str(wheels)],
        capture_output=True,
        text=True,
        timeout=1200,
    )
    assert built.returncode == 0, built.stderr
    (wheel,) = wheels.glob("cehmm-*.whl")
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=300)
    # This Python's packages, after the venv's own (a .pth file's lines go to the end of sys.path).
    (venv_site,) = venv.glob("lib/python*/site-packages")
    (venv_site / "tests-site-packages.pth").write_text("".join(f"{p}\n" for p in _site_packages()))
    pip = subprocess.run(
        [str(venv / "bin" / "python"), "-m", "pip", "install", "--no-deps", "--no-index", "-q", str(wheel)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert pip.returncode == 0, pip.stderr
    # Only the venv and the system's own tools: no cargo, no rustc.
    env = {**os.environ, "PATH": f"{venv / 'bin'}{os.pathsep}/usr/bin{os.pathsep}/bin"}
    assert shutil.which("cargo", path=env["PATH"]) is None
    work = tmp_path / "work"
    work.mkdir()

    def cehmm(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(["cehmm", *args], capture_output=True, text=True, cwd=work, env=env, timeout=600)

    where = subprocess.run(
        ["python", "-c", "import cehmm, numpy; print(cehmm.__file__)"],
        capture_output=True,
        text=True,
        env=env,
        cwd=work,
        timeout=120,
    )
    assert str(venv) in where.stdout, (where.stdout, where.stderr)
    steps = [
        (
            "optimize",
            "--case",
            "3",
            "--levels",
            "16",
            "--max-iterations",
            "5",
            "--out",
            "p.json",
            "--history",
            "h.jsonl",
        ),
        ("evaluate", "p.json", "--episodes", "1000"),
        ("controller", "--pomdp", str(TIGER), "--nodes", "4", "--out", "t.json", "--quiet"),
        ("plot", "h.jsonl", "--out", "lc.png"),
    ]
    for step in steps:
        done = cehmm(*step)
        assert done.returncode == 0, (step, done.stdout, done.stderr)
    assert (work / "lc.png").stat().st_size > 1000
    assert len((work / "h.jsonl").read_text().splitlines()) == 5


WITHOUT_NUMPY = """
import sys
sys.modules["numpy"] = None  # numpy cannot be imported, as where it is not installed
import cehmm
"""


def test_import_without_numpy_names_it_and_how_to_install_it(tmp_path: Path) -> None:
    # It was a Rust panic with a backtrace: "Failed to access NumPy array API capsule".
    for code in (WITHOUT_NUMPY, WITHOUT_NUMPY.replace("import cehmm", "import cehmm._core")):
        done = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=120,
            env={**os.environ, "RUST_BACKTRACE": "1"},
        )  # fmt: skip
        assert done.returncode == 1, done.stderr
        last = done.stderr.strip().splitlines()[-1]
        assert last.startswith("ImportError: cehmm needs numpy") and "pip install numpy" in last, done.stderr
        assert "panic" not in done.stderr.lower() and "capsule" not in done.stderr, done.stderr
