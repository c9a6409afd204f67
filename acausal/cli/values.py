"""What the command line's arguments may be: option values (numbers, ``NAME=VALUE`` pairs, whole numbers) and
input and output files and folders, each refused with a message naming the option before any work starts."""
from __future__ import annotations

import argparse
import math
from pathlib import Path

from ..errors import DataError


def number(text: str, where: str) -> float:
    """``text`` as a finite number, or a DataError naming ``where`` (the option and its item)."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not math.isfinite(value):
        raise DataError(f"{where}: the value after '=' must be a finite number, got {text!r}")
    return value


def pairs(items, flag):
    """``NAME=VALUE`` items of option ``flag`` as ``(name, value)`` text pairs; a name given twice is a DataError
    (which value was meant cannot be told)."""
    seen = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        if not sep:
            raise SystemExit(f"acausal: {flag} {item!r}: expected NAME=VALUE")
        name = name.strip()
        if name in seen:
            raise DataError(f"{flag} {name}: given twice ({seen[name]!r} and {item!r}); give each once")
        seen[name] = item
        yield name, value.strip()


def whole_number(option: str, least: int = 1):
    """An argparse type: a whole number >= ``least``, refused with a message naming ``option``."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = least - 1
        if value < least or str(value) != text.strip():
            raise argparse.ArgumentTypeError(f"{option} takes a whole number >= {least}, got {text!r}")
        return value
    return parse


def check_outputs(data, **outputs):
    """Output paths must not touch the input data: none equal to or inside the data folder (outputs would mix with
    the recordings) and none an existing input file. ``outputs``: option name -> path (None: not given).
    A DataError names the option, the path and why."""
    data = Path(data).resolve()
    for option, path in outputs.items():
        if path is None:
            continue
        p = Path(path).resolve()
        flag = "--" + option.replace("_", "-")
        if p == data or data in p.parents:
            raise DataError(f"{flag} {path}: inside the input data folder {data}; outputs would mix with the "
                            "recordings (and a folder of recordings with other files in it no longer loads): "
                            "choose a folder outside it")


def check_file_output(path, flag: str) -> None:
    """An option's output file must not be an existing folder (checked before any work)."""
    if path is not None and Path(path).is_dir():
        raise DataError(f"{flag} {path}: is a folder; give a file path (e.g. {Path(path) / 'verdict.json'})")


#: the kinds of file a report writes into its --out folder
REPORT_SUFFIXES = (".md", ".png", ".csv", ".html")


def check_beside_report(path, flag: str, out) -> None:
    """An option's output file inside the ``--out`` folder must not be a file of the kind the report writes there
    (``report.md``, its figures and tables): one output would silently replace another."""
    if path is None or out is None:
        return
    p, folder = Path(path).resolve(), Path(out).resolve()
    if p.parent == folder and p.suffix.lower() in REPORT_SUFFIXES:
        raise DataError(f"{flag} {path}: inside --out {out}, where the report writes its {', '.join(REPORT_SUFFIXES)} "
                        f"files (one would replace the other); give another name, e.g. {folder / 'verdict.json'}")


#: the file a run writes last into its --out folder: a folder without it holds no complete run
COMPLETION_MARK = "report.md"


def clear_completion_mark(out) -> None:
    """Remove an earlier run's ``report.md`` from ``out`` before this run writes anything there, so that a run that
    stops half-way leaves a folder that says it is incomplete (no report), never an old report beside new files."""
    mark = Path(out) / COMPLETION_MARK
    if mark.is_file():
        mark.unlink()


def check_file_input(path, flag: str, what: str) -> None:
    """An option's input file must be there (checked before any work); ``what`` says which file it takes."""
    if path is not None and not Path(path).is_file():
        raise DataError(f"{flag} {path}: no such file (give {what})")


def check_bench_folder(out, force: bool):
    """``acausal bench --out`` into a folder that already holds files needs ``--force`` (its recordings of the same
    names would be overwritten and others would stay beside them)."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise DataError(f"--out {out}: exists and is not a folder")
    if out.is_dir() and not force:
        present = [p.name for p in out.iterdir() if not p.name.startswith(".")]
        if present:
            raise DataError(f"--out {out}: the folder is not empty ({len(present)} files, e.g. {sorted(present)[0]!r}); "
                            "its recordings would be overwritten or mixed with the new ones: give an empty or new "
                            "folder, or --force to clear it first")
    if out.is_dir() and force:
        for p in out.iterdir():
            if p.is_file():
                p.unlink()
