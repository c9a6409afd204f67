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

from ..errors import ModelError


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
    except ModelError:
        raise
    except SyntaxError as exc:
        raise ModelError(f"{what} {ref!r}: {exc.filename} line {exc.lineno}: SyntaxError: {exc.msg}") from None
    except ImportError as exc:
        raise ModelError(f"{what} {ref!r}: cannot import {where!r}: {exc}") from None
    except Exception as exc:  # the user's module raised while it was loaded
        raise user_code_error(f"{what} {ref!r}: loading {where}", exc) from None
    cls = getattr(module, name, None)
    if not (isinstance(cls, type) and issubclass(cls, base)):
        raise ModelError(f"{what} {ref!r}: {where} has no {base.__name__} class {name!r}")
    return cls


def user_code_error(doing: str, exc: BaseException) -> ModelError:
    """A ModelError for an exception the user's code raised while ``doing`` (e.g. "model 's.py:X': building
    it"): its type and message, and the last line of the traceback outside this package (the user's file and
    line), instead of a raw traceback."""
    import traceback

    here = Path(__file__).resolve().parent.parent  # acausal/, beside library/ and models/ (acausal.library, .models)
    ours = tuple(str(here / part) + os.sep for part in ("acausal", "library", "models"))
    installed = tuple({os.path.realpath(p) + os.sep for p in (sys.prefix, sys.base_prefix, sys.exec_prefix)})

    def users(filename):
        real = os.path.realpath(filename)
        return not real.startswith(ours) and not real.startswith(installed) and not filename.startswith("<")

    frames = [f for f in traceback.extract_tb(exc.__traceback__) if users(f.filename)]
    at = f" ({frames[-1].filename} line {frames[-1].lineno})" if frames else ""
    return ModelError(f"{doing} raised {type(exc).__name__}: {exc}{at}")
