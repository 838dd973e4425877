"""Output folders of the ``ismpc`` commands and how a command stops when asked to.

:func:`open_output_dir` checks the ``--out`` folder before anything is simulated (it can be
created and written, it is empty unless ``--overwrite``), locks it against a second ``ismpc``
writing there at the same time (``fcntl.flock`` on ``OUT/.lock``, released when the process ends,
even by SIGKILL) and removes the temporary files an earlier, killed process left behind
(:func:`robust_ismpc.io.is_temporary`).

:class:`Interrupts` turns SIGINT (Ctrl-C) and SIGTERM into a request that the simulation loops
honour at the end of a tick, so that the part of a run that finished is written; a second signal
stops at once.
"""

from __future__ import annotations

import errno
import fcntl
import os
import signal
import threading
from pathlib import Path

from ..exceptions import ParameterError
from ..io import is_temporary

#: Name of the lock file inside an output folder.
LOCK_NAME = ".lock"


def is_scratch(name: str) -> bool:
    """Files that do not make a folder "not empty": the lock and temporary leftovers."""
    return name == LOCK_NAME or is_temporary(name)


class OutputDir:
    """A locked output folder (use :func:`open_output_dir`).

    Attributes
    ----------
    path : Path
        The folder.
    created : bool
        True if :func:`open_output_dir` created it (then :meth:`release` removes it again when
        nothing was written into it).
    """

    def __init__(self, path: Path, fd: int, created: bool) -> None:
        self.path = path
        self.created = created
        self._fd: int | None = fd

    def outputs(self) -> list[Path]:
        """Files and folders in the output folder, without the lock and temporary files."""
        return sorted(p for p in self.path.iterdir() if not is_scratch(p.name))

    def release(self) -> None:
        """Remove the lock (and the folder, if this process created it and left it empty)."""
        if self._fd is None:
            return
        try:
            (self.path / LOCK_NAME).unlink(missing_ok=True)
        finally:
            os.close(self._fd)  # closing releases the flock
            self._fd = None
        if self.created:
            try:
                self.path.rmdir()
            except OSError:
                pass  # not empty: outputs were written

    def __enter__(self) -> OutputDir:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


def _lock(path: Path, flag: str, text: str) -> int:
    """Open and flock ``path/.lock``; the descriptor holds the lock."""
    lock_path = path / LOCK_NAME
    while True:
        try:
            fd = os.open(lock_path, os.O_RDWR | os.O_CREAT, 0o666)
        except OSError as exc:
            raise ParameterError(
                f"{flag} {text!r} is not writable ({exc.strerror}); choose a folder you can write to"
            ) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            holder = os.read(fd, 32).decode(errors="replace").strip() or "?"
            os.close(fd)
            if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise ParameterError(
                    f"{flag} {text!r} is in use by another ismpc process (pid {holder}); wait for it to "
                    f"finish or choose another {flag}"
                ) from None
            raise ParameterError(f"{flag} {text!r}: cannot lock it ({exc.strerror})") from None
        # The holder may have removed the file between our open and flock: lock the current one.
        try:
            same = os.stat(lock_path).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
            return fd
        os.close(fd)


def open_output_dir(text: str, overwrite: bool = False, flag: str = "--out", require_empty: bool = True) -> OutputDir:
    """Check, create and lock the output folder named by ``text`` (the value of ``flag``).

    Parameters
    ----------
    text : str
        The folder as the user gave it.
    overwrite : bool
        Allow a folder that already holds files.
    flag : str
        Command-line flag named in the messages.
    require_empty : bool
        Refuse a non-empty folder unless ``overwrite`` (False: the caller judges its contents,
        e.g. a sweep that resumes).

    Raises
    ------
    ParameterError
        Empty name; a file, or a location that cannot be created or written; a folder in use by
        another process; a non-empty folder without ``overwrite``. One line naming ``flag``.
    """
    if not isinstance(text, str) or not text.strip():
        raise ParameterError(f"{flag} is empty; name a folder for the outputs, e.g. {flag} runs/demo")
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise ParameterError(f"{flag} {text!r} exists and is not a directory; choose a folder")
    created = not path.exists()
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ParameterError(
            f"{flag} {text!r}: cannot create this folder ({exc.strerror}); choose a location you can write to"
        ) from None
    try:
        out = OutputDir(path, _lock(path, flag, text), created)
    except ParameterError:
        if created:
            path.rmdir()
        raise
    try:
        leftovers = [p for p in path.iterdir() if is_temporary(p.name)]
        if require_empty and not overwrite and out.outputs():
            raise ParameterError(f"{flag} {text!r} exists and is not empty; pass --overwrite to write into it")
        for stale in leftovers:  # from a process killed while writing; we hold the lock
            stale.unlink(missing_ok=True)
    except BaseException:
        out.release()
        raise
    return out


class Interrupts:
    """SIGINT and SIGTERM handling of a command.

    Parameters
    ----------
    deferred : bool
        True: the first signal is only noted (:attr:`requested`) and :meth:`check`, called by the
        simulation's progress callback once per simulated second, raises ``KeyboardInterrupt``
        there, at a tick boundary; the loops then return what ran. A second signal raises at
        once. False: both signals raise ``KeyboardInterrupt`` at once (SIGTERM like Ctrl-C).
    """

    def __init__(self, deferred: bool = True) -> None:
        self.deferred = deferred
        self.count = 0
        self._previous: dict[int, object] = {}

    @property
    def requested(self) -> bool:
        """True once a signal arrived."""
        return self.count > 0

    def _handle(self, signum: int, frame: object) -> None:
        self.count += 1
        if not self.deferred or self.count > 1:
            raise KeyboardInterrupt

    def check(self) -> None:
        """Raise ``KeyboardInterrupt`` if a signal arrived."""
        if self.requested:
            raise KeyboardInterrupt

    def install(self) -> Interrupts:
        """Install the handlers (main thread only; elsewhere this does nothing)."""
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def restore(self) -> None:
        """Put the previous handlers back."""
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        self._previous.clear()
