"""Every reader of a user's file written in Python goes through the engine's bounded read: history
files read back (``cehmm.plots.read_history``), drawn (``cehmm.plots.learning_curve``) and drawn by
``cehmm plot``. What is not a regular file (a device, a link to one, a FIFO, a directory) or is
too large is refused at once; a malformed history is refused with the file, the line and what was
expected, as a :class:`cehmm.CehmmError` in Python and as one line with exit status 2 from
``cehmm plot``; a valid one reads back as the run's own history."""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import cehmm
from cehmm import cli, plots
from cehmm.plots import history

pytest.importorskip("matplotlib")

TIGER = Path(__file__).resolve().parents[1] / "data" / "pomdp" / "tiger.95.POMDP"

#: A history as the engine writes it (episode CE: ``ceworld optimize --history h.jsonl``).
ENGINE_JSONL = (
    '{"best":2.0,"elite_mean":1.5,"elite_threshold":1.0,"iteration":0,"mean":0.5,"seconds":0.01,"successful":true}\n'
    '{"best":3.0,"elite_mean":2.5,"elite_threshold":2.0,"iteration":1,"mean":1.25,"seconds":0.02,"successful":true}\n'
)
ENGINE_CSV = (
    "best,elite_mean,elite_threshold,iteration,mean,seconds,successful\n"
    "2.0,1.5,1.0,0,0.5,0.01,true\n"
    "3.0,2.5,2.0,1,1.25,0.02,true\n"
)


def at_once(call: Callable[..., Any], *args: Any, fifo: Path | None = None, **kwargs: Any) -> BaseException | None:
    """What ``call(*args, **kwargs)`` raised (``None``: it returned), asserting that it ended within 20 s (a
    FIFO's reader waiting for a writer is released, and the test fails)."""
    outcome: list[BaseException | None] = []
    seconds = 20.0

    def run() -> None:
        try:
            call(*args, **kwargs)
            outcome.append(None)
        except BaseException as e:  # noqa: BLE001 - handed to the test
            outcome.append(e)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(seconds)
    if thread.is_alive() and fifo is not None:
        with open(fifo, "w"):  # release the reader
            pass
        thread.join(seconds)
    assert outcome, f"still running after {seconds} s"
    return outcome[0]


def plot_fails(capsys: pytest.CaptureFixture[str], *args: str) -> str:
    """``cehmm plot ARGS`` run in this process: exit status 2 and one error line (returned)."""
    status = cli.main(["plot", *args])
    err = capsys.readouterr().err
    assert status == 2, err
    assert err.startswith("cehmm plot: error: ") and err.count("\n") == 1 and "Traceback" not in err, err
    return err


@pytest.fixture
def not_files(tmp_path: Path) -> dict[str, Path]:
    """Paths that name no regular file, all with a history's name where they can have one."""
    fifo = tmp_path / "fifo.jsonl"
    os.mkfifo(fifo)
    zero, random = tmp_path / "zero.jsonl", tmp_path / "random.csv"
    zero.symlink_to("/dev/zero")
    random.symlink_to("/dev/urandom")
    folder = tmp_path / "folder.jsonl"
    folder.mkdir()
    return {"/dev/zero": Path("/dev/zero"), "link to /dev/zero": zero, "link to /dev/urandom": random, "fifo": fifo}


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="needs /dev/zero and FIFOs (a Unix system)")
def test_what_is_not_a_regular_file_is_refused_at_once(
    not_files: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    paths = [*not_files.values(), Path("/dev/urandom"), tmp_path / "folder.jsonl"]
    for path in paths:
        fifo = path if path == not_files["fifo"] else None
        # The raw read refuses them whatever their name.
        e = at_once(cehmm._files.read_bytes, path, 1 << 20, "history file", fifo=fifo)
        assert isinstance(e, cehmm.InvalidArgumentError) and str(path) in str(e), e
        assert "history file" in str(e) and ("not a regular file" in str(e) or "is a directory" in str(e)), e
        if path.suffix not in (".jsonl", ".csv"):
            continue
        for reader in (plots.read_history, plots.learning_curve):
            e = at_once(reader, path, fifo=fifo)
            assert isinstance(e, cehmm.InvalidArgumentError) and str(path) in str(e), e
        out = tmp_path / "figure.png"
        e = at_once(plot_fails, capsys, str(path), "--out", str(out), fifo=fifo)
        assert e is None, e
        assert not out.exists()
    # A device by its own name is not a history (no suffix): refused before any read.
    err = plot_fails(capsys, "/dev/zero", "--out", str(tmp_path / "z.png"))
    assert "/dev/zero" in err and "expected a .jsonl or .csv file" in err, err


def test_a_history_over_the_limit_is_refused_before_it_is_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    big = tmp_path / "big.jsonl"
    with open(big, "wb") as f:
        f.truncate(history.MAX_HISTORY_BYTES + 1)  # sparse: nothing is written
    expected = f"{big} has {history.MAX_HISTORY_BYTES + 1} bytes (at most {history.MAX_HISTORY_BYTES} are read)"
    for reader in (plots.read_history, plots.learning_curve):
        with pytest.raises(cehmm.InvalidArgumentError, match="invalid history file") as e:
            reader(big)
        assert expected in str(e.value)
    assert expected in plot_fails(capsys, str(big), "--out", str(tmp_path / "big.png"))
    # At the limit, the file is read (and its zeros are not UTF-8 JSON).
    with open(big, "r+b") as f:
        f.truncate(history.MAX_HISTORY_BYTES)
    with pytest.raises(cehmm.InvalidArgumentError, match="line 1: "):
        plots.read_history(big)


#: Malformed histories: (name, content, what the error says besides the file and the line).
MALFORMED = [
    ("no-mean.jsonl", '{"iteration": 0, "best": 1.0}\n', "line 1: no 'mean' field in the first record"),
    ("not-an-object.jsonl", "[1, 2]\n", "line 1: [1, 2] is not a JSON object"),
    ("a-number.jsonl", ENGINE_JSONL + "7\n", "line 3: 7 is not a JSON object"),
    ("bad-json.jsonl", '{"iteration": 0, "mean": 1.0 "x": 2}\n', "line 1: Expecting ',' delimiter at column 30"),
    ("deep.jsonl", "[" * 100_000 + "\n", "line 1: nested too deep to read"),
    ("deep-object.jsonl", '{"a":' * 100_000 + "\n", "line 1: nested too deep to read"),
    ("huge.jsonl", '{"iteration": 0, "mean": 1e400}\n', "line 1: the number 1e400 is out of a float's range"),
    ("nan.jsonl", '{"iteration": 0, "mean": NaN}\n', "line 1: NaN (expected a finite number"),
    ("infinity.jsonl", '{"iteration": 0, "mean": -Infinity}\n', "line 1: -Infinity (expected a finite number"),
    ("long-int.jsonl", '{"iteration": 0, "mean": ' + "9" * 5000 + "}\n", "line 1: the integer 9999"),
    ("int64.jsonl", '{"iteration": 9223372036854775808, "mean": 1}\n', "out of range (expected a 64-bit integer)"),
    ("string.jsonl", '{"iteration": 0, "mean": "abc"}\n', "line 1: field 'mean' is 'abc' (expected a finite number"),
    ("list.jsonl", '{"iteration": 0, "mean": [1]}\n', "line 1: field 'mean' is [1]"),
    ("flag-mean.jsonl", '{"iteration": 0, "mean": true}\n', "line 1: field 'mean' is true (expected a finite number"),
    ("negative.jsonl", '{"iteration": -1, "mean": 1}\n', "line 1: field 'iteration' is -1 (expected an integer, 0"),
    ("float-iteration.jsonl", '{"iteration": 1.5, "mean": 1}\n', "field 'iteration' is 1.5"),
    ("fields.jsonl", ENGINE_JSONL + '{"iteration": 2, "mean": 1.0}\n', "line 3: no best, elite_mean"),
    (
        "kinds.jsonl",
        ENGINE_JSONL.replace('"successful":true}\n', '"successful":1}\n', 1),
        "line 2: field 'successful' is true where line 1 has a number",
    ),
    ("empty.jsonl", "\n \n", ": no record (expected a line per iteration"),
    ("latin1.jsonl", ENGINE_JSONL + '{"x": "\xe9"}\n', "line 3: byte 0xe9 at column 8 is not UTF-8"),
    ("short-row.csv", ENGINE_CSV + "0.0,1.0\n", "line 4: 2 fields where the header has 7"),
    ("long-row.csv", ENGINE_CSV + "1,2,3,4,5,6,7,8\n", "line 4: 8 fields where the header has 7"),
    ("word.csv", ENGINE_CSV.replace("0.5", "half"), "line 2: field 'mean' is 'half' (expected a finite number"),
    ("inf.csv", ENGINE_CSV.replace("0.5", "inf"), "line 2: field 'mean' is 'inf'"),
    ("huge.csv", ENGINE_CSV.replace("0.5", "1e400"), "line 2: the number 1e400 is out of a float's range"),
    ("no-mean.csv", "iteration,best\n0,1.0\n", "line 1: no 'mean' field in the header"),
    ("twice.csv", "iteration,mean,mean\n0,1,2\n", "line 1: field 'mean' twice in the header"),
    ("quotes.csv", 'iteration,mean\n0,"1"x\n', "line 2: ',' expected after '\"'"),
    ("header-only.csv", "iteration,mean\n", ": no record"),
]


@pytest.mark.parametrize(("name", "text", "said"), MALFORMED, ids=[m[0] for m in MALFORMED])
def test_a_malformed_history_is_refused_naming_the_file_and_the_line(
    name: str, text: str, said: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / name
    path.write_bytes(text.encode("latin-1" if name.startswith("latin1") else "utf-8"))
    expected = f"invalid history file: {path}"
    for reader in (plots.read_history, plots.learning_curve):
        with pytest.raises(cehmm.InvalidArgumentError) as e:
            reader(path)
        assert expected in str(e.value) and said in str(e.value), str(e.value)
        assert len(str(e.value)) < 400, str(e.value)
    err = plot_fails(capsys, str(path), "--out", str(tmp_path / "figure.png"))
    assert expected in err and said in err, err
    # Both readers agree: the fast one gives up, the checked one names the error.
    for fast in (True, False):
        with pytest.raises(history._Refused):
            history._parse(path.read_bytes(), path.suffix, fast=fast)


def test_a_history_reads_back_as_the_run_has_it(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = ["optimize", "--case", "1", "--levels", "2", "--samples", "50", "--max-iterations", "4", "--quiet"]
    run += ["--eval-episodes", "10"]
    for name in ("h.jsonl", "h.csv"):
        out = str(tmp_path / f"{name}.json")
        assert cli.main([*run, "--out", out, "--history", str(tmp_path / name)]) == 0
    search = ["controller", "--pomdp", str(TIGER), "--nodes", "2", "--max-iterations", "3", "--restarts", "2"]
    assert cli.main([*search, "--quiet", "--out", str(tmp_path / "c.json"), "--history", str(tmp_path / "c.csv")]) == 0
    capsys.readouterr()
    world = cehmm.TargetTracking(case=1)
    result = cehmm.optimize(world, levels=[2], samples=50, max_iterations=4, eval_episodes=10, progress=False)
    controller = cehmm.optimize_controller(
        cehmm.PomdpWorld.from_file(TIGER), nodes=2, max_iterations=3, restarts=2, progress=False
    )
    for name, expected in [("h.jsonl", result.history), ("h.csv", result.history), ("c.csv", controller.history)]:
        read = plots.read_history(tmp_path / name)
        assert sorted(read) == sorted(expected), name
        for key, column in read.items():
            assert column.dtype == np.asarray(expected[key]).dtype, (name, key, column.dtype)
            if key != "seconds":
                assert np.array_equal(column, expected[key]), (name, key)
        # The fast reader and the checked one give the same columns.
        data = (tmp_path / name).read_bytes()
        fast, checked = history._parse(data, Path(name).suffix), history._parse(data, Path(name).suffix, fast=False)
        assert fast.keys() == checked.keys()
        for key in fast:
            assert fast[key].dtype == checked[key].dtype and np.array_equal(fast[key], checked[key]), key
        plots.learning_curve(tmp_path / name, x="seconds").savefig(tmp_path / "f.png", dpi=40)


def test_what_the_engine_may_write_or_an_editor_leave_is_read(tmp_path: Path) -> None:
    # null and an empty cell (a statistic that was not a finite number) are NaN; a byte-order
    # mark, CRLF line ends and blank lines are passed over.
    path = tmp_path / "h.jsonl"
    edited = ENGINE_JSONL.replace('"mean":0.5', '"mean":null').replace("\n", "\r\n\n")
    path.write_bytes(b"\xef\xbb\xbf" + edited.encode())
    read = plots.read_history(path)
    assert np.isnan(read["mean"][0]) and read["mean"][1] == 1.25 and read["iteration"].dtype == np.int64
    path = tmp_path / "h.csv"
    path.write_text(ENGINE_CSV.replace(",0.5,", ",,").replace("\n", "\r\n"), newline="")
    read = plots.read_history(path)
    assert np.isnan(read["mean"][0]) and list(read["successful"]) == [True, True]
    plots.learning_curve(path).savefig(tmp_path / "f.png", dpi=40)


def test_values_too_large_to_draw_are_refused_naming_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "h.jsonl"
    path.write_text('{"iteration": 0, "mean": 1.7e308}\n{"iteration": 1, "mean": -1.7e308}\n')
    assert plots.read_history(path)["mean"][0] == 1.7e308  # a finite number: read
    with pytest.raises(cehmm.InvalidArgumentError, match=r"field 'mean' has 1.7e\+308 \(expected values within"):
        plots.learning_curve(path)
    err = plot_fails(capsys, str(path), "--out", str(tmp_path / "f.png"))
    assert f"invalid history file: {path}" in err, err
    with pytest.raises(cehmm.InvalidArgumentError, match=r"invalid run \(dict\): field 'mean' does not hold numbers"):
        plots.learning_curve({"mean": ["a", "b"]})


def test_cehmm_plot_never_writes_over_what_it_reads(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "h.jsonl"
    path.write_text(ENGINE_JSONL)
    (tmp_path / "link.png").symlink_to(path)
    for out in (path, tmp_path / "link.png"):
        err = plot_fails(capsys, str(path), "--out", str(out), "--force")
        assert "invalid --out" in err and "read by the same command" in err, err
    assert path.read_text() == ENGINE_JSONL
