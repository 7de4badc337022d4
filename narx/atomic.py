"""Atomic file writes: a reader sees the old file or the new one, never half.

Typical use::

    from narx.atomic import atomic_writer
    with atomic_writer("model.json") as fh:
        fh.write(text)

The text goes to a temporary file in the destination folder, is flushed and
fsync'ed, then moved over the destination with ``os.replace`` (atomic on
POSIX and Windows). On any exception the temporary file is removed and the
destination is untouched.
"""
from __future__ import annotations

import contextlib
import os
import tempfile

__all__ = ["atomic_writer", "atomic_write_text", "check_writable"]


def check_writable(path, what: str = "output") -> None:
    """Raise ``ValueError`` naming ``path`` when a file
    cannot be written there: a directory in the way, a missing or
    unwritable folder. Call it before long work, so the work is not lost."""
    path = os.fspath(path)
    if os.path.isdir(path):
        raise ValueError(f"{what} {path}: is a directory, not a file name")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise ValueError(f"{what} {path}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ValueError(f"{what} {path}: folder {folder} is not writable")


@contextlib.contextmanager
def atomic_writer(path, newline=None, encoding="utf-8"):
    path = os.fspath(path)
    check_writable(path)
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", dir=folder)
    try:
        # mkstemp creates 0600; give the file the permissions open() would
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        with os.fdopen(fd, "w", newline=newline, encoding=encoding) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def atomic_write_text(path, text: str) -> None:
    with atomic_writer(path) as fh:
        fh.write(text)
