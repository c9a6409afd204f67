"""Atomic file writes: a file is either its old content or its complete new content, never a torn mix.

Each write goes to a temporary file in the same folder (``.NAME.tmp-PID``), is flushed to disk and then renamed over
the target (:func:`os.replace` is atomic on POSIX and Windows within one file system). An interrupted run leaves
the old file (or none) and at worst a temporary file that no loader reads (its name starts with a dot and does not
end in ``.csv``/``.json``).
"""
from __future__ import annotations

import hashlib
import os
from pathlib import Path


def atomic_write_bytes(path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (see the module docstring); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def atomic_write_text(path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def sha256(path) -> str:
    """Hex SHA-256 of a file's bytes."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()
