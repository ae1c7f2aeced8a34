"""The Python layer writes its files (reports, tables, figures) by the engine's rules: whole or not
at all, never over what is not a regular file, through symbolic links, safe with concurrent
writers; and reads a user's files by the engine's bounded read (regular files only, of a stated
size at most)."""

from __future__ import annotations

import os
import threading
from pathlib import Path

import pytest

import cehmm
from cehmm._files import read_bytes, write_atomic, write_text


def test_a_file_is_replaced_whole_and_no_temporary_is_left(tmp_path: Path) -> None:
    path = tmp_path / "report.md"
    write_text(path, "old")
    write_text(path, "new")
    assert path.read_text() == "new"

    def fail(f: object) -> None:
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        write_atomic(path, fail)
    assert path.read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.md"]


def test_what_is_not_a_regular_file_is_refused_and_links_are_written_through(tmp_path: Path) -> None:
    with pytest.raises(IsADirectoryError):
        write_text(tmp_path, "x")
    if os.path.exists("/dev/null"):
        with pytest.raises(OSError, match="not a regular file"):
            write_text(Path("/dev/null"), "x")
        assert not Path("/dev/null").is_file()
    real = tmp_path / "real.txt"
    real.write_text("old")
    link = tmp_path / "link.txt"
    link.symlink_to(real)
    write_text(link, "new")
    assert link.is_symlink() and real.read_text() == "new"


def test_concurrent_writers_never_mix(tmp_path: Path) -> None:
    path = tmp_path / "shared.txt"
    texts = [str(k) * 50_000 for k in range(4)]
    seen: list[str] = []

    def writer(text: str) -> None:
        for _ in range(15):
            write_text(path, text)

    def reader() -> None:
        for _ in range(100):
            if path.exists():
                seen.append(path.read_text())

    threads = [threading.Thread(target=writer, args=(t,)) for t in texts] + [threading.Thread(target=reader)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert path.read_text() in texts
    assert all(s in texts for s in seen)


def test_reads_go_through_the_engines_bounded_read_of_regular_files(tmp_path: Path) -> None:
    path = tmp_path / "a.txt"
    path.write_bytes(b"abc")
    assert read_bytes(path, 3, "test file") == b"abc" == read_bytes(str(path), 3, "test file")
    with pytest.raises(cehmm.InvalidArgumentError, match=r"invalid test file: .*a\.txt has 3 bytes \(at most 2 are"):
        read_bytes(path, 2, "test file")
    with pytest.raises(cehmm.InvalidArgumentError, match=r"invalid test file: .* is a directory \(expected a file"):
        read_bytes(tmp_path, 10, "test file")
    with pytest.raises(FileNotFoundError) as missing:
        read_bytes(tmp_path / "none.txt", 10, "test file")
    assert missing.value.filename == str(tmp_path / "none.txt")
    if os.path.exists("/dev/zero"):
        with pytest.raises(cehmm.InvalidArgumentError, match="/dev/zero is not a regular file"):
            read_bytes("/dev/zero", 10, "test file")
