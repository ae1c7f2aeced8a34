"""The ``cehmm`` console script: the engine's whole command line, compiled into the package (the
one the ``ceworld`` binary runs; its own tests are crates/ceworld/tests/cli.rs), reached without
cargo; the package's own commands; the interpreter's signal handlers left as they were."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cehmm import cli

TIGER = Path(__file__).resolve().parents[1] / "data" / "pomdp" / "tiger.95.POMDP"


def cehmm(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """``cehmm ARGS`` as the console script runs it."""
    return subprocess.run(
        [sys.executable, "-m", "cehmm.cli", *args], capture_output=True, text=True, cwd=cwd, timeout=300
    )


def test_the_console_script_runs_the_engines_commands(tmp_path: Path) -> None:
    done = cehmm("optimize", "--case", "3", "--levels", "16", "--max-iterations", "3", "--out", "p.json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stderr.startswith("cehmm: world"), done.stderr
    assert "max_iterations: 3 iterations" in done.stdout
    assert json.loads((tmp_path / "p.json").read_text())["format"] == "cehmm-policy"
    evaluated = cehmm("evaluate", "p.json", "--episodes", "100", cwd=tmp_path)
    assert evaluated.returncode == 0 and "100 episodes: mean" in evaluated.stdout, evaluated.stderr
    searched = cehmm("controller", "--pomdp", str(TIGER), "--nodes", "4", "--quiet", "--out", "t.json", cwd=tmp_path)
    assert searched.returncode == 0 and "exact infinite-horizon value" in searched.stdout, searched.stderr
    shown = cehmm("show", "t.json", cwd=tmp_path)
    assert shown.returncode == 0 and "listen" in shown.stdout, shown.stderr
    # Errors: exit 2, one line naming the problem, as the program `cehmm`.
    bad = cehmm("optimize", "--case", "9", "--out", "x.json", cwd=tmp_path)
    assert bad.returncode == 2 and bad.stderr.startswith("cehmm: error: invalid"), bad.stderr
    assert cehmm("optimize", "--bogus", cwd=tmp_path).returncode == 2
    helped = cehmm("--help", cwd=tmp_path)
    assert helped.returncode == 0
    for command in ["optimize", "controller", "evaluate", "show", "optimum", "qlearn", "qlearn-eval", "reproduce"]:
        assert command in helped.stdout, command


def test_the_command_line_leaves_the_interpreters_signal_handlers_as_they_were(capfd, tmp_path: Path) -> None:
    before = (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM))
    assert cli.main(["optimum", "--case", "1"]) == 0
    assert capfd.readouterr().out.strip() == "86"
    # optimize installs its own SIGINT and SIGTERM handlers while it runs.
    out = str(tmp_path / "p.json")
    assert (
        cli.main(["optimize", "--case", "1", "--max-iterations", "1", "--samples", "20", "--quiet", "--out", out]) == 0
    )
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == before
    # The C-level handler is Python's again: Ctrl-C raises KeyboardInterrupt, not a silent flag.
    with pytest.raises(KeyboardInterrupt):
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(1)
    assert cli.main([]) == 2
