"""Property tests of the readers of history files and of ``cehmm plot``'s inputs (Hypothesis):
damaged copies of histories the engine wrote (``--history`` as JSON lines and CSV, of episode CE
and of the controller search) and of a policy file, by byte flips and random bytes, changed
digits, deleted, duplicated and inserted spans (tokens that broke earlier readers among them:
deep nesting, huge numbers, NaN, NUL, stray quotes), and truncations. A history either reads
back as columns (the fast reader and the checked one giving the same) or is refused with
:class:`cehmm.InvalidArgumentError` naming the file; ``cehmm plot`` draws it or exits with status
2 and one error line; never another exception, a traceback or a hang. The example count is small
for CI; ``HYPOTHESIS_PROFILE=long`` runs many more (profiles: conftest.py)."""

from __future__ import annotations

import contextlib
import io
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st

import cehmm
from cehmm import cli, plots
from cehmm.plots import history

pytest.importorskip("matplotlib")

TIGER = Path(__file__).resolve().parents[1] / "data" / "pomdp" / "tiger.95.POMDP"

#: Spans inserted into a file: what broke earlier readers, and JSON's and CSV's own syntax.
TOKENS = [
    b"[" * 3000,
    b'{"a":' * 3000,
    b"1e400",
    b"-1e400",
    b"9" * 30,
    b"NaN",
    b"-Infinity",
    b"null",
    b"true",
    b"false",
    b'"',
    b",",
    b"\n",
    b"\r\n",
    b"\x00",
    b"\xff\xfe",
    b"\xef\xbb\xbf",
    b"{}",
    b"[]",
    b'"mean"',
    b'"iteration":',
    b"-",
    b"e",
    b".",
    b" ",
    b"\t",
    "\u2028".encode(),
]


def _run(args: list[str]) -> tuple[int, str]:
    """``cehmm ARGS`` in this process: the status and what it printed to stderr."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        status = cli.main(args)
    return status, err.getvalue()


def _good_files() -> dict[str, bytes]:
    """Files the engine wrote: histories of a short CE run and a controller search, and a policy."""
    with tempfile.TemporaryDirectory() as folder:
        d = Path(folder)
        ce = ["optimize", "--case", "3", "--levels", "2", "--samples", "40", "--max-iterations", "5", "--quiet"]
        ce += ["--eval-episodes", "10", "--out", str(d / "p.json")]
        search = ["controller", "--pomdp", str(TIGER), "--nodes", "2", "--max-iterations", "3", "--restarts", "2"]
        search += ["--quiet", "--out", str(d / "tiger.json")]
        for args, name in [(ce, "ce.jsonl"), (ce, "ce.csv"), (search, "search.jsonl"), (search, "search.csv")]:
            status, err = _run([*args, "--force", "--history", str(d / name)])
            assert status == 0, err
        return {f.name: f.read_bytes() for f in d.iterdir()}


GOOD = _good_files()
HISTORIES = sorted(name for name in GOOD if name.endswith((".jsonl", ".csv")))


@st.composite
def damaged(draw: st.DrawFn, good: bytes) -> bytes:
    """``good`` with one to four damages."""
    data = bytearray(good)
    for _ in range(draw(st.integers(1, 4))):
        size = len(data)
        kind = draw(st.sampled_from(["flip", "byte", "digit", "delete", "duplicate", "insert", "truncate"]))
        at = draw(st.integers(0, max(size - 1, 0)))
        if kind == "truncate":
            del data[at:]
        elif kind == "insert":
            data[at:at] = draw(st.sampled_from(TOKENS) | st.binary(min_size=1, max_size=8))
        elif size == 0:
            continue
        elif kind == "flip":
            data[at] ^= 1 << draw(st.integers(0, 7))
        elif kind == "byte":
            data[at] = draw(st.integers(0, 255))
        elif kind == "digit":
            digits = [k for k, b in enumerate(data) if 48 <= b <= 57]
            if digits:
                data[draw(st.sampled_from(digits))] = 48 + draw(st.integers(0, 9))
        else:
            end = min(size, at + draw(st.integers(1, 200)))
            span = bytes(data[at:end])
            if kind == "delete":
                del data[at:end]
            else:
                where = draw(st.integers(0, len(data)))
                data[where:where] = span * draw(st.integers(1, 3))
    return bytes(data)


@st.composite
def damaged_history(draw: st.DrawFn) -> tuple[str, bytes]:
    name = draw(st.sampled_from(HISTORIES))
    return name, draw(damaged(GOOD[name]))


def _check_columns(columns: dict[str, np.ndarray]) -> None:
    """What a history read back always is."""
    lengths = {len(c) for c in columns.values()}
    assert len(lengths) == 1 and lengths.pop() > 0
    assert all(c.ndim == 1 and c.dtype in (np.bool_, np.int64, np.float64) for c in columns.values())
    assert columns["iteration"].dtype == np.int64 and (columns["iteration"] >= 0).all()
    assert columns["mean"].dtype in (np.int64, np.float64)
    assert not any(np.isinf(c).any() for c in columns.values() if c.dtype == np.float64)


@given(damaged_history())
def test_a_damaged_history_reads_back_or_is_refused_by_both_readers_alike(case: tuple[str, bytes]) -> None:
    name, data = case
    suffix = Path(name).suffix
    try:
        checked = history._parse(data, suffix, fast=False)
    except history._Refused as e:
        event("refused")
        assert e.message and len(e.message) < 600, e.message
        with pytest.raises(history._Refused) as fast_refusal:
            history._parse(data, suffix)
        assert (fast_refusal.value.message, fast_refusal.value.line) == (e.message, e.line)
        return
    event("read")
    _check_columns(checked)
    fast = history._parse(data, suffix)
    assert list(fast) == list(checked)
    for key in fast:
        assert fast[key].dtype == checked[key].dtype, key
        assert np.array_equal(fast[key], checked[key], equal_nan=fast[key].dtype == np.float64), key


@settings(max_examples=max(10, settings.default.max_examples // 3))
@given(damaged_history())
def test_cehmm_plot_draws_a_damaged_history_or_says_what_is_wrong_in_one_line(case: tuple[str, bytes]) -> None:
    name, data = case
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / name
        path.write_bytes(data)
        try:
            plots.read_history(path)
            readable = True
        except cehmm.InvalidArgumentError as e:
            assert f"invalid history file: {path}" in str(e), e
            readable = False
        status, err = _run(["plot", str(path), "--out", str(Path(folder) / "f.png")])
    assert status in (0, 2) and "Traceback" not in err, err
    event(f"status {status}")
    if status == 2:
        assert err.startswith("cehmm plot: error: ") and err.count("\n") == 1, err
        assert str(path) in err, err
    else:
        assert readable and not err, err


@settings(max_examples=max(10, settings.default.max_examples // 3))
@given(damaged(GOOD["tiger.json"]))
def test_cehmm_plot_draws_a_damaged_policy_file_or_says_what_is_wrong_in_one_line(data: bytes) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "tiger.json"
        path.write_bytes(data)
        status, err = _run(["plot", str(path), "--out", str(Path(folder) / "f.png")])
    assert status in (0, 2) and "Traceback" not in err, err
    event(f"status {status}")
    if status == 2:
        assert err.startswith("cehmm plot: error: ") and err.count("\n") == 1, err
