"""The memory benchmark (``python -m cehmm.benchmarks.memory``): budgets parsed, a cell learns
within its budget in steps and is valued through the agent, the grid skips finished cells and
groups the rival's budgets, and the command writes its data and page and does not run a finished
cell again."""

from __future__ import annotations

from pathlib import Path

import pytest

from cehmm.benchmarks import memory, memory_report
from cehmm.reproduce.records import append_record


def test_a_budget_is_steps_or_seconds() -> None:
    assert memory.budget("50k") == (50_000, None)
    assert memory.budget("2M") == (2_000_000, None)
    assert memory.budget("1000") == (1000, None)
    assert memory.budget("300s") == (None, 300.0)
    for bad in ("", "0", "5x", "-3k", "k"):
        with pytest.raises(ValueError, match="invalid budget"):
            memory.budget(bad)


def test_a_cell_learns_within_its_budget_and_is_valued_through_the_agent() -> None:
    (random,) = memory.run_cell("t-maze-10", "random", "0", 0, episodes=50)
    assert random["value"] < 0 and random["env_steps"] == 0 and random["episodes"] == 50
    (learnt,) = memory.run_cell("t-maze-10", "cehmm", "2k", 0, episodes=50)
    assert learnt["env_steps"] >= 2000 and learnt["stop"] == "max_env_steps"
    assert learnt["curve"] and learnt["curve"][-1][0] == learnt["env_steps"]
    # Valued on the same fresh episodes through the environment's loop: the same value again.
    assert memory.run_cell("t-maze-10", "cehmm", "2k", 0, episodes=50)[0]["value"] == learnt["value"]
    with pytest.raises(ValueError, match="invalid method"):
        memory.run_cell("t-maze-10", "nothing", "2k", 0, episodes=50)


def test_the_grid_skips_finished_cells_and_trains_the_rival_once_per_seed() -> None:
    done = {("t-maze-10", "cehmm", "5k", 0), ("t-maze-10", "recurrent-ppo", "5k", 0)}
    todo = memory.jobs(["t-maze-10"], ["random", "cehmm", "recurrent-ppo"], ["5k", "9k"], [0, 1], done)
    assert todo == [
        ("t-maze-10", "random", "0", 0),
        ("t-maze-10", "cehmm", "9k", 0),
        ("t-maze-10", "cehmm", "5k", 1),
        ("t-maze-10", "cehmm", "9k", 1),
        ("t-maze-10", "recurrent-ppo", "9k", 0),
    ]


def test_the_command_writes_data_and_page_and_resumes(tmp_path: Path) -> None:
    argv = ["--quick", "--methods", "random", "cehmm", "--episodes", "20", "--out", str(tmp_path)]
    assert memory.main(argv) == 0
    data = (tmp_path / "data" / "memory.jsonl").read_text().splitlines()
    assert len(data) == 2  # random and cehmm at 5k, seed 0
    page = (tmp_path / "memory-benchmark.md").read_text()
    assert "| t-maze-10 | 1 |" in page and "| 5k |" in page
    assert memory.main(argv) == 0
    assert (tmp_path / "data" / "memory.jsonl").read_text().splitlines() == data


def test_the_page_is_of_the_data_as_it_is_when_the_run_ends(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # Another run at once appends its cell while this one runs: the page shows both.
    data = tmp_path / "data" / "memory.jsonl"
    ours = memory._run_all

    def with_another(*args: object) -> object:
        record = {"task": "t-maze-10", "method": "memoryless", "budget": "5k", "seed": 0, "value": 0.123}
        append_record(data, {**record, "std_error": 0.0, "env_steps": 5000, "seconds": 1.0, "episodes": 20})
        return ours(*args)

    monkeypatch.setattr(memory, "_run_all", with_another)
    argv = ["--quick", "--methods", "random", "--episodes", "20", "--out", str(tmp_path)]
    assert memory.main(argv) == 0
    assert "0.123" in (tmp_path / "memory-benchmark.md").read_text()


def test_the_page_shows_the_rival_beside_the_seeds_range() -> None:
    records = [
        {"task": "t-maze-10", "method": "cehmm", "budget": "50k", "seed": s, "value": v, "env_steps": 50_100}
        for s, v in enumerate([0.5, 1.0, 0.9])
    ]
    records.append({"task": "t-maze-10", "method": "recurrent-ppo", "budget": "50k", "seed": 0, "value": 0.25})
    page = memory_report.render(records, memory.TASKS, memory._budget_order)
    assert "| t-maze-10 | 1 | — | 50k | — | 0.800 [0.50, 1.00] | 50,100 | — | — | 0.250 |" in page
