"""Measured recordings: a declared file format, a loader that checks and screens, and a writer.

A *recording set* is a folder; each experiment is a pair ``NAME.csv`` (one header row, then rows of floats,
columns in any order, SI units in the column names) plus ``NAME.json`` (the experiment's settings). What the
columns and keys are is declared by a :class:`RecordingFormat` (the ankle actuator's is in
``acausal.models.bench.recording_format``); this module knows no model.

The loader answers bad input with a :class:`~acausal.errors.DataError` naming the file, the line and the column or
key: missing or misspelled columns (with the closest known name), a column in an unknown unit (``time_ms`` where
``time_s`` is declared), cells that are not numbers, JSON that misses a required key, has an unknown key, a value
of the wrong type or a non-positive value where a positive one is required, CSV and JSON files that do not pair
up, and a recording the format's checks find implausible as a whole (a unit slip, a dead sensor). Nothing is
guessed: extra CSV columns are kept (``Recording.extra``) and otherwise ignored. A file separated by semicolons or
tabs is named as such; extensions may be upper-case. A JSON key given twice is an error (a parser would silently
keep the last value), and so is a gap in time wider than ``RecordingFormat.max_gap`` median sample intervals (rows
dropped: a smoothed replay cannot bridge them), unless the format's model can restart a replay inside a recording
(``RecordingFormat.split_at_gaps``): :func:`load_recordings` then splits the recording there into parts.

Samples as real loggers write them (a dropout row, an encoder read error, a repeated time stamp, an empty cell)
are screened (:mod:`~.masking`): masked and named in ``Recording.masked``, the recording kept; one too damaged to
use is left out of the set with the reason (``RecordingSet.left_out``); ``strict=True`` refuses them instead.

Torn and mixed sets: a format may declare the span a recording must cover (``RecordingFormat.expected_span``, e.g.
strides x stride time), and a writer of a whole set writes ``manifest.json`` (:func:`write_manifest`: first as not
complete, then with every recording's rows and SHA-256); :func:`load_recordings` refuses a set whose manifest is
incomplete, lists other files or other contents. Every file is written atomically (:mod:`acausal.results.files`).
"""
from __future__ import annotations

import csv
import difflib
import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from ..errors import DataError
from ..results.files import atomic_write_text, sha256
from .masking import LeftOut, screen

#: the file a writer of a recording set writes last: the recordings it wrote, with row counts and checksums
MANIFEST = "manifest.json"


@dataclass(frozen=True)
class Column:
    """A declared CSV column: ``name`` is ``<quantity>_<unit>`` (e.g. ``time_s``)."""

    name: str
    unit: str
    doc: str = ""
    #: the range one sample can take [unit]: a few samples outside it, among samples inside, are glitches and are
    #: masked (:mod:`~.masking`); None: any finite value
    bounds: tuple | None = None
    #: the fastest change [unit/s] the measured quantity makes: a sample reached and left faster is a glitch
    max_rate: float | None = None
    #: the largest acceleration [unit/s^2] the measured quantity undergoes: a sample farther off the line through
    #: its neighbours than it allows is a glitch
    max_accel: float | None = None

    @property
    def quantity(self) -> str:
        """The name without its unit suffix (``time`` of ``time_s``; a name without one is its own quantity)."""
        suffix = f"_{self.unit}"
        return self.name[: -len(suffix)] if self.name.endswith(suffix) else self.name


@dataclass(frozen=True)
class Key:
    """A declared JSON key; ``kind`` is ``"number"``, ``"integer"`` or ``"text"``. A dotted name
    (``controller.kp``) is a path into nested objects. ``nullable``: ``null`` is accepted and means "not
    recorded" (the key is then left out of ``Recording.meta``, with a note)."""

    name: str
    unit: str = ""
    doc: str = ""
    required: bool = True
    kind: str = "number"
    positive: bool = True
    nullable: bool = False


@dataclass(frozen=True)
class RecordingFormat:
    name: str
    columns: tuple  # of Column, all required
    keys: tuple  # of Key
    time_column: str = "time_s"
    #: what an undeclared top-level JSON key is: ``"error"`` (a DataError naming it) or ``"note"`` (ignored, with
    #: a note in ``Recording.notes``: for formats whose files carry provenance and documentation of their own)
    unknown_keys: str = "error"
    #: ``meta -> seconds or None``: the time the recording must span according to its JSON (e.g. strides x
    #: stride time); a recording that covers less (truncated) or more is an error. ``None``: no such check
    expected_span: Callable | None = None
    #: the widest interval allowed between two samples, in median sample intervals: a wider gap means rows were
    #: dropped (a buffer overrun, a cut) and is an error naming the line. The default lets one dropped sample pass
    #: (a gap of 2), as jittery loggers come close to it (the XL330 recordings reach 1.75), and refuses two (a gap
    #: of 3). ``None``: gaps allowed (a format for data recorded in bursts)
    max_gap: float | None = 2.5
    #: physical plausibility checks of the format: each ``check(columns, meta) -> str | None`` returns what is wrong
    #: (a sentence naming the line, column or key) or None; the loader raises it as a DataError on the CSV file
    #: (units by magnitude, values in range, flags in their set, enough rows)
    checks: tuple = ()
    #: the channels a logging dropout zeroes together (declared or extra columns, those the file has): a row where
    #: all of them read exactly 0 is masked (:mod:`~.masking`)
    dropout: tuple = ()
    #: the share of a recording's rows that may be masked; a recording with more is left out with the reason
    max_masked: float = 0.02
    #: what a gap wider than ``max_gap`` is: False, an error naming the line (a replay that cannot restart inside a
    #: recording: a smoothed one); True, the place where :func:`load_recordings` splits the recording in parts
    #: (``Recording.part``), each replayed from its own first reading; a part shorter than ``min_part_rows`` rows
    #: is left out with the reason
    split_at_gaps: bool = False
    min_part_rows: int = 20

    def column(self, name: str) -> Column:
        return next(c for c in self.columns if c.name == name)

    def describe(self) -> str:
        """A markdown description of the format (columns and keys with units)."""
        lines = [f"### {self.name}", "", "CSV columns (any order, SI units; extra columns are kept and ignored):", ""]
        lines += [f"- `{c.name}` [{c.unit}]: {c.doc}" for c in self.columns]
        lines += ["", "JSON keys:", ""]
        lines += [f"- `{k.name}`{' [' + k.unit + ']' if k.unit else ''} ({'required' if k.required else 'optional'}"
                  f"{', > 0' if k.kind != 'text' and k.positive else ''}): {k.doc}" for k in self.keys]
        return "\n".join(lines)


@dataclass
class Recording:
    """One experiment: declared columns (name -> array), settings from the JSON, and extra columns."""

    name: str
    columns: dict
    meta: dict
    extra: dict = field(default_factory=dict)
    path: Path | None = None
    notes: list = field(default_factory=list)  # what the loader ignored or assumed, one sentence each
    #: column -> which samples were masked (:mod:`~.masking`; their values repaired), for columns with any
    masks: dict = field(default_factory=dict)
    #: every sample the screening masked or left out (:class:`~.masking.MaskedSample`)
    masked: list = field(default_factory=list)
    #: 0: the whole file; k >= 1: the k-th part of a file split at gaps (``RecordingFormat.split_at_gaps``), whose
    #: first reading is not the file's (a model starts its replay from it, moving)
    part: int = 0
    #: the file line (header = 1) of every row (None: not read from a file)
    lines: np.ndarray | None = None

    @property
    def t(self) -> np.ndarray:
        return self.columns["time_s"]

    def __getitem__(self, column: str) -> np.ndarray:
        try:
            return self.columns[column]
        except KeyError:
            if column in self.extra:
                return self.extra[column]
            raise DataError(f"recording {self.name!r} has no column {column!r}; it has "
                            f"{', '.join(list(self.columns) + list(self.extra))}") from None

    def __len__(self):
        return len(self.t)

    def select(self, mask) -> "Recording":
        """The rows where ``mask`` is true (e.g. some strides), as a new recording."""
        return Recording(self.name, {k: v[mask] for k, v in self.columns.items()}, dict(self.meta),
                         {k: v[mask] for k, v in self.extra.items()}, self.path, list(self.notes),
                         {k: v[mask] for k, v in self.masks.items()}, list(self.masked), self.part,
                         None if self.lines is None else self.lines[mask])

    def masked_rows(self, columns) -> np.ndarray:
        """Which samples have a masked value in any of ``columns`` (e.g. the fitted signals)."""
        out = np.zeros(len(self), dtype=bool)
        for c in columns:
            if c in self.masks:
                out |= self.masks[c]
        return out


class RecordingSet(list):
    """The recordings of a folder (a list), with those left out and why (:class:`~.masking.LeftOut`)."""

    def __init__(self, recordings=(), left_out=()):
        super().__init__(recordings)
        self.left_out = list(left_out)

    @property
    def masked(self) -> list:
        """Every masked sample of the recordings kept."""
        return [m for r in self for m in r.masked]


def screening_summary(recordings, left_out=None) -> dict:
    """What the screening of ``recordings`` (a :class:`RecordingSet` or a list) masked and left out, as the
    verdict's JSON carries it."""
    left = getattr(recordings, "left_out", []) if left_out is None else left_out
    return {"masked": [m.to_dict() for r in recordings for m in r.masked], "left_out": [x.to_dict() for x in left]}


def screening_warnings(summary: dict, shown: int = 3) -> list:
    """The screening ``summary`` (:func:`screening_summary`) as warnings: one per recording left out, one per
    recording with masked samples (the first ``shown`` of them named; the report lists them all)."""
    out = [f"{x['file']}: left out: {x['why']}" for x in summary.get("left_out", [])]
    by: dict = {}
    for m in summary.get("masked", []):
        by.setdefault(m["recording"], []).append(m)
    for name, ms in by.items():
        cuts = [m for m in ms if m["kind"] == "gap"]
        out += [f"{name}: starts after a gap at line {m['line']} ({m['why'].split(' before this row')[0]}): the "
                "recording is split there, this part replayed from its own first reading" for m in cuts]
        ms = [m for m in ms if m["kind"] != "gap"]
        if not ms:
            continue
        named = "; ".join(f"line {m['line']}" + (f" ({m['column']})" if m["column"] else "") + f": {m['kind']}"
                          for m in ms[:shown])
        more = f"; and {len(ms) - shown} more (listed in the report)" if len(ms) > shown else ""
        out.append(f"{name}: {len(ms)} sample(s) masked, left out of the residual with the inputs held across them "
                   f"({named}{more})")
    return out


# ------------------------------------------------------------------------------------------------------ loading
def load_recordings(folder, fmt: RecordingFormat, strict: bool = False) -> RecordingSet:
    """Every ``NAME.csv`` + ``NAME.json`` pair in ``folder``, sorted by name, screened (:mod:`~.masking`): a
    recording too damaged to use is left out (``RecordingSet.left_out``) unless none is left; ``strict``: a sample
    that cannot be physical refuses the set, naming file, line and column."""
    folder = Path(folder)
    if folder.is_file():
        raise DataError(f"recording set {folder}: is a file; give the folder that holds the NAME.csv + NAME.json "
                        "recordings")
    if not folder.is_dir():
        raise DataError(f"recording set {folder}: no such folder")
    entries = list(folder.iterdir())
    for p in entries:
        if p.is_dir() and p.suffix.lower() in (".csv", ".json"):
            raise DataError(f"{p}: is a folder, not a recording file (a recording is a NAME.csv + NAME.json pair "
                            "of files)")
    files = [p for p in entries if p.is_file() and not p.name.startswith(".")]
    csvs = {p.stem: p for p in files if p.suffix.lower() == ".csv"}
    jsons = {p.stem: p for p in files if p.suffix.lower() == ".json" and p.name != MANIFEST}
    for stem in sorted(set(csvs) ^ set(jsons)):
        have, miss = (csvs[stem], f"{stem}.json") if stem in csvs else (jsons[stem], f"{stem}.csv")
        raise DataError(f"{have}: no matching {miss} in {folder} (every experiment is a NAME.csv + NAME.json pair)")
    if not csvs:
        raise DataError(f"recording set {folder}: no NAME.csv + NAME.json pairs found")
    if (folder / MANIFEST).exists():
        check_manifest(folder, csvs, jsons)
    kept, left = [], []
    for s in sorted(csvs):
        try:
            rec, gaps = _load(csvs[s], fmt, jsons[s], strict, split=fmt.split_at_gaps and not strict)
        except LeftOut as exc:
            left.append(exc)
            continue
        if not gaps:
            kept.append(rec)
            continue
        parts, short = split_at_gaps(rec, gaps, fmt)
        kept += parts
        left += short
    if not kept:
        raise DataError(f"recording set {folder}: every recording was left out; the first: {left[0]}")
    return RecordingSet(kept, left)


def write_manifest(folder, names, complete: bool = True, about: dict | None = None) -> Path:
    """Write ``folder/manifest.json`` listing the recordings ``names`` (data rows, SHA-256 of both files).
    A writer calls it with ``complete=False`` (names planned, no checksums) before it writes the recordings and with
    ``complete=True`` after the last: a folder whose writing was interrupted then says so when it is loaded."""
    folder = Path(folder)
    entries = {}
    for n in names:
        if complete:
            csv, js = folder / f"{n}.csv", folder / f"{n}.json"
            entries[n] = {"rows": _rows(csv), "csv_sha256": sha256(csv), "json_sha256": sha256(js)}
        else:
            entries[n] = {}
    body = {"complete": bool(complete), **(about or {}), "recordings": entries}
    return atomic_write_text(folder / MANIFEST, json.dumps(body, indent=1) + "\n")


def _rows(csv: Path) -> int:
    """Data rows of a CSV file (lines after the header)."""
    with open(csv, "rb") as fh:
        return sum(1 for line in fh if line.strip()) - 1


def check_manifest(folder: Path, csvs: dict, jsons: dict):
    """Every recording of ``folder`` is the one its manifest lists (a DataError naming the file otherwise)."""
    path = folder / MANIFEST
    try:
        man = json.loads(read_text(path))
        listed = man["recordings"]
    except (json.JSONDecodeError, KeyError, TypeError):
        raise DataError(f"{path}: not a manifest of this library (JSON object with 'recordings' expected)") from None
    if not man.get("complete", False):
        raise DataError(f"{path}: the run that wrote this folder did not finish (the manifest lists "
                        f"{len(listed)} planned recordings and no checksums); its files may mix two runs: write the "
                        "set again")
    extra = sorted(set(csvs) - set(listed))
    if extra:
        raise DataError(f"{csvs[extra[0]]}: not listed in {path} ({len(extra)} such file(s)): the folder mixes "
                        "recordings of different runs")
    missing = sorted(set(listed) - set(csvs))
    if missing:
        raise DataError(f"{path} lists {missing[0]!r}, but {folder / (missing[0] + '.csv')} is missing")
    for name in sorted(listed):
        entry = listed[name]
        for kind, files in (("csv", csvs), ("json", jsons)):
            if sha256(files[name]) != entry.get(f"{kind}_sha256"):
                rows = _rows(files[name]) if kind == "csv" else None
                what = f" ({rows} rows, the manifest says {entry.get('rows')})" if rows is not None else ""
                raise DataError(f"{files[name]}: its content differs from what {path} recorded{what}: the file was "
                                "changed or its writing was interrupted")


def load_recording(csv_path, fmt: RecordingFormat, json_path=None, strict: bool = False) -> Recording:
    """Load, validate and screen one experiment (``json_path``, default: the JSON next to the CSV with the same
    stem, its extension in any case): samples that cannot be physical are masked and named (:mod:`~.masking`;
    ``strict``: refused); a :class:`~.masking.LeftOut` where too many are. A gap wider than the format's
    ``max_gap`` is an error here (:func:`load_recordings` splits the recording there where the format allows)."""
    return _load(csv_path, fmt, json_path, strict, split=False)[0]


def _load(csv_path, fmt: RecordingFormat, json_path, strict: bool, split: bool) -> tuple:
    """``(recording, gaps)``: :func:`load_recording`'s, and the rows after which a gap wider than ``max_gap`` falls
    (empty unless ``split``: a gap is then not an error)."""
    csv_path = Path(csv_path)
    if json_path is None:
        same = [p for p in csv_path.parent.glob(f"{csv_path.stem}.*") if p.suffix.lower() == ".json"]
        json_path = same[0] if same else csv_path.with_suffix(".json")
    json_path = Path(json_path)
    if not csv_path.exists():
        raise DataError(f"{csv_path}: no such file")
    if not json_path.exists():
        raise DataError(f"{csv_path}: no matching {json_path.name} next to it")
    meta, notes, twice = _load_meta(json_path, fmt)
    columns, extra, screened = _load_csv(csv_path, fmt, strict)
    lines = np.flatnonzero(screened.keep) + 2  # the file line of every row kept
    gaps = []
    if fmt.max_gap is not None:
        gaps = _gaps(columns[fmt.time_column], fmt.max_gap)
        if gaps and not split:
            raise DataError(_gap_sentence(csv_path, columns[fmt.time_column], gaps[0], lines, fmt.time_column)
                            + ("" if not fmt.split_at_gaps else
                               " (without strict, load_recordings splits the recording there)"))
    if fmt.expected_span is not None:
        _check_span(csv_path, columns[fmt.time_column], fmt.expected_span(meta))
    for check in fmt.checks:
        problem = check(columns, meta)
        if problem:
            raise DataError(f"{csv_path} ({json_path.name}): {problem}")
    if twice:  # after the range checks: a unit slip in the key the format reads is the likelier culprit
        raise DataError(f"{json_path}: {twice}")
    if screened.left_out:  # after the checks: a recording wrong as a whole is refused, naming its column
        raise LeftOut(csv_path.stem, csv_path, screened.left_out)
    return Recording(csv_path.stem, columns, meta, extra, csv_path, notes, screened.masks, screened.masked,
                     lines=lines), gaps


def _gaps(t: np.ndarray, max_gap: float) -> list:
    """The rows after which the interval to the next sample is wider than ``max_gap`` median intervals (rows
    dropped), widest first."""
    if t.size < 3:
        return []
    dt = np.diff(t)
    wide = np.flatnonzero(dt > max_gap * float(np.median(dt)))
    return [int(k) for k in wide[np.argsort(-dt[wide], kind="stable")]]


def _gap_sentence(path, t, k: int, lines, column: str) -> str:
    dt, med = float(t[k + 1] - t[k]), float(np.median(np.diff(t)))
    return (f"{path}, line {int(lines[k + 1])}, column {column!r}: a gap of {dt:.4g} s after t = {float(t[k])!r} s, "
            f"{dt / med:.1f} times the median sample interval {med:.4g} s: rows are missing (dropped samples or a "
            "cut in the file)")


def split_at_gaps(rec: Recording, gaps, fmt: RecordingFormat) -> tuple:
    """``(parts, left out)``: recording ``rec`` cut at the rows after ``gaps`` (:func:`_gaps`) into parts named
    ``"NAME part k"`` (``Recording.part = k``), each a recording of its own (its masks and masked samples; the
    first row of a later part named as a masked sample of kind ``"gap"``, so the report lists the cut); a part of
    fewer than ``fmt.min_part_rows`` rows is left out (:class:`~.masking.LeftOut`) with the reason."""
    from .masking import MaskedSample
    t = rec.t
    cuts = sorted(gaps)
    bounds = [0, *(k + 1 for k in cuts), len(t)]
    med = float(np.median(np.diff(t)))
    parts, short = [], []
    for k, (a, b) in enumerate(zip(bounds[:-1], bounds[1:]), start=1):
        name = f"{rec.name} part {k}"
        first, last = int(rec.lines[a]), int(rec.lines[b - 1])
        if b - a < fmt.min_part_rows:
            short.append(LeftOut(name, rec.path, f"lines {first}-{last}, {b - a} rows between gaps (fewer than "
                                                 f"{fmt.min_part_rows}): too short to replay"))
            continue
        rows = np.zeros(len(t), dtype=bool)
        rows[a:b] = True
        part = rec.select(rows)
        part.name, part.part = name, k
        part.masked = [m for m in rec.masked if first <= m.line <= last]
        for i, m in enumerate(part.masked):
            part.masked[i] = MaskedSample(name, m.line, m.column, m.t, m.kind, m.why)
        if a > 0:
            gap = float(t[a] - t[a - 1])
            part.masked.insert(0, MaskedSample(name, first, fmt.time_column, float(t[a]), "gap",
                                               f"a gap of {gap:.4g} s ({gap / med:.1f} median sample intervals) "
                                               f"before this row: {rec.name} is split here and this part replayed "
                                               "from its own first reading"))
        parts.append(part)
    return parts, short


def _check_span(path: Path, t: np.ndarray, span):
    """The samples cover ``span`` seconds to within one sample interval (a logger may write both ends, t = 0 and
    t = span); two or more samples less is a truncated file."""
    if span is None or t.size < 2:
        return
    dt = float(np.median(np.diff(t)))
    covered = float(t[-1] - t[0]) + dt
    if abs(covered - span) > 1.5 * dt:
        why = "truncated (an interrupted write?)" if covered < span else "longer than declared"
        if span > 0 and not 0.1 < covered / span < 10:
            why += f", by a factor {covered / span:.4g}: time in another unit than seconds?"
        raise DataError(f"{path}: the samples cover {covered:.4g} s ({t.size} rows) but its JSON declares "
                        f"{span:.4g} s: {why}")


def _no_duplicate_keys(path: Path):
    """A JSON object hook that refuses a key given twice in one object (``json`` would keep the last silently)."""
    def hook(pairs):
        seen = {}
        for k, v in pairs:
            if k in seen:
                raise DataError(f"{path}: key {k!r} appears twice (values {seen[k]!r} and {v!r}); which one is "
                                "meant is not for the loader to guess")
            seen[k] = v
        return seen
    return hook


def _load_meta(path: Path, fmt: RecordingFormat) -> tuple:
    try:
        raw = json.loads(read_text(path), object_pairs_hook=_no_duplicate_keys(path))
    except json.JSONDecodeError as e:
        raise DataError(f"{path}: not valid JSON (line {e.lineno}, column {e.colno}: {e.msg})") from None
    if not isinstance(raw, dict):
        raise DataError(f"{path}: the JSON must be an object of keys, got {type(raw).__name__}")
    keys = {k.name: k for k in fmt.keys}
    tops = {k.name.split(".")[0] for k in fmt.keys}
    notes = []
    for name in raw:
        if name not in tops:
            close = difflib.get_close_matches(name, tops, n=1)
            if fmt.unknown_keys == "note":
                notes.append(f"{path.name}: key {name!r} is not used by format {fmt.name!r}; ignored")
                continue
            hint = f"; did you mean {close[0]!r}?" if close else f"; known keys: {', '.join(keys)}"
            raise DataError(f"{path}: unknown key {name!r}{hint}")
    meta = {}
    missing = object()
    for k in fmt.keys:
        v = _lookup(raw, k.name, missing)
        if v is missing:
            if k.required:
                raise DataError(f"{path}: required key {k.name!r} [{k.unit}] is missing")
            continue
        if v is None and k.nullable:
            notes.append(f"{path.name}: key {k.name!r} is null (not recorded)")
            continue
        if k.kind == "text":
            if not isinstance(v, str):
                raise DataError(f"{path}: key {k.name!r} must be text, got {v!r}")
        else:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise DataError(f"{path}: key {k.name!r} must be a finite number [{k.unit}], got {v!r}")
            if k.kind == "integer" and int(v) != v:
                raise DataError(f"{path}: key {k.name!r} must be a whole number, got {v!r}")
            if k.positive and v <= 0:
                raise DataError(f"{path}: key {k.name!r} must be positive [{k.unit}], got {v!r}")
            v = int(v) if k.kind == "integer" else float(v)
        meta[k.name] = v
    return meta, notes, _said_twice(raw, keys)


def _said_twice(raw: dict, keys: dict) -> str | None:
    """A number the JSON gives again under another object (``kp`` and ``controller.kp``), disagreeing with the key
    the format reads; None when every such pair agrees."""
    for leaf, value in _leaves(raw):
        if leaf in keys:
            continue
        for k in (k for k in keys if k.rsplit(".", 1)[-1] == leaf.rsplit(".", 1)[-1]):
            given = _lookup(raw, k, None)
            numbers = all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in (value, given))
            if numbers and value != given:
                return (f"key {leaf!r} = {value!r} contradicts key {k!r} = {given!r}; the format reads {k!r}: remove "
                        "or correct the other")
    return None


def _leaves(raw: dict, prefix: str = ""):
    """``(dotted name, value)`` of every value in the JSON object ``raw`` that is not itself an object."""
    for k, v in raw.items():
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            yield from _leaves(v, name + ".")
        else:
            yield name, v


def _lookup(raw: dict, dotted: str, missing):
    """``raw["a"]["b"]`` for ``"a.b"``; ``missing`` where a step is absent or not an object."""
    v = raw
    for part in dotted.split("."):
        if not isinstance(v, dict) or part not in v:
            return missing
        v = v[part]
    return v


def read_text(path: Path) -> str:
    """A text file of a recording set as UTF-8 (a leading byte-order mark, as spreadsheet programs write, is
    dropped); a DataError naming the file and the first byte that is not UTF-8 otherwise."""
    try:
        return path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise DataError(f"{path}: not UTF-8 text (byte {exc.object[exc.start]:#04x} at offset {exc.start})") from None


def _load_csv(path: Path, fmt: RecordingFormat, strict: bool):
    try:
        return _parse_csv(path, fmt, strict)
    except UnicodeDecodeError as exc:
        with open(path, "rb") as fh:
            head = fh.read(4)
        what = ("gzip-compressed: decompress it first (gunzip)" if head[:2] == b"\x1f\x8b" else
                "a zip archive: extract it first" if head[:2] == b"PK" else
                f"not UTF-8 text (byte {exc.object[exc.start]:#04x} at offset {exc.start})")
        raise DataError(f"{path}: {what}; a recording is a comma-separated text file") from None


def _parse_csv(path: Path, fmt: RecordingFormat, strict: bool):
    with open(path, newline="", encoding="utf-8-sig") as fh:  # a byte-order mark before the header is dropped
        header_line = fh.readline()
        if not header_line.strip():
            raise DataError(f"{path}: empty file (expected a header row of column names)")
        if "," not in header_line:
            for sep, label in ((";", "semicolons"), ("\t", "tabs")):
                if sep in header_line:
                    raise DataError(f"{path}, line 1: the columns are separated by {label}; the format wants "
                                    "comma-separated values (CSV with ',')")
        # a spreadsheet quotes the names ("time_s",...): read as CSV, not split at every comma
        header = [h.strip() for h in next(csv.reader([header_line.rstrip("\r\n")]))]
        _check_header(path, header, fmt)
        body = fh.read()
    try:
        data = np.loadtxt(body.splitlines(), delimiter=",", ndmin=2, dtype=float) if body.strip() else None
    except ValueError:  # an empty cell, or a bad one: read row by row (empty cells as NaN, the rest named)
        data = _read_rows(path, body, header)
    if data is None or data.shape[0] == 0:
        raise DataError(f"{path}: no data rows after the header")
    if data.shape[1] != len(header):
        _read_rows(path, body, header)  # names the first row of the wrong length
    screened = screen(path, path.stem, header, data, fmt, strict)
    data = screened.data
    bad = ~np.isfinite(data)
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise DataError(f"{path}, line {r + 2}, column {header[c]!r}: value {data[r, c]} is not finite "
                        "(NaN and inf are not accepted)")
    cols = {h: data[:, j] for j, h in enumerate(header)}
    t = cols[fmt.time_column]
    dt = np.diff(t)
    if (dt <= 0).any():
        r = int(np.argmax(dt <= 0))
        what = "is duplicated" if dt[r] == 0 else "goes back"
        raise DataError(f"{path}, line {r + 3}, column {fmt.time_column!r}: time {what} ({float(t[r + 1])!r} after "
                        f"{float(t[r])!r}); time must increase strictly")
    declared = {c.name for c in fmt.columns}
    return ({c.name: cols[c.name] for c in fmt.columns}, {h: v for h, v in cols.items() if h not in declared},
            screened)


def _check_header(path, header, fmt):
    seen = set()
    for h in header:
        if not h:
            raise DataError(f"{path}, line 1: an empty column name in the header")
        if h in seen:
            raise DataError(f"{path}, line 1: column {h!r} appears twice")
        seen.add(h)
    for c in fmt.columns:
        if c.name in seen:
            continue
        same_quantity = [h for h in header if h.rsplit("_", 1)[0] == c.quantity and "_" in h]
        if same_quantity:
            unit = same_quantity[0].rsplit("_", 1)[1]
            raise DataError(f"{path}, line 1, column {same_quantity[0]!r}: unknown unit {unit!r} for "
                            f"{c.quantity}; the format wants SI [{c.unit}] in a column named {c.name!r}")
        close = difflib.get_close_matches(c.name, [h for h in header if h not in {x.name for x in fmt.columns}], n=1)
        hint = f" (is {close[0]!r} a misspelling of it?)" if close else ""
        raise DataError(f"{path}, line 1: required column {c.name!r} [{c.unit}] is missing{hint}")


def _read_rows(path, body, header) -> np.ndarray:
    """The rows of ``body`` as numbers, an empty cell as NaN (the screening masks it); a DataError naming the line
    and column of a cell that is not a number, or a row of the wrong length."""
    rows = []
    for n, line in enumerate(body.splitlines(), start=2):
        if not line.strip():
            raise DataError(f"{path}, line {n}: empty row")
        fields = line.split(",")
        if len(fields) != len(header):
            raise DataError(f"{path}, line {n}: {len(fields)} values for {len(header)} columns")
        row = []
        for h, f in zip(header, fields):
            f = f.strip()
            try:
                if "_" in f:  # Python's float() takes 1_000; a CSV reader does not
                    raise ValueError(f)
                row.append(float(f) if f else math.nan)
            except ValueError:
                raise DataError(f"{path}, line {n}, column {h!r}: {f!r} is not a number") from None
        rows.append(row)
    return np.array(rows, dtype=float).reshape(len(rows), len(header))


# ------------------------------------------------------------------------------------------------------ writing
def write_recording(folder, name: str, columns: dict, meta: dict, fmt: RecordingFormat, digits: int = 9) -> Path:
    """Write ``NAME.csv`` + ``NAME.json`` into ``folder``; checks the columns and keys against ``fmt`` first."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    missing = [c.name for c in fmt.columns if c.name not in columns]
    if missing:
        raise DataError(f"write_recording {name!r}: columns {missing} of format {fmt.name!r} are missing")
    names = [c.name for c in fmt.columns] + [k for k in columns if k not in {c.name for c in fmt.columns}]
    data = np.column_stack([np.asarray(columns[k], dtype=float) for k in names])
    path = folder / f"{name}.csv"
    buf = io.StringIO()
    np.savetxt(buf, data, delimiter=",", header=",".join(names), comments="", fmt=f"%.{digits}g")
    atomic_write_text(folder / f"{name}.json", json.dumps(meta, indent=2) + "\n")
    atomic_write_text(path, buf.getvalue())
    try:  # what is written must load (its glitches screened, as they will be: a converted log may have some)
        load_recording(path, fmt)
    except LeftOut:
        pass  # written as it came; the loader leaves it out of a set, saying why
    return path
