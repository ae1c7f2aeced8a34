"""The memory benchmark (``python -m cehmm.benchmarks.memory``): a cell learns and evaluates, the
command writes its data and report and does not run a finished cell again."""

from __future__ import annotations

from pathlib import Path

from cehmm.benchmarks import memory


def test_a_cell_learns_within_its_budget_and_is_evaluated() -> None:
    random = memory.run_cell("t-maze-10", "random", budget=1.0, episodes=50, seed=0)
    assert random is not None and random["value"] < 0 and random["seconds"] < 1.0
    # Exact values apply to .pomdp files only; the cell records the controller's exact value.
    assert memory.run_cell("t-maze-10", "controller-exact", budget=1.0, episodes=50, seed=0) is None
    tiger = memory.run_cell("tiger", "controller-exact", budget=1.0, episodes=50, seed=0)
    assert tiger is not None and tiger["exact"] > 0


def test_the_command_writes_data_and_report_and_resumes(tmp_path: Path) -> None:
    argv = ["--tasks", "t-maze-10", "--methods", "random", "memoryless", "--budget", "0.5", "--episodes", "20"]
    assert memory.main([*argv, "--out", str(tmp_path)]) == 0
    data = (tmp_path / "data" / "memory.jsonl").read_text().splitlines()
    assert len(data) == 3  # the header and two cells
    report = (tmp_path / "memory-benchmark.md").read_text()
    assert "| t-maze-10 | 1 |" in report and "memoryless" in report
    assert memory.main([*argv, "--out", str(tmp_path)]) == 0
    assert (tmp_path / "data" / "memory.jsonl").read_text().splitlines() == data
