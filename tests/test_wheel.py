"""The user's path, as issue 20's "done when" states it: a wheel built from this tree, installed in
a fresh virtual environment with no cargo on the PATH, gives the whole command line as ``cehmm``:
an optimisation with its history, its evaluation, a controller search and a learning curve.
(The venv sees the system's site-packages for numpy and matplotlib, so that no download is
needed; the ``cehmm`` it imports is the wheel's, which the test checks.)"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TIGER = ROOT / "data" / "pomdp" / "tiger.95.POMDP"


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
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)], check=True, timeout=300)
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
        ["python", "-c", "import cehmm; print(cehmm.__file__)"], capture_output=True, text=True, env=env, cwd=work
    )
    assert str(venv) in where.stdout, where.stdout
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
