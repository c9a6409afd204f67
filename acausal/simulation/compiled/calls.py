"""Calling a CasADi integrator of the compiled path: the inputs and outputs handed over as numpy memory (CasADi's
buffer interface), a failure turned into the line that says what failed, and what SUNDIALS printed on the standard
error during the call captured for the caller's message."""
from __future__ import annotations

import contextlib
import os
import sys
import tempfile
import threading

import numpy as np


def run_integrator(integ, call, idas: bool) -> tuple:
    """``(outputs, None, "")`` of one integrator call, or ``(None, its failure, what SUNDIALS printed)``.
    Outputs are numpy arrays of CasADi's shapes (``xf``: states by output times). IDAS's consistent
    initialisation prints its failures on the standard error (``idas``: captured); CVODES, with CasADi's internal
    warnings off, says everything in the exception."""
    if not idas:
        try:
            return _call(integ, call), None, ""
        except RuntimeError as exc:
            return None, first_line(exc), ""
    with _solver_messages() as said:
        try:
            return _call(integ, call), None, ""
        except RuntimeError as exc:
            failed = first_line(exc)
    return None, failed, said()


def _call(integ, call) -> dict:
    """``integ(**call)`` through CasADi's buffer interface: the inputs and outputs are numpy memory CasADi reads
    and writes in place (no conversion to and from CasADi matrices: 50 us of a 0.65 ms run). CasADi stores a
    matrix by columns, which is the row-major layout of its transpose. One buffer per integrator and thread (a
    buffer holds one evaluation's memory)."""
    bufs = integ.__dict__.setdefault("_acausal_buffers", {})  # on the Python object: hashing it costs more
    key = threading.get_ident()
    if key not in bufs:
        ins = [(i, name, integ.size_in(i)) for i, name in enumerate(integ.name_in()) if integ.nnz_in(i)]
        outs = [(i, name, integ.size_out(i)) for i, name in enumerate(integ.name_out()) if integ.nnz_out(i)]
        bufs[key] = integ.buffer() + (ins, outs)
    buf, trigger, ins, outs = bufs[key]
    keep = []  # the memory CasADi reads from: alive until the call returns
    for i, name, shape in ins:
        given = call.get(name)  # an input not given is zero, as in a CasADi call
        a = np.zeros(shape[::-1]) if given is None else np.ascontiguousarray(
            np.asarray(given, dtype=float).reshape(shape).T)
        keep.append(a)
        buf.set_arg(i, memoryview(a))
    out = {}
    for i, name, (rows, cols) in outs:
        a = np.empty((cols, rows))
        out[name] = a.T
        buf.set_res(i, memoryview(a))
    trigger()
    return out


def steps_taken(integ) -> int:
    """The steps SUNDIALS took in the last call of ``integ`` on this thread (:func:`run_integrator`), from its
    buffer's statistics; 0 where it has none."""
    found = integ.__dict__.get("_acausal_buffers", {}).get(threading.get_ident())
    if found is None:
        return 0
    try:
        return int(found[0].stats().get("nsteps", 0))
    except (RuntimeError, TypeError, ValueError):  # no statistics (a call that failed before its first step)
        return 0


def first_line(exc) -> str:
    lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
    useful = [ln for ln in lines if "CV_" in ln or "IDA_" in ln or "failed" in ln.lower()]
    return (useful or lines or ["unknown error"])[-1]


@contextlib.contextmanager
def _solver_messages():
    """What SUNDIALS prints on the process's standard error during the block (IDAS's consistent-initialisation
    line search reports its failures there, bypassing Python), captured: the block gets a function returning the
    text, which the caller puts into its own error where the run failed (runs that succeed print nothing). One
    scratch file per process takes the text, emptied after each block."""
    if not _SINK:
        fd, name = tempfile.mkstemp(prefix="acausal-sundials-")
        os.unlink(name)  # nameless: gone with the process
        _SINK.append(fd)
    sink = _SINK[0]
    sys.stderr.flush()
    saved = os.dup(2)
    os.dup2(sink, 2)
    text = []
    try:
        yield lambda: text[0] if text else ""
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        size = os.lseek(sink, 0, os.SEEK_END)
        if size:
            os.lseek(sink, 0, os.SEEK_SET)
            text.append(" ".join(os.read(sink, size).decode(errors="replace").split()))
            os.ftruncate(sink, 0)
            os.lseek(sink, 0, os.SEEK_SET)


_SINK: list = []  # the descriptor of _solver_messages's scratch file, opened on first use
