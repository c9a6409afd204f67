"""Classes named by reference: ``MODULE:CLASS`` (an importable module) or ``FILE.py:CLASS`` (a file of the user's).

A reference is a string, so it travels to worker processes and into JSON records, and every process resolves it
the same way (a file is loaded once per process under a name derived from its path).
"""
from __future__ import annotations

import hashlib
import importlib
import importlib.util
import os
import sys
from pathlib import Path

from .errors import ModelError


def load_class(ref: str, base: type, what: str = "class"):
    """The class ``ref`` names, which must be a subclass of ``base``; a :class:`ModelError` naming the reference
    (and the file or module) when it cannot be found, imported or is of the wrong kind. ``what`` names the
    reference in messages (e.g. ``"model"``, ``"candidate component"``)."""
    if not isinstance(ref, str):
        raise ModelError(f"{what} {ref!r}: expected a string MODULE:CLASS or FILE.py:CLASS")
    where, sep, name = ref.rpartition(":")
    if not sep or not where or not name:
        raise ModelError(f"{what} {ref!r}: expected MODULE:CLASS or FILE.py:CLASS")
    try:
        if where.endswith(".py"):
            path = Path(where).resolve()
            if not path.is_file():
                raise ModelError(f"{what} {ref!r}: no file {where}")
            key = "acausal_user_" + hashlib.sha1(str(path).encode()).hexdigest()[:12] + "_" + path.stem
            module = sys.modules.get(key)
            if module is None:
                spec = importlib.util.spec_from_file_location(key, path)
                module = importlib.util.module_from_spec(spec)
                sys.modules[key] = module
                try:
                    spec.loader.exec_module(module)
                except Exception:
                    del sys.modules[key]
                    raise
        else:
            if os.getcwd() not in sys.path:  # the console script does not put the working directory on it
                sys.path.insert(0, os.getcwd())
            module = importlib.import_module(where)
    except ImportError as exc:
        raise ModelError(f"{what} {ref!r}: cannot import {where!r}: {exc}") from None
    cls = getattr(module, name, None)
    if not (isinstance(cls, type) and issubclass(cls, base)):
        raise ModelError(f"{what} {ref!r}: {where} has no {base.__name__} class {name!r}")
    return cls
