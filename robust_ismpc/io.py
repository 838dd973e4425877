"""Files: atomic output (a reader never sees a half-written file, even after an interrupt) and
JSON input with one error for every way a file can be unreadable.

Every file is written to a hidden temporary file in the same folder, ``.NAME.XXXX.tmp``, then
renamed. A process killed between the two (SIGKILL, power loss) leaves that temporary file
behind; :func:`is_temporary` recognises it, so that an output folder holding only such
leftovers counts as empty and a rerun can remove them.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

from .exceptions import ParameterError

#: Suffix of the temporary files written by :func:`atomic_write_bytes` (and the video writer).
TEMP_SUFFIX = ".tmp"


def temporary_path(path: Path) -> Path:
    """A hidden temporary name beside ``path`` that :func:`is_temporary` recognises, keeping the
    suffix (``out/video.mp4`` -> ``out/.video.mp4.<pid>.tmp.mp4``, for writers that choose the
    format by extension)."""
    path = Path(path)
    return path.with_name(f".{path.name}.{os.getpid()}{TEMP_SUFFIX}{path.suffix}")


def is_temporary(name: str) -> bool:
    """True for the name of a temporary file left by an interrupted atomic write."""
    return name.startswith(".") and (name.endswith(TEMP_SUFFIX) or f"{TEMP_SUFFIX}." in name)


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=TEMP_SUFFIX, dir=path.parent)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the file the usual permissions
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def atomic_write_json(path: Path, obj: Any) -> None:
    """Write ``obj`` as indented JSON atomically."""
    atomic_write_bytes(Path(path), (json.dumps(obj, indent=2, sort_keys=False) + "\n").encode())


def read_json(path: Path, required_key: str | None = None) -> Any:
    """The JSON content of ``path`` (with ``required_key``: an object that has that key).

    Raises
    ------
    ParameterError
        The file cannot be read, is not JSON, or lacks ``required_key`` (the message names the
        file and why).
    """
    try:
        with open(path, encoding="utf-8") as f:
            content = json.load(f)
    except (OSError, ValueError) as exc:
        raise ParameterError(f"cannot read {path}: {exc}") from None
    if required_key is not None and not (isinstance(content, dict) and required_key in content):
        raise ParameterError(f"{path} has no {required_key!r}: not a file this command wrote")
    return content
