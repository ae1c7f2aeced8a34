"""What every optimiser's Python front runs inside, :func:`driven`: its callbacks made the engine's
per-iteration hook; their files held with the run's checkpoint to the one rule of a run's outputs
before the first iteration (:func:`check_outputs`); the result given to the callbacks and the
callbacks closed without losing the result or the run's own error; and the run's signals: with a
checkpoint, SIGTERM stops the run like Ctrl-C and then ends the process (:class:`Signals`; a
signal a callback sends to its own process is seen before the next iteration by the bindings,
which run the handlers after every callback). :mod:`cehmm.callbacks`
states these rules for the user; this module is where each is kept.
"""

from __future__ import annotations

import os
import re
import signal
import stat
import tempfile
import threading
import warnings
from collections.abc import Sequence
from types import TracebackType
from typing import Any, Callable, TypeVar

from . import _core
from .callbacks import (
    PLACEHOLDERS,
    CallbackLike,
    CallbackList,
    Iteration,
    Output,
    TensorBoard,
    _answer,
    failure,
    members,
    note,
)

Result = TypeVar("Result")


def as_callback(callback: CallbackLike) -> Callable[[Iteration], bool | None] | None:
    """``callback=`` as one callable: ``None``, a callable, or a :class:`CallbackList` of a list.

    Raises:
        TypeError: anything else (the message names it).

    Example:
        >>> as_callback([print, print]).callbacks == [print, print], as_callback(None)
        (True, None)
    """
    if callback is None or callable(callback):
        return callback
    if isinstance(callback, (list, tuple)):
        return CallbackList(list(callback))
    raise TypeError(
        f"invalid callback: {callback!r} (expected a callable taking the iteration, a list of them, or None)"
    )


def driven(
    callback: CallbackLike,
    tensorboard_log: str | os.PathLike[str] | None = None,
    checkpoint: str | os.PathLike[str] | None = None,
) -> Drive:
    """The frame of one optimiser's run: ``with driven(callback, tensorboard_log, checkpoint) as
    run:`` checks them before the run (:func:`check_outputs`: the callbacks' files with the
    checkpoint), gives the engine ``run.hook`` (``None`` without a callback), and the optimiser
    returns ``run.ended(result)``. Every :class:`Callback` is closed once the block has ended.

    Raises:
        TypeError: ``callback`` is not a callable or a list of them.
        ImportError: ``tensorboard_log`` without tensorboardX.
        InvalidArgumentError, OSError: an output is refused (:func:`check_outputs`).

    Example:
        >>> with driven(lambda it: None) as run:
        ...     run.hook({"iteration": 0}, None)
        True
    """
    one = as_callback(callback)
    if tensorboard_log is not None:
        board = TensorBoard(tensorboard_log)
        one = board if one is None else CallbackList([one, board])
    return Drive(one, checkpoint)


class Drive:
    """One run's callbacks and signals (:func:`driven`)."""

    def __init__(self, one: Callable[[Iteration], bool | None] | None, checkpoint: Any) -> None:
        self._one = one
        self._callbacks = members(one)
        runs = [] if checkpoint is None else [Output("checkpoint", os.fspath(checkpoint))]
        check_outputs(runs + [Output(*o) for c in self._callbacks for o in c.outputs()])
        self._checkpointed = checkpoint is not None
        self._signals: Signals | None = None
        self.hook = None if one is None else self._hook

    def __enter__(self) -> Drive:
        self._signals = Signals(self._checkpointed)
        return self

    def _hook(self, record: dict[str, Any], policy: _core.Policy | None) -> bool:
        assert self._one is not None
        return _answer(self._one, self._one(Iteration(record, policy)))

    def ended(self, result: Result) -> Result:
        """``result``, given to every callback first (what one raises is a warning)."""
        for c in self._callbacks:
            try:
                c.on_result(result)
            except Exception as e:
                _warn(failure(c, e, "given the result"))
        return result

    def __exit__(
        self, kind: type[BaseException] | None, error: BaseException | None, traceback: TracebackType | None
    ) -> None:
        try:
            for c in self._callbacks:
                try:
                    c.close()
                except Exception as e:
                    if error is None:
                        _warn(failure(c, e, "closed"))
                    else:
                        note(error, failure(c, e, "closed"))
        finally:
            if self._signals is not None:
                self._signals.end()


def _warn(text: str) -> None:
    # The caller of the optimiser: this, Drive's method, the optimiser, its caller.
    warnings.warn(f"{text} (the run's result is returned)", RuntimeWarning, stacklevel=4)


class Signals:
    """The signal handlers of one run, in the main thread. With a checkpoint, and while SIGTERM
    has its default action: SIGTERM stops the run like Ctrl-C (the checkpoint is saved) and, once
    the run is over and its callbacks closed, the process ends as SIGTERM asked, with its exit
    status. A signal a callback sends to its own process is seen before the run goes on: after
    every callback the engine has the handlers run at once (``SignalCheck`` of the bindings), so
    that it stops there, as it does for a signal from outside."""

    def __init__(self, checkpointed: bool) -> None:
        self.terminated = False
        self._previous: dict[int, Any] = {}
        if threading.current_thread() is not threading.main_thread():
            return
        if checkpointed and signal.getsignal(signal.SIGTERM) is signal.SIG_DFL:
            self._previous[signal.SIGTERM] = signal.signal(signal.SIGTERM, self._handler)

    def _handler(self, signum: int, frame: object) -> None:
        self.terminated = True
        raise KeyboardInterrupt

    def end(self) -> None:
        """Restores the handlers; ends the process if SIGTERM asked."""
        for signum, previous in self._previous.items():
            signal.signal(signum, previous)
        self._previous = {}
        if self.terminated:
            # The checkpoint is saved: now end as SIGTERM asked, with its exit status.
            os.kill(os.getpid(), signal.SIGTERM)


def check_outputs(outputs: Sequence[Output]) -> None:
    """The one rule of a run's files, before its first iteration: no output is the file of another
    (``ceworld::files::check_distinct``, links followed; a series of files, ``{iteration}`` in its
    name, by each of its names that another output takes), and each can be written
    (:func:`check_writable`, :func:`check_folder`).

    Raises:
        InvalidArgumentError: an output is another's file, or not what it should be (the message
            names it, the path, and what was expected).
        OSError: its folder cannot be written (``PermissionError``, ``FileNotFoundError``).

    Example:
        >>> check_outputs([Output("checkpoint", "run.ckpt"), Output("SaveBest path", "best-{run}.json")])
        >>> check_outputs([Output("checkpoint", "best-1.json"), Output("SaveBest path", "best-{run}.json")])
        Traceback (most recent call last):
        cehmm.InvalidArgumentError: invalid SaveBest path: best-1.json is the file that checkpoint names, ...
    """
    files = [(o.name, o.path) for o in outputs if not _series(o.path)]
    for o in outputs:
        if _series(o.path):
            folder, name = os.path.split(o.path)
            pattern = re.escape(name)
            for placeholder in PLACEHOLDERS:
                pattern = pattern.replace(re.escape(placeholder), "[0-9]+")
            for other, path in files:
                for taken in {os.path.basename(path), os.path.basename(os.path.realpath(path))}:
                    if re.fullmatch(pattern, taken):
                        _core.check_distinct([], [(other, path), (o.name, os.path.join(folder, taken))])
    _core.check_distinct([], files + [(o.name, o.path) for o in outputs if _series(o.path)])
    for o in outputs:
        if o.folder:
            check_folder(o.name, o.path)
        else:
            path = o.path
            for placeholder in PLACEHOLDERS:
                path = path.replace(placeholder, "0")
            check_writable(o.name, path)


def _series(path: str) -> bool:
    return any(p in os.path.basename(path) for p in PLACEHOLDERS)


def check_writable(name: str, path: str) -> None:
    """Refuses a file ``path`` that cannot be written: the engine's rule
    (``ceworld::files::check_writable``: links followed; it creates and removes a temporary file
    beside it), its ``OSError`` naming the output.

    Raises:
        InvalidArgumentError: ``path`` is a directory, a device or a FIFO.
        OSError: its folder is missing or cannot be written.

    Example:
        >>> check_writable("out", "new.json")
        >>> check_writable("out", "/dev/null")
        Traceback (most recent call last):
        cehmm.InvalidArgumentError: invalid out: /dev/null is not a regular file (a device, socket or pipe) ...
    """
    try:
        _core.check_writable(name, path)
    except OSError as e:
        raise type(e)(
            e.errno,
            f"invalid {name}: {path!r} cannot be written: {e.strerror} "
            "(expected a file in a folder that exists and can be written)",
            e.filename,
        ) from None


def check_folder(name: str, path: str) -> None:
    """Refuses a folder ``path`` that is not one and cannot be made (a file, a device, a FIFO, or
    under one), or cannot be written (it creates and removes a temporary file in it, or in the
    folder it would be made in).

    Raises:
        InvalidArgumentError: ``path``, or what it would be made in, is not a folder.
        OSError: that folder cannot be written.

    Example:
        >>> check_folder("tensorboard_log", "runs/new")
        >>> check_folder("tensorboard_log", "/dev/null")
        Traceback (most recent call last):
        cehmm.InvalidArgumentError: invalid tensorboard_log: '/dev/null' is a device, socket or pipe ...
    """
    target = os.path.realpath(path)
    existing = target
    while _mode(existing) is None and os.path.dirname(existing) != existing:
        existing = os.path.dirname(existing)
    mode = _mode(existing)
    if mode is not None and not stat.S_ISDIR(mode):
        where = "is" if existing == target else f"cannot be made: {existing!r} is"
        raise _core.InvalidArgumentError(
            f"invalid {name}: {path!r} {where} {_kind(mode)} (expected a folder that exists or can be made)"
        )
    _probe(name, path, existing, "a folder that exists or can be made, and can be written")


def _mode(path: str) -> int | None:
    try:
        return os.stat(path).st_mode
    except OSError:
        return None


def _kind(mode: int) -> str:
    return "a directory" if stat.S_ISDIR(mode) else "a file" if stat.S_ISREG(mode) else "a device, socket or pipe"


def _probe(name: str, path: str, folder: str, expected: str) -> None:
    """Creates and removes a temporary file in ``folder``, or raises the ``OSError`` naming ``path``."""
    try:
        fd, probe = tempfile.mkstemp(prefix=".cehmm-probe.", suffix=".tmp", dir=folder or ".")
    except OSError as e:
        raise type(e)(
            e.errno, f"invalid {name}: {path!r} cannot be written: {e.strerror} (expected {expected})", path
        ) from None
    os.close(fd)
    os.unlink(probe)
