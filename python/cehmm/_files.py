"""Files written safely, by the rules of the engine's ``ceworld::files``: a fresh temporary file in
the target's folder (created exclusively, so concurrent writers never share one), flushed and
synced, then renamed over the target, so that a reader sees the old file or the new one, whole.
A target that exists and is not a regular file (a directory, a device, a pipe) is refused; a
symbolic link is written through (the file it points to is replaced, the link stays). Files are
read by the engine's bounded read (:func:`read_bytes`), as the engine reads its own."""

from __future__ import annotations

import os
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

from . import _core


def write_atomic(
    path: Path, write: Callable[[IO[Any]], None], *, binary: bool = False, newline: str | None = None
) -> None:
    """Writes ``path`` through ``write(file)`` on a temporary file, synced, then renamed over it.

    Raises:
        IsADirectoryError: ``path`` is a directory.
        OSError: ``path`` exists and is not a regular file, or the folder cannot be written.
    """
    target = Path(os.path.realpath(path))
    try:
        mode = os.stat(target).st_mode
    except FileNotFoundError:
        mode = None
    if mode is not None and not stat.S_ISREG(mode):
        if stat.S_ISDIR(mode):
            raise IsADirectoryError(f"{path} is a directory (expected a regular file to write, or a new name)")
        raise OSError(f"{path} is not a regular file (a device, socket or pipe): refused")
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    try:
        with os.fdopen(fd, "wb" if binary else "w", newline=newline) as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_text(path: Path, text: str) -> None:
    """:func:`write_atomic` of ``text``."""
    write_atomic(path, lambda f: f.write(text))


#: The most bytes read of a text file the package's tools take (a preset, records, a list of
#: sources): 256 MiB.
MAX_TEXT_BYTES = 256 << 20


def read_bytes(path: str | os.PathLike[str], max_bytes: int, what: str) -> bytes:
    """The bytes of the regular file ``path``, read by the engine (``ceworld::files::read_limited``):
    a directory, a device (``/dev/zero``), a FIFO (at once, without waiting for a writer), a link
    to one, or a file of more than ``max_bytes`` is refused; ``what`` names the file in the error.

    Raises:
        InvalidArgumentError: not a regular file, or more than ``max_bytes``; the message names
            ``what``, the path as given (and where its links lead) and the limit.
        OSError: the file cannot be opened (``FileNotFoundError``, ``PermissionError``).
    """
    return _core.read_file(path, max_bytes, what)
