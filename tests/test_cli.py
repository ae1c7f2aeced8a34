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

import numpy as np
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


def test_the_help_is_one_list_of_every_command_each_on_a_line(tmp_path: Path) -> None:
    helped = cehmm("--help", cwd=tmp_path)
    assert helped.returncode == 0, helped.stderr
    # One usage (the second block, where the package's commands hid, is gone).
    assert helped.stdout.lower().count("usage:") == 1, helped.stdout
    listed = helped.stdout.split("Commands:\n")[1].split("\n\n")[0].splitlines()
    described = dict(line.split(None, 1) for line in listed)
    engine = ["optimize", "controller", "evaluate", "show", "optimum", "qlearn", "qlearn-eval", "run"]
    assert list(described) == [*engine, *cli.PYTHON_COMMANDS, "help"], listed
    # The package's commands as the package describes them; every description one short line.
    for name, what in cli.PYTHON_COMMANDS.items():
        assert described[name] == what, name
    assert all(len(line) < 120 for line in listed), listed
    # Without a command: the same list, on stderr, exit 2; `help COMMAND` for the package's too.
    bare = cehmm(cwd=tmp_path)
    assert bare.returncode == 2 and "plot " in bare.stderr and "qlearn-eval " in bare.stderr, bare.stderr
    helped = cehmm("help", "plot", cwd=tmp_path)
    assert helped.returncode == 0 and "usage: cehmm plot" in helped.stdout, helped.stderr


def test_the_packages_commands_call_themselves_by_the_name_they_were_run_by(tmp_path: Path) -> None:
    # `cehmm benchmarks --help` printed `usage: python -m cehmm.benchmarks`.
    for command in cli.PYTHON_COMMANDS:
        helped = cehmm(command, "--help", cwd=tmp_path)
        assert helped.returncode == 0 and helped.stdout.startswith(f"usage: cehmm {command} "), helped.stdout[:200]
    refused = cehmm("benchmarks", "--check", cwd=tmp_path)
    assert refused.returncode != 0 and refused.stderr.startswith(
        "cehmm benchmarks: error: --check goes with --report-only"
    ), refused.stderr
    refused = cehmm("benchmarks", "--controllers", "nonsense", "--data-dir", str(TIGER.parent), cwd=tmp_path)
    assert refused.stderr.startswith("cehmm benchmarks: error: unknown controller(s) ['nonsense']"), refused.stderr
    # Run as a module, it is that module.
    helped = subprocess.run([sys.executable, "-m", "cehmm.benchmarks", "--help"], capture_output=True, text=True)
    assert helped.stdout.startswith("usage: python -m cehmm.benchmarks "), helped.stdout[:200]


def test_sizes_given_apart_and_episodes_of_an_exact_value_are_refused_by_name(tmp_path: Path) -> None:
    spaced = cehmm("optimize", "--levels", "16", "16", cwd=tmp_path)
    assert spaced.returncode == 2, spaced.stderr
    assert spaced.stderr.startswith("cehmm: error: invalid --levels: 16 16 (expected sizes separated by commas")
    assert "--levels 16,16" in spaced.stderr
    searched = cehmm("controller", "--pomdp", str(TIGER), "--nodes", "2", "--quiet", "--out", "t.json", cwd=tmp_path)
    assert searched.returncode == 0, searched.stderr
    exact = cehmm("evaluate", "t.json", "--exact", cwd=tmp_path)
    assert exact.returncode == 0 and "exact infinite-horizon value" in exact.stdout, exact.stderr
    assert exact.stderr == ""  # no stray "(0.00s)"
    both = cehmm("evaluate", "t.json", "--exact", "--episodes", "10", cwd=tmp_path)
    assert both.returncode == 2 and "invalid --episodes: 10" in both.stderr and "--exact" in both.stderr, both.stderr


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


def test_a_run_keeps_its_history_and_cehmm_plot_draws_it(tmp_path: Path) -> None:
    run = ["optimize", "--case", "3", "--levels", "4", "--samples", "100", "--max-iterations", "6", "--quiet"]
    done = cehmm(*run, "--out", "p.json", "--history", "h.jsonl", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    again = cehmm(*run, "--out", "p.json", "--history", "h.csv", cwd=tmp_path)
    assert again.returncode == 2 and "exists (give --force" in again.stderr, again.stderr
    forced = cehmm(*run, "--out", "p.json", "--force", "--history", "h.csv", cwd=tmp_path)
    assert forced.returncode == 0, forced.stderr
    from cehmm.plots import read_history

    lines, table = read_history(tmp_path / "h.jsonl"), read_history(tmp_path / "h.csv")
    assert list(lines["iteration"]) == list(range(6))
    for key in ("mean", "best", "elite_threshold", "elite_mean"):
        assert np.array_equal(lines[key], table[key]), key
    drawn = cehmm("plot", "h.jsonl", "h.csv", "--out", "lc.png", cwd=tmp_path)
    assert drawn.returncode == 0, drawn.stderr
    assert (tmp_path / "lc.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert cehmm("plot", "h.jsonl", "--out", "lc.png", cwd=tmp_path).returncode == 2  # exists
    bad = cehmm("plot", "h.jsonl", "p.json", "--out", "x.png", cwd=tmp_path)
    assert bad.returncode == 2 and "expected history files, or one policy file" in bad.stderr, bad.stderr
    bad = cehmm("plot", "h.txt", "--out", "x.png", cwd=tmp_path)
    assert bad.returncode == 2 and "expected a .jsonl or .csv" in bad.stderr, bad.stderr
    bad = cehmm("plot", "h.jsonl", "--what", "graph", "--out", "x.png", cwd=tmp_path)
    assert bad.returncode == 2 and "invalid --what: graph (expected a policy file" in bad.stderr, bad.stderr


def test_results_draw_their_learning_curves(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import cehmm as package

    world = package.TargetTracking(case=1)
    result = package.optimize(world, levels=[2], samples=100, max_iterations=4, eval_episodes=20, progress=False)
    search = package.optimize_controller(
        package.PomdpWorld.from_file(TIGER), nodes=2, max_iterations=3, restarts=2, progress=False
    )
    rival = {"mean": [1.0, 2.0, 2.5], "seconds": [0.1, 0.2, 0.3]}
    for figure in [result.plot(), search.plot(x="seconds"), package.plots.learning_curve(result, search, rival)]:
        path = tmp_path / "f.png"
        figure.savefig(path)
        assert path.stat().st_size > 1000
    with pytest.raises(TypeError, match="expected a result"):
        package.plots.learning_curve([1, 2, 3])
    with pytest.raises(package.InvalidArgumentError, match="'iteration', 'seconds' or 'env_steps'"):
        result.plot(x="time")
    # Without matplotlib (the optional extra), the error says how to install it.
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)
    with pytest.raises(ImportError, match=r"pip install 'cehmm\[plot\]'"):
        result.plot()
