"""Atomic file writes: a killed run never leaves a half-written file that looks complete."""

from __future__ import annotations

import json
import os
import re
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import tomli_w

# mkstemp creates files readable by the owner only; results should honour the umask.
_UMASK = os.umask(0)
os.umask(_UMASK)


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; move it into place only on success."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        os.chmod(tmp_path, 0o666 & ~_UMASK)
        os.replace(tmp_path, path)
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


# Characters a file name made from user text may keep: no separators, no ".." path parts.
_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")


def safe_filename(name: str, fallback: str = "output") -> str:
    """``name`` made into one plain file name that stays in the directory it is put in.

    Runs of other characters than letters, digits, ``.``, ``_`` and ``-`` (path
    separators included) become ``-``; leading dots and dashes go (no hidden
    files, no ``..``, nothing read as an option). A name with nothing left
    becomes ``fallback``. ``"../../x"`` -> ``"x"``, ``"/etc/passwd"`` -> ``"etc-passwd"``.
    """
    cleaned = _UNSAFE.sub("-", name).lstrip(".-").rstrip("-")
    return cleaned[:200] or fallback


def write_atomic(path: str | Path, writer: Callable[[Path], Any]) -> Path:
    """Call ``writer(tmp_path)`` and atomically move the result to ``path``."""
    with atomic_path(path) as tmp:
        writer(tmp)
    return Path(path)


def write_text(path: str | Path, text: str) -> Path:
    return write_atomic(path, lambda p: p.write_text(text, encoding="utf-8"))


def write_json(path: str | Path, data: Any) -> Path:
    return write_text(path, json.dumps(data, indent=2, sort_keys=False) + "\n")


def write_toml(path: str | Path, data: dict[str, Any]) -> Path:
    return write_text(path, tomli_w.dumps(data))


def write_csv(path: str | Path, rows: list[dict[str, Any]], columns: list[str]) -> Path:
    """Write rows (dicts) as CSV with a fixed column order, atomically."""
    import csv
    import io

    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return write_text(path, buffer.getvalue())


class DirectoryBusy(OSError):
    """Another process holds the lock of a directory."""


@contextmanager
def directory_lock(directory: str | Path, name: str = "run.lock") -> Iterator[Path]:
    """Hold an exclusive ``flock`` on ``directory/name`` (created, with the directory).

    The lock belongs to the open file, so the kernel drops it when the process
    dies, even by ``kill -9``: a stale lock file never blocks a later run. Raises
    :class:`DirectoryBusy` at once (no waiting) if another process holds it, and
    the ``OSError`` of ``mkdir``/``open`` if the directory cannot be made.
    """
    import fcntl

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / name
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666 & ~_UMASK)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise DirectoryBusy(f"{directory} is in use by another process "
                                f"(it holds {path})") from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())  # who holds it, for a person to read
        yield path
    finally:
        os.close(fd)  # closing drops the lock
