"""History files read back: what a run saved with ``--history FILE.jsonl`` or ``FILE.csv`` (the
engine's ``cli/output.rs``: one record per iteration, as JSON lines, or as CSV under a header of
the first record's fields), checked line by line.

The file is read by the engine's bounded read (:func:`cehmm._files.read_bytes`): a directory, a
device, a FIFO or a link to one is refused at once, and so is a file over
:data:`MAX_HISTORY_BYTES`. A history is UTF-8 text; every record has the fields of the first
(at most :data:`MAX_FIELDS`), among them ``iteration`` (an integer, 0 or more) and ``mean`` (a
number); a value is a number as JSON writes it (finite; an integer within 64 bits), ``true`` or
``false``, or nothing (JSON ``null``, an empty CSV cell: how the engine writes a statistic that
is not a finite number, read as NaN), a field holding flags or numbers, not both; a CSV row has
one cell per header field; blank lines are passed over. Anything else is an
:class:`~cehmm.InvalidArgumentError` naming the file, the line and what was expected.

Two readers share these rules: a fast one, column by column, that gives up (``None``) at the
first thing it does not take, and the checked one, line by line, that then finds the first
error in the file and names it. The fuzzers (``tests/test_readers_fuzz.py``) hold them to the
same answers.
"""

from __future__ import annotations

import csv
import io
import itertools
import json
import math
import operator
import os
import re
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .. import _core
from .._files import read_bytes

#: The largest history file read, in bytes (16 MiB: fifty thousand iterations or more, far more
#: than a figure shows); a larger file is refused before it is read.
MAX_HISTORY_BYTES = 16 << 20

#: The most fields a record may have (a run's records have about a dozen).
MAX_FIELDS = 1000

#: The fields every record has: the x and the y of a learning curve.
REQUIRED = ("iteration", "mean")

#: A number as JSON writes it (the engine's CSV cells are JSON values too).
_NUMBER = r"-?(?:0|[1-9][0-9]*)(?:\.[0-9]+)?(?:[eE][+-]?[0-9]+)?"
_NUMBER_CELL = re.compile(_NUMBER)
_INTEGER_CELL = re.compile(r"-?(?:0|[1-9][0-9]*)")
#: A line that is not a number nor empty, in a CSV column's cells joined by newlines.
_NOT_NUMBER = re.compile(rf"^(?!(?:{_NUMBER})?$)", re.M)
#: An integer cell of 19 digits or more, in such a column (it may not fit in 64 bits).
_LONG_INTEGER = re.compile(r"(?:^|\n)-?[0-9]{19,}(?=\n|$)")
#: A line that is not blank, from its first character that is not a space.
_LINE = re.compile(r"\S[^\n]*")

#: Integers of more digits are refused unread (int64 holds 19).
_MOST_DIGITS = 19

_EXPECTED_VALUE = "expected a finite number, true, false or null"


class _Refused(Exception):
    """What is wrong with a history file (``line``: where, when it is one line)."""

    def __init__(self, message: str, line: int | None = None) -> None:
        super().__init__(message)
        self.message, self.line = message, line


def read_history(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """The history a run saved (``--history FILE.jsonl`` or ``FILE.csv``) as columns, one numpy
    array per field in the file's order, as :attr:`cehmm.OptimizeResult.history` has them:
    ``int64`` for integers, ``bool`` for flags, ``float64`` for the rest (a missing value NaN).

    Raises:
        InvalidArgumentError: not a ``.jsonl`` or ``.csv`` file, not a regular file (a directory,
            a device, a FIFO), over :data:`MAX_HISTORY_BYTES`, or not a history (module docs);
            the message names the file, the line and what was expected.
        OSError: the file cannot be opened (``FileNotFoundError``, ``PermissionError``).

    Example:
        >>> with open("run.jsonl", "w", encoding="utf-8") as f:
        ...     _ = f.write('{"iteration": 0, "mean": 1.5, "successful": true}\\n'
        ...                 '{"iteration": 1, "mean": null, "successful": false}\\n')
        >>> cehmm.plots.read_history("run.jsonl")
        {'iteration': array([0, 1]), 'mean': array([1.5, nan]), 'successful': array([ True, False])}
        >>> with open("run.csv", "w", encoding="utf-8") as f:
        ...     _ = f.write("iteration,mean\\n0,1.5\\n1,2\\n")
        >>> cehmm.plots.read_history("run.csv")["mean"]
        array([1.5, 2. ])
    """
    shown = os.fsdecode(path)
    suffix = Path(shown).suffix
    if suffix not in (".jsonl", ".csv"):
        raise _core.InvalidArgumentError(f"invalid history file: {shown} (expected a .jsonl or .csv file)")
    data = read_bytes(path, MAX_HISTORY_BYTES, "history file")
    try:
        return _parse(data, suffix)
    except _Refused as e:
        where = "" if e.line is None else f" line {e.line}"
        raise _core.InvalidArgumentError(f"invalid history file: {shown}{where}: {e.message}") from None


def _parse(data: bytes, suffix: str, fast: bool = True) -> dict[str, np.ndarray]:
    """The columns of a history file's bytes (``suffix``: ``".jsonl"`` or ``".csv"``): by the
    fast reader where it takes them (unless ``fast`` is false), else by the checked one.

    Raises:
        _Refused: what is wrong, and the line.
    """
    text = _text(data)
    columns = _fast(text, suffix) if fast else None
    return columns if columns is not None else _checked(text, suffix)


def _text(data: bytes) -> str:
    """The file's text (UTF-8; a byte-order mark first is left out)."""
    try:
        return data.decode("utf-8").removeprefix("\ufeff")
    except UnicodeDecodeError as e:
        line = data.count(b"\n", 0, e.start) + 1
        column = e.start - (data.rfind(b"\n", 0, e.start) + 1) + 1
        message = f"byte {data[e.start]:#04x} at column {column} is not UTF-8 (expected UTF-8 text)"
        raise _Refused(message, line) from None


def _shown(text: str, most: int = 40) -> str:
    """``text`` cut to ``most`` characters (an error quotes what it found, never megabytes)."""
    return text if len(text) <= most else text[:most] + f"… ({len(text)} characters)"


def _checked_fields(fields: Sequence[str], where: str) -> None:
    """Refuses a first record or header without the required fields, or with too many."""
    missing = [f for f in REQUIRED if f not in fields]
    if missing:
        raise _Refused(
            f"no {' and no '.join(repr(f) for f in missing)} field in {where} (expected {' and '.join(REQUIRED)} at "
            f"least, as --history writes them; found {_shown(', '.join(fields), 80) or 'none'})"
        )
    if len(fields) > MAX_FIELDS:
        raise _Refused(f"{len(fields)} fields in {where} (expected at most {MAX_FIELDS})")


# -- the fast reader ---------------------------------------------------------------------------

#: The longest CSV cell the fast reader takes.
_LONGEST_CELL = 4000

#: Records converted at a time (memory stays a few arrays per field, whatever the file's size).
_CHUNK = 1 << 15


def _fast(text: str, suffix: str) -> dict[str, np.ndarray] | None:
    """The columns, or ``None`` at the first thing out of the plain case (the checked reader
    then says what)."""
    try:
        fields, chunks = _fast_json(text) if suffix == ".jsonl" else _fast_csv(text)
        if fields is None:
            return None
        convert = _fast_json_column if suffix == ".jsonl" else _fast_csv_column
        pieces: list[list[np.ndarray]] = [[] for _ in fields]
        for chunk in chunks:
            if chunk is None:
                return None
            for piece, column in zip(pieces, chunk):
                array = convert(column)
                if array is None:
                    return None
                piece.append(array)
        if not pieces[0]:
            return None
        out = {}
        for field, piece in zip(fields, pieces):
            flags = [p.dtype == bool for p in piece]
            if any(flags) and not all(flags):
                return None
            # Integers where every chunk has them, else numbers (as the checked reader's arrays).
            out[field] = np.concatenate(piece)
    except Exception:  # noqa: BLE001 - anything unplanned: the checked reader decides
        return None
    iteration, mean = out["iteration"], out["mean"]
    if iteration.dtype != np.int64 or (iteration < 0).any() or mean.dtype == bool:
        return None
    return out


def _no_constant(text: str) -> Any:
    raise ValueError(text)


#: JSON as Python reads it, but for NaN and Infinity (the checked reader names them).
_PLAIN = json.JSONDecoder(parse_constant=_no_constant)

_Chunks = Iterator["list[Sequence[Any]] | None"]


def _fast_json(text: str) -> tuple[list[str] | None, _Chunks]:
    """The first record's fields and the records' columns, a chunk at a time (``None``: a line
    out of the plain case)."""
    lines = (m.group() for m in _LINE.finditer(text))
    first = next(lines, None)
    if first is None:
        return None, iter(())
    record = _PLAIN.decode(first)
    if type(record) is not dict or any(f not in record for f in REQUIRED) or len(record) > MAX_FIELDS:
        return None, iter(())
    fields = list(record)
    getters = [operator.itemgetter(f) for f in fields]

    def chunks() -> _Chunks:
        pending: Iterator[str] = itertools.chain([first], lines)
        while True:
            records = list(map(_PLAIN.decode, itertools.islice(pending, _CHUNK)))
            if not records:
                return
            if set(map(type, records)) != {dict} or set(map(len, records)) != {len(fields)}:
                yield None
                return
            yield [list(map(get, records)) for get in getters]

    return fields, chunks()


def _fast_json_column(column: list[Any]) -> np.ndarray | None:
    kinds = set(map(type, column))
    if kinds == {bool}:
        return np.array(column, dtype=bool)
    if kinds == {int}:
        return np.array(column, dtype=np.int64)
    if kinds <= {int, float, type(None)}:
        if int in kinds and any(not -(2**63) <= v < 2**63 for v in column if type(v) is int):
            return None
        array = np.array(column, dtype=np.float64)
        return None if np.isinf(array).any() else array
    return None


def _fast_csv(text: str) -> tuple[list[str] | None, _Chunks]:
    """The header's fields and the rows' columns, a chunk at a time (``None``: a row out of the
    plain case)."""
    rows: Iterator[list[str]]
    if '"' in text or "\r" in text:
        rows = filter(None, csv.reader(io.StringIO(text, newline=""), strict=True))
    else:
        # Without quotes or carriage returns, the csv module's rows are the lines that are not
        # empty, its cells what lies between commas: split so, a piece of the text at a time.
        rows = (line.split(",") for piece in _pieces(text) for line in piece)
    header = next(rows, None)
    if header is None or "" in header or len(set(header)) < len(header):
        return None, iter(())
    if any(f not in header for f in REQUIRED) or len(header) > MAX_FIELDS:
        return None, iter(())
    width = len(header)

    def chunks() -> _Chunks:
        if '"' in text or "\r" in text:
            while chunk := list(itertools.islice(rows, _CHUNK)):
                if set(map(len, chunk)) != {width}:
                    yield None
                    return
                yield list(zip(*chunk))
            return
        for piece in _pieces(text, after=header):
            if set(map(operator.methodcaller("count", ","), piece)) != {width - 1}:
                yield None
                return
            cells = ",".join(piece).split(",")
            yield [cells[k::width] for k in range(width)]

    return header, chunks()


def _pieces(text: str, after: list[str] | None = None) -> Iterator[list[str]]:
    """The lines of ``text`` that are not empty, a list per megabyte or so; ``after``: those
    after the first line that is not empty (a header, given as its cells)."""
    start, skip = 0, after is not None
    while start < len(text):
        end = text.find("\n", start + (1 << 20))
        end = len(text) if end < 0 else end
        lines = list(filter(None, text[start:end].split("\n")))
        start = end + 1
        if skip and lines:
            lines, skip = lines[1:], False
        if lines:
            yield lines


def _fast_csv_column(column: Sequence[str]) -> np.ndarray | None:
    if max(map(len, column)) > _LONGEST_CELL:
        return None  # the csv module's field size limit is the checked reader's to apply
    if column[0] in ("true", "false") and set(column) <= {"true", "false"}:
        return np.array([c == "true" for c in column], dtype=bool)
    joined = "\n".join(column)
    if joined.count("\n") != len(column) - 1 or _NOT_NUMBER.search(joined):
        return None
    if not any(c in joined for c in ".eE") and "" not in column:
        return np.array(list(map(int, column)), dtype=np.int64)
    if _LONG_INTEGER.search(joined):
        return None
    array = np.array(list(map(float, [c or "nan" for c in column])), dtype=np.float64)
    return None if np.isinf(array).any() else array


# -- the checked reader ------------------------------------------------------------------------


def _checked(text: str, suffix: str) -> dict[str, np.ndarray]:
    """The columns, or the first error of the file, line by line."""
    columns = _Columns()
    for line, record in _json_lines(text) if suffix == ".jsonl" else _csv_rows(text):
        try:
            columns.add(record, line)
        except _Refused as e:
            raise _Refused(e.message, line) from None
    if columns.count == 0:
        raise _Refused("no record (expected a line per iteration, as --history writes)")
    return columns.arrays()


def _int(text: str) -> int:
    if len(text.lstrip("-")) > _MOST_DIGITS:
        raise _Refused(f"the integer {_shown(text)} is out of range (expected at most {_MOST_DIGITS} digits)")
    return int(text)


def _float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise _Refused(f"the number {_shown(text)} is out of a float's range ({_EXPECTED_VALUE})")
    return value


def _constant(text: str) -> Any:
    raise _Refused(f"{text} ({_EXPECTED_VALUE})")


_DECODER = json.JSONDecoder(parse_int=_int, parse_float=_float, parse_constant=_constant)


def _json_lines(text: str) -> Iterator[tuple[int, dict[str, Any]]]:
    """``(line, record)`` per line of JSON text that is not blank."""
    number, at = 1, 0
    for match in _LINE.finditer(text):
        number += text.count("\n", at, match.start())
        at = match.start()
        line = match.group()
        try:
            record = _DECODER.decode(line)
        except json.JSONDecodeError as e:
            column = e.colno + at - (text.rfind("\n", 0, at) + 1)
            raise _Refused(f"{e.msg} at column {column} (expected a JSON object per line)", number) from None
        except RecursionError:
            raise _Refused("nested too deep to read (expected a flat JSON object per line)", number) from None
        except _Refused as e:
            raise _Refused(e.message, number) from None
        if not isinstance(record, dict):
            raise _Refused(
                f"{_shown(line.strip())} is not a JSON object (expected one record per line, "
                '{"iteration": ..., "mean": ..., ...})',
                number,
            )
        yield number, record


def _csv_rows(text: str) -> Iterator[tuple[int, dict[str, Any]]]:
    """``(line, record)`` per CSV row after the header that is not blank."""
    reader = csv.reader(io.StringIO(text, newline=""), strict=True)
    header: list[str] | None = None
    while True:
        try:
            row = next(reader, None)
            if row is None:
                return
            if not row:
                continue
            if header is None:
                header = _header(row)
                continue
            if len(row) != len(header):
                raise _Refused(
                    f"{len(row)} field{'s' * (len(row) != 1)} where the header has {len(header)} "
                    f"(expected one per header field: {_shown(','.join(header), 120)})"
                )
            record = {name: _cell(name, cell) for name, cell in zip(header, row)}
        except csv.Error as e:
            raise _Refused(f"{e} (expected CSV as --history writes it)", reader.line_num) from None
        except _Refused as e:
            raise _Refused(e.message, reader.line_num) from None
        yield reader.line_num, record


def _header(row: list[str]) -> list[str]:
    """The field names of a CSV header, each given once and none empty."""
    seen: set[str] = set()
    for name in row:
        if not name:
            raise _Refused(f"an empty field name in the header {_shown(','.join(row))} (expected a name per field)")
        if name in seen:
            raise _Refused(f"field {_shown(name)!r} twice in the header (expected each field once)")
        seen.add(name)
    _checked_fields(row, "the header")
    return row


def _cell(name: str, cell: str) -> Any:
    """A CSV cell as the JSON value it was written from (a number, true, false; empty: null)."""
    if cell == "":
        return None
    if cell in ("true", "false"):
        return cell == "true"
    if _INTEGER_CELL.fullmatch(cell):
        return _int(cell)
    if _NUMBER_CELL.fullmatch(cell):
        return _float(cell)
    raise _Refused(f"field {_shown(name)!r} is {_shown(cell)!r} ({_EXPECTED_VALUE}, or an empty cell)")


class _Columns:
    """The records gathered field by field, each value checked on the way: a field holds flags
    (``true``, ``false``) or numbers (null among them), not both; integers fit in 64 bits."""

    def __init__(self) -> None:
        self.values: dict[str, list[Any]] = {}
        #: Per field, whether it holds flags, and the line that says so.
        self.kinds: dict[str, tuple[bool, int]] = {}
        self.count = 0

    def add(self, record: dict[str, Any], line: int) -> None:
        if not self.count:
            _checked_fields(list(record), "the first record")
            self.values = {f: [] for f in record}
        elif record.keys() != self.values.keys():
            lost = [f for f in self.values if f not in record]
            new = [f for f in record if f not in self.values]
            parts = [f"no {_shown(', '.join(lost), 80)}"] if lost else []
            parts += [f"{_shown(', '.join(new), 80)} added"] if new else []
            raise _Refused(f"{'; '.join(parts)} (expected the fields of the first record on every line)")
        for field, value in record.items():
            if value is not None and not isinstance(value, (bool, int, float)):
                shown = _shown(json.dumps(value) if isinstance(value, (list, dict)) else repr(value))
                raise _Refused(f"field {_shown(field)!r} is {shown} ({_EXPECTED_VALUE})")
            if isinstance(value, int) and not isinstance(value, bool) and not -(2**63) <= value < 2**63:
                raise _Refused(f"field {_shown(field)!r} is {value}, out of range (expected a 64-bit integer)")
            flag = isinstance(value, bool)
            kind = self.kinds.setdefault(field, (flag, line))
            if kind[0] != flag and (value is not None or kind[0]):
                had = "true or false" if kind[0] else "a number"
                raise _Refused(
                    f"field {_shown(field)!r} is {json.dumps(value)} where line {kind[1]} has {had} "
                    "(expected flags or numbers in a field, not both)"
                )
        iteration, mean = record["iteration"], record["mean"]
        if isinstance(iteration, bool) or not isinstance(iteration, int) or iteration < 0:
            raise _Refused(f"field 'iteration' is {json.dumps(iteration)} (expected an integer, 0 or more)")
        if isinstance(mean, bool):
            raise _Refused(f"field 'mean' is {json.dumps(mean)} (expected a finite number or null)")
        for field, value in record.items():
            self.values[field].append(value)
        self.count += 1

    def arrays(self) -> dict[str, np.ndarray]:
        """One array per field: bool for flags, int64 where every value is an integer, else
        float64 (null as NaN)."""
        out: dict[str, np.ndarray] = {}
        for field, values in self.values.items():
            if self.kinds[field][0]:
                out[field] = np.array(values, dtype=bool)
            elif all(isinstance(v, int) for v in values):
                out[field] = np.array(values, dtype=np.int64)
            else:
                out[field] = np.array([math.nan if v is None else v for v in values], dtype=np.float64)
        return out
