"""The machine's C compiler: where it is looked for, and shared libraries built from generated C once per source.

Three users: the FMU exporter (:mod:`acausal.export.fmu`, which turns a missing compiler into an error saying what
to install), the native fixed step (:mod:`acausal.simulation.compiled.native`, which falls back to CasADi's virtual
machine without one) and the native loop (:mod:`acausal.simulation.compiled.native_loop`, which falls back to CasADi's
integrators); the last two through :func:`try_shared_library`. A library built here is cached on disk under the SHA-256
of its source, compiler and flags (:func:`cache_dir`), so each source is compiled once per machine, not once per
process: a process pool's workers that replay the same model load the same file.
"""
from __future__ import annotations

import functools
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

#: C compilers looked for, in order, when neither the caller nor the ``CC`` environment variable names one
COMPILERS = ("cc", "gcc", "clang")


def which_compiler(compiler: str | None = None) -> tuple:
    """``(path or None, what was looked for)``: ``compiler``, else ``$CC``, else the first of :data:`COMPILERS` on
    the PATH. The second item names the origin of a compiler that was asked for and not found (``"compiler="`` or
    ``"the CC environment variable"``), or is None when the search was the default one. Looked up once per
    compiler, ``$CC`` and ``$PATH`` (every compiled run asks)."""
    return _which(compiler, os.environ.get("CC"), os.environ.get("PATH"))


@functools.lru_cache(maxsize=16)
def _which(compiler, cc, search_path) -> tuple:
    wanted = compiler or cc
    if wanted:
        return shutil.which(wanted, path=search_path), ("compiler=" if compiler else "the CC environment variable")
    for name in COMPILERS:
        found = shutil.which(name, path=search_path)
        if found:
            return found, None
    return None, None


def cache_dir() -> Path:
    """Where built libraries are kept: ``$ACAUSAL_CACHE_DIR``, else ``$XDG_CACHE_HOME/acausal``, else
    ``~/.cache/acausal`` (each with a ``native/`` folder); a folder in the system's temporary directory where that
    cannot be created. Deleting it is always safe (the libraries are rebuilt on first use)."""
    base = os.environ.get("ACAUSAL_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "acausal")
    folder = Path(base) / "native"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        if os.access(folder, os.W_OK):
            return folder
    except OSError:
        pass
    folder = Path(tempfile.gettempdir()) / f"acausal-native-{os.getuid() if hasattr(os, 'getuid') else 0}"
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def library_form() -> tuple:
    """``(file suffix, link flags)`` of a shared library on this system: ``.dylib`` and ``-dynamiclib`` on macOS,
    ``.so`` and ``-shared`` elsewhere."""
    return (".dylib", ("-dynamiclib",)) if sys.platform == "darwin" else (".so", ("-shared",))


class BuildError(RuntimeError):
    """A shared library could not be built (no compiler, or the compiler refused the source: its message)."""


def shared_library(source: str, flags=("-O1",), compiler: str | None = None, libs=()) -> Path:
    """The shared library built from C ``source`` with ``flags``, linked with ``libs`` (``-l`` options, after the
    source) (cached by content: :func:`cache_dir`). Raises
    :class:`BuildError` without a compiler or when it fails. Written to a temporary name and moved into place,
    so processes building the same source at once do not read a half-written file."""
    cc, origin = which_compiler(compiler)
    if cc is None:
        raise BuildError(f"no C compiler found ({origin or 'looked for $CC, ' + ', '.join(COMPILERS)})")
    suffix, link = library_form()
    cmd = [cc, *link, "-fPIC", *flags]
    key = hashlib.sha256("\0".join([*cmd, *libs, source]).encode()).hexdigest()[:32]
    folder = cache_dir()
    lib = folder / f"{key}{suffix}"
    if lib.exists():
        return lib
    fd, tmp = tempfile.mkstemp(suffix=".c", dir=folder)
    with os.fdopen(fd, "w") as fh:
        fh.write(source)
    out = tmp[:-2] + suffix
    try:
        run = subprocess.run([*cmd, "-o", out, tmp, *libs, "-lm"], capture_output=True, text=True, timeout=300)
        if run.returncode != 0:
            raise BuildError(f"{cc} failed (exit status {run.returncode}): {(run.stderr or run.stdout)[-800:]}")
        os.replace(out, lib)
    except (OSError, subprocess.SubprocessError) as exc:
        raise BuildError(f"{cc} could not be run: {exc}") from None
    finally:
        for leftover in (tmp, out):
            if os.path.exists(leftover):
                os.remove(leftover)
    return lib


def try_shared_library(source: str, flags=("-O1",), libs=()) -> tuple:
    """``(library path, None)`` of :func:`shared_library`, or ``(None, why)`` where no C compiler is found or it
    refuses the source. A refusal is remembered per compiler, options and source: not tried again in this process
    (the callers fall back to a path without compiled code)."""
    cc = which_compiler()[0]
    if cc is None:
        return None, "no C compiler found"
    key = (cc, tuple(flags), tuple(libs), hashlib.sha256(source.encode()).hexdigest())
    if key not in _REFUSED:
        try:
            return shared_library(source, flags, libs=libs), None
        except BuildError as exc:
            _REFUSED[key] = str(exc)
    return None, _REFUSED[key]


_REFUSED: dict = {}  # (compiler, flags, libraries, source digest) -> why the compiler refused it
