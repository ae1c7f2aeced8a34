"""The reproduction runner end to end, in its --quick form (a few seconds), and its pieces."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

from cehmm import reproduce

QUICK_JOBS = len(reproduce.QUICK_ROWS) * reproduce.QUICK_SEEDS


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "cehmm.reproduce", *args], capture_output=True, text=True, timeout=120)


@pytest.fixture(scope="module")
def quick(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, subprocess.CompletedProcess]:
    out = tmp_path_factory.mktemp("quick")
    done = _run("--quick", "--out-dir", str(out))
    assert done.returncode == 0, done.stderr
    return out, done


def test_quick_run_writes_one_jsonl_line_per_job(quick):
    out, done = quick
    lines = (out / "reproduce.jsonl").read_text().splitlines()
    records = [json.loads(line) for line in lines]
    assert len(records) == QUICK_JOBS
    assert {(r["row"], r["seed"]) for r in records} == {
        (row, seed) for row in reproduce.QUICK_ROWS for seed in range(reproduce.QUICK_SEEDS)
    }
    for r in records:
        assert set(reproduce.RECORD_KEYS) <= set(r)
        assert r["settings"] == "quick"
        assert r["iterations"] == 5 and r["stop_reason"] == "max_iterations"
        assert r["eval_episodes"] == 200 and 0 <= r["mean"] <= 100
        assert (out / r["policy"]).stat().st_size > 0
        assert set(r["history"]) == set(reproduce.HISTORY_KEYS) and len(r["history"]["mean"]) == 5
        assert r["commit"]
    assert f"[{QUICK_JOBS}/{QUICK_JOBS}]" in done.stdout


def test_quick_run_writes_the_tables(quick):
    out, _ = quick
    doc = json.loads((out / "results.json").read_text())
    assert [s["row"] for s in doc["rows"]] == reproduce.QUICK_ROWS
    for s in doc["rows"]:
        assert s["seeds"] == reproduce.QUICK_SEEDS and len(s["runs"]) == reproduce.QUICK_SEEDS
        assert s["percent"] == pytest.approx(100 * s["mean"] / 69)
        assert s["status"].startswith(("≥ paper", "below paper by"))
    assert doc["machine"]["cores"] >= 1
    with open(out / "results.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["row"] for r in rows] == reproduce.QUICK_ROWS
    assert set(reproduce.CSV_FIELDS) == set(rows[0])


def test_quick_run_writes_the_report_and_figures(quick):
    out, _ = quick
    text = (out / "results.md").read_text()
    assert "| row | model | criterion | paper | paper % | ours (mean ± std over seeds) |" in text
    assert "## Optimiser findings" in text and "engine-results.md" in text
    assert "**Machine**" in text and "**Command**" in text
    for name in ("summary", "learning_curves", "trajectory", "memory"):
        png = out / "img" / f"{name}.png"
        assert png.stat().st_size > 1000, name
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert f"img/{name}.png" in text


def test_second_run_resumes_and_runs_nothing(quick, tmp_path):
    out, _ = quick
    before = (out / "reproduce.jsonl").read_text()
    findings = tmp_path / "findings.md"
    findings.write_text("Smoothing helps *case 2*.\n")
    done = _run("--quick", "--out-dir", str(out), "--no-figures", "--findings", str(findings))
    assert done.returncode == 0, done.stderr
    assert "0 job(s) to run" in done.stdout
    assert (out / "reproduce.jsonl").read_text() == before
    assert "Smoothing helps *case 2*." in (out / "results.md").read_text()


def test_report_only_rebuilds_without_running(tmp_path):
    out = tmp_path / "out"
    assert (
        reproduce.main(["--quick", "--out-dir", str(out), "--rows", "c3-16-weak", "--seeds", "1", "--no-figures"]) == 0
    )
    (out / "results.csv").unlink()
    report = tmp_path / "r.md"
    assert (
        reproduce.main(["--quick", "--out-dir", str(out), "--report-only", "--no-figures", "--report", str(report)])
        == 0
    )
    assert len((out / "reproduce.jsonl").read_text().splitlines()) == 1
    assert (out / "results.csv").exists() and "`c3-16-weak`" in report.read_text()


def test_rows_and_settings_are_data():
    ids = [row["id"] for row in reproduce.ROWS]
    assert len(ids) == len(set(ids)) == 15
    assert "c3-256x256-strong" in ids and not any("q" in i.split("-")[0] for i in ids)
    for row in reproduce.ROWS:
        assert row["paper_percent"] == pytest.approx(100 * row["paper_reward"] / 69, abs=0.1)
    row = reproduce.rows_by_id()["c3-16x2x2x2-strong"]
    kwargs = reproduce.job_kwargs(row, reproduce.SETTINGS["paper"], {"smoothing": 0.7})
    assert kwargs == {"levels": [16, 2, 2, 2], "patience": 500, "samples": 1000, "rho": 0.5, "smoothing": 0.7}
    assert reproduce.parse_set(["smoothing=0.7", "init=random"]) == {"smoothing": 0.7, "init": "random"}
    assert reproduce.settings_label("paper", {"smoothing": 0.7}) == "paper+smoothing=0.7"
    assert [r["id"] for r in reproduce.select_rows(["c3-*-strong"])] == [
        "c3-16-strong",
        "c3-16x2-strong",
        "c3-16x2x2-strong",
        "c3-16x2x2x2-strong",
        "c3-256x256-strong",
    ]
    assert reproduce.status_text(70, 69) == "≥ paper"
    assert reproduce.status_text(62.1, 69) == "below paper by 6.9 (10.0 pp)"


def test_console_script_dispatches(capsys):
    from cehmm import cli

    assert cli.main(["reproduce", "--list-rows"]) == 0
    assert "c3-256x256-strong" in capsys.readouterr().out
    assert cli.main(["nope"]) == 2


def test_worker_processes_give_the_same_results(quick, tmp_path):
    out, _ = quick
    done = _run("--quick", "--out-dir", str(tmp_path), "--jobs", "2", "--no-figures")
    assert done.returncode == 0, done.stderr
    key = lambda r: (r["row"], r["seed"])  # noqa: E731
    serial = sorted(reproduce.read_records(out / "reproduce.jsonl"), key=key)
    parallel = sorted(reproduce.read_records(tmp_path / "reproduce.jsonl"), key=key)
    assert [(key(r), r["mean"], r["best_iteration"]) for r in parallel] == [
        (key(r), r["mean"], r["best_iteration"]) for r in serial
    ]
    assert all(r["threads"] == 1 for r in parallel)


def test_report_only_without_data_is_an_error(tmp_path, capsys):
    code = reproduce.main(["--quick", "--out-dir", str(tmp_path), "--report-only", "--no-figures"])
    assert code == 2
    assert "no finished job" in capsys.readouterr().err
    assert not (tmp_path / "results.md").exists()


def test_changed_preset_settings_run_again(tmp_path, monkeypatch):
    args = ["--quick", "--out-dir", str(tmp_path), "--rows", "c3-16-weak", "--seeds", "1", "--no-figures"]
    assert reproduce.main(args) == 0
    # The same preset name with other settings: the old record is not reused, nor reported.
    quick = {**reproduce.SETTINGS["quick"], "*": {**reproduce.SETTINGS["quick"]["*"], "samples": 120}}
    monkeypatch.setitem(reproduce.SETTINGS, "quick", quick)
    assert reproduce.main(args) == 0
    records = reproduce.read_records(tmp_path / "reproduce.jsonl")
    assert [r["kwargs"]["samples"] for r in records] == [100, 120]
    doc = json.loads((tmp_path / "results.json").read_text())
    assert [r["kwargs"]["samples"] for r in doc["rows"][0]["runs"]] == [120]


def test_check_compares_the_report_with_the_data(tmp_path, capsys):
    out = tmp_path
    assert reproduce.main(["--quick", "--out-dir", str(out), "--rows", "c3-16-weak", "--seeds", "1"]) == 0
    args = ["--quick", "--out-dir", str(out), "--rows", "c3-16-weak", "--report-only", "--check"]
    assert reproduce.main(args) == 0
    report = out / "results.md"
    report.write_text(report.read_text().replace("c3-16-weak", "c3-16-weak (edited)"))
    assert reproduce.main(args) == 1
    assert "is not what" in capsys.readouterr().err


def test_report_only_replays_a_job_whose_policy_is_gone(tmp_path, capsys):
    args = ["--quick", "--out-dir", str(tmp_path), "--rows", "c3-16x16-weak", "--seeds", "1", "--no-figures"]
    assert reproduce.main(args) == 0
    (record,) = reproduce.read_records(tmp_path / "reproduce.jsonl")
    saved = (tmp_path / record["policy"]).read_text()
    (tmp_path / record["policy"]).unlink()
    img = tmp_path / "img"
    assert reproduce.main([*args[:-1], "--report-only", "--img-dir", str(img)]) == 0
    err = capsys.readouterr().err
    assert "replaying c3-16x16-weak seed 0" in err and "warning" not in err
    # The replay gives the same policy, bit for bit (its provenance holds the same numbers).
    assert json.loads((tmp_path / record["policy"]).read_text())["policy"] == json.loads(saved)["policy"]
    for name in reproduce.planned_figures(
        reproduce.aggregate(
            [record],
            reproduce.select_rows(["c3-16x16-weak"]),
            "quick",
            {"c3-16x16-weak": reproduce.kwargs_key(record["kwargs"])},
        )
    ):
        assert (img / f"{name}.png").stat().st_size > 1000, name


@pytest.mark.parametrize(
    "args",
    [
        [],
        ["--settings", "tuned", "--report", "docs/results-tuned.md", "--img-dir", "docs/img/tuned"],
    ],
    ids=["paper", "tuned"],
)
def test_committed_reports_are_what_the_committed_data_gives(args, monkeypatch, capsys):
    # A fresh clone rebuilds docs/results.md and docs/results-tuned.md from docs/data/reproduce.jsonl,
    # byte for byte (the figures are not compared: matplotlib's output varies with its version).
    monkeypatch.chdir(Path(__file__).resolve().parents[1])
    code = reproduce.main(["--report-only", "--check", *args])
    assert code == 0, capsys.readouterr().err
