"""The native loop: a run integrated by SUNDIALS itself (CVODES for an ODE, IDAS where Newton blocks are algebraic
variables), a state event's crossing found inside the integration, the model's functions printed as C by CasADi
(``native_dae.c`` holds the loop). Every run of the compiled path takes it where it can be built (a model without
state events is one segment).

Each segment between two events is one call into the library: the solver steps from a consistent start (the
algebraic variables from the Python Newton solve of their blocks, as on the CasADi path), its steps ending at the
last output time, not at each (a stop per output truncated the steps of a dense grid); it checks the zero functions
at the end of each step, and at :data:`SUBSTEPS` interior points of it (the solver's interpolating polynomial, the
algebraic variables made consistent there) where one crossed or where its total variation over the step says it may
have bounced; it writes the outputs it passes, read off that polynomial, and stops at the first crossing, located on
it. The event itself (its assignments, the cascade of mode changes, the thresholds watched from there) is the one
event loop's (:mod:`acausal.simulation.loop`; :class:`NativeSegments` is its segment integrator), so all paths switch
the same way; a crossing that changes no mode is passed and the next call starts from it. The C loop runs the steps
of a segment and the search for its crossing, the work a run spends its time in; the event between two calls is
Python's, once per event.

For a model without events, this skips what CasADi's integrator adds around the same SUNDIALS steps (its virtual
machine evaluating the model, its buffers): the 1-s drive of the benchmarks integrates in about 0.75 of the time of
the same two equations written by hand for CasADi's CVODES, three states against two.

For events, this removes what made them expensive on the CasADi path (:mod:`acausal.simulation.compiled.events`): there,
every run of the integrator starts cold and costs about a millisecond whatever its length, and a crossing costs
several runs (windows, the locating run, the integrals up to it). Here a segment costs one start, and the steps
themselves run in compiled code. Table inputs (recordings, gait tables) are evaluated in C from their numbers passed
at run time, so one library serves every recording of a model.

The energy integrals are quadratures whose error test is scaled by the largest energy flow of each step (not by
each whole integral so far, which lets a long run's energies drift by many times ``rtol``), so the energies' errors
stay near ``rtol`` of the balance they enter; each distinct integrand is integrated once, none that is structurally
zero.

The loop (``native_dae.c``) is built once per machine, each model's functions into a library of their own (about
0.2 s of the C compiler on a model's first run on the machine: :func:`acausal.backends.ccompiler.shared_library` caches
both by their source), and the loop calls them through their addresses.

Needs a C compiler and SUNDIALS's headers and libraries (6.x: Debian's ``libsundials-dev``); without them, or for
a model whose functions have no CasADi form, :func:`segment_runner` returns None and the run stays on CasADi's
integrators. ``ACAUSAL_NATIVE=0`` in the environment keeps every run there.
"""
from __future__ import annotations

import ctypes
import dataclasses
import os
from pathlib import Path

import numpy as np

from ...backends.ccompiler import try_shared_library, which_compiler
from ...errors import SimulationError
from ..events import SUBSTEPS, zeros
from ..loop import event_modes, integrate_segments
from ...backends.casadi import Signals, Unsupported

MAX_NUM_STEPS = 1_000_000  # solver steps per segment at most
MAX_PASSES = 100_000  # crossings that change no mode, per run, at most (each restarts the integration past it)
LIBS = ("-lsundials_cvodes", "-lsundials_idas", "-lsundials_nvecserial", "-lsundials_sunmatrixdense",
        "-lsundials_sunlinsoldense")
OUTSIDE = {"extend": 0, "hold": 1, "periodic": 2}  # how a table continues beyond its breaks (native_dae.c)
_SOURCE = Path(__file__).with_name("native_dae.c")


def enabled() -> bool:
    """Whether runs may take the native loop: a C compiler is there and ``ACAUSAL_NATIVE=0`` does not say no."""
    return why_off() is None


def why_off() -> str | None:
    """Why runs may not take the native loop here (switched off, or no C compiler), or None."""
    if os.environ.get("ACAUSAL_NATIVE", "1") == "0":
        return "switched off (ACAUSAL_NATIVE=0)"
    return None if which_compiler()[0] is not None else "needs a C compiler, none found"


class RuntimeSignals(Signals):
    """:class:`~.translate.Signals` whose table lookups become symbols (``slots``: one per table, derivative order
    and argument), their values computed in C from the numbers of the run's tables at the arguments (expressions of
    time and parameters: ``arguments``); a table read at an argument that depends on the states raises
    :class:`Unsupported`."""

    def __init__(self, cm, u, t):
        super().__init__(cm, u)
        self.t = t
        self.slots: list = []  # (table input index, derivative order)
        self.arguments: list = []  # the argument of each slot (CasADi, of time and parameters)
        self.symbols: list = []

    def _table(self, k, order, arg):
        import casadi as ca
        for j, (key, a) in enumerate(zip(self.slots, self.arguments)):
            if key == (k, order) and ca.is_equal(a, arg, 64):
                return self.symbols[j]
        self.slots.append((k, order))
        self.arguments.append(arg)
        self.symbols.append(ca.SX.sym(f"s{len(self.slots) - 1}"))
        return self.symbols[-1]

    def tables_of_run(self):
        """:meth:`tables`, once per run (a segment per event asks again)."""
        if getattr(self, "_tables", None) is None:
            self._tables = self.tables()
        return self._tables

    def tables(self):
        """``(table fields, slots, numbers)`` of the run: per table input used, its pieces, degree, how it continues
        outside, the offsets of its breaks and rows in the numbers, and its row width (``native_dae.c``)."""
        used = sorted({k for k, _ in self.slots})
        fields, data, where = [], [], {}
        offset = 0
        for k in used:
            _, (n, g, outside, _, _), breaks, rows = self.forms[k]
            where[k] = len(fields) // 6
            fields += [n, g, OUTSIDE[outside], offset, offset + breaks.size, rows.shape[1]]
            data += [breaks.ravel(), rows.ravel()]
            offset += breaks.size + rows.size
        slots = [v for k, order in self.slots for v in (where[k], order)]
        numbers = np.concatenate(data) if data else np.zeros(1)
        return (np.array(fields or [0], dtype=np.int64), np.array(slots or [0], dtype=np.int64),
                np.ascontiguousarray(numbers, dtype=float))


class SegmentRunner:
    """The compiled segment loop of one model, one signal layout and one set of quadratures."""

    def __init__(self, fn, model, n, nz, names, rows, nq, ng, entry):
        self.fn, self.n, self.nz, self.ng = fn, n, nz, ng
        self.model = model  # the model's library, its functions' addresses and where they are (kept alive)
        self.names = list(names)  # the integrals a Result gets
        self.rows = np.asarray(rows, dtype=int)  # each name's row among the integrated quadratures (-1: zero)
        self.nq, self.nv = nq, ng  # integrated: the distinct integrands, then each zero function's variation
        self.entry = entry  # z_index and the caches the algebraic start needs

    def run(self, sig, seg, t0, y0, g0, mute, off, t_out):
        """One segment (``seg``: :class:`~..run.Segment`, its parameters, modes, tolerances and step bounds) from
        ``t0`` with the states and algebraic variables ``y0``, the zero functions ``g0`` there, the crossings
        ``mute`` passed at the start and the thresholds ``off``, writing the outputs at ``t_out`` it passes:
        ``(status, outputs written, X, Q, t_event, y_event, q_event, directions, message)``."""
        pd = np.concatenate([seg.p, seg.d])
        rtol, atol, max_step, first_step = seg.rtol, seg.atol, seg.max_step, seg.first_step
        fields, slots, numbers = sig.tables_of_run() if sig.slots else _NO_TABLES
        n, ny, nq, ng, N = self.n, self.n + self.nz, self.nq, self.ng, t_out.size
        wq, wg = max(nq, 1), max(ng, 1)
        # every array the loop reads in one buffer, every one it writes in another, passed by their addresses
        # (ctypes's pointer objects, one per array, cost more than the whole run of a small model)
        ins = np.concatenate([y0, pd, off, np.zeros(wg - len(off)), g0, np.zeros(wg - len(g0)), t_out], dtype=float)
        a = ins.ctypes.data
        a_pd = a + 8 * len(y0)
        a_off = a_pd + 8 * len(pd)
        a_g0 = a_off + 8 * wg
        a_t = a_g0 + 8 * wg
        out = np.empty(N * ny + N * wq + ny + wq + 1)
        b = out.ctypes.data
        b_q = b + 8 * N * ny
        b_ye = b_q + 8 * N * wq
        b_qe = b_ye + 8 * ny
        b_te = b_qe + 8 * wq
        flags = np.zeros(2 * wg + 2, dtype=np.int32)  # mute, directions, then the outputs written (a long)
        flags[:len(mute)] = mute
        c = flags.ctypes.data
        msg = np.zeros(512, dtype=np.uint8)
        status = self.fn(self.model[2], n, self.nz, nq, self.nv, ng, len(sig.slots), float(t0), a, a_pd, a_off,
                         a_g0, c, fields.ctypes.data, slots.ctypes.data, numbers.ctypes.data, N, a_t, float(rtol),
                         float(atol), float(max_step), float(first_step or 0.0), MAX_NUM_STEPS, SUBSTEPS, b, b_q,
                         c + 8 * wg, b_te, b_ye, b_qe, c + 4 * wg,
                         msg.ctypes.data, msg.size)
        k = int(flags[2 * wg:].view(np.int64)[0])
        X = out[:N * ny].reshape(N, ny)[:k].T
        y_e, t_e = out[N * ny + N * wq:N * ny + N * wq + ny], float(out[-1])
        if self.names:
            Q, q_e = out[N * ny:N * ny + N * wq].reshape(N, wq), out[-1 - wq:-1]
            rows, known = np.maximum(self.rows, 0), (self.rows >= 0)
            Qn = np.where(known[:, None], Q[:k, rows].T, 0.0)  # one row per name (a structurally zero one: zeros)
            qn = np.where(known, q_e[rows], 0.0)
        else:
            Qn, qn = np.zeros((0, k)), np.zeros(0)
        said = msg.tobytes().split(b"\0", 1)[0].decode(errors="replace") if status < 0 else ""
        return status, k, X, Qn, t_e, y_e, qn, flags[wg:wg + ng], said


#: the table arguments of a run without table inputs (the loop reads none of them)
_NO_TABLES = (np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64), np.zeros(1))


def runner_for(cm, u, accounts):
    """``(runner, signals)`` of :func:`segment_runner` for a run of ``cm`` with signals ``u`` whose energy
    integrals are ``accounts`` (names; those with a compiled form are integrated), or ``(None, why not)``: the
    native loop switched off or not built here. What :func:`~acausal.simulation.simulate.simulate` and
    :func:`~acausal.simulation.batch.simulate_many` ask before a run."""
    if not enabled():
        return None, "the native loop is off (ACAUSAL_NATIVE=0, or no C compiler)"
    return segment_runner(cm, u, cm.compiled_path.integrable(accounts, u) if accounts else [])


def segment_runner(cm, u, integrals):
    """``(runner, signals)`` for runs of ``cm`` with signals ``u`` and the quadratures ``integrals`` (those with a
    compiled form), or ``(None, why not)``. Built once per model, layout and quadratures (the library once per
    machine: :func:`acausal.backends.ccompiler.shared_library` caches it by its source)."""
    path = cm.compiled_path
    store = path.__dict__.setdefault("_native", {})
    try:
        layout = tuple((f[0], f[1][:4] if f[0] == "table" else f[1]) for f in
                       (Signals.layout(cm, u)))
    except Unsupported as exc:
        return None, str(exc)
    key = (layout, tuple(integrals))
    if key not in store:
        store[key] = _build(cm, u, integrals)
    runner = store[key][0]
    if runner is None:
        return None, store[key][1]
    sig = RuntimeSignals(cm, u, None)  # this run's numbers, the slots of the build
    sig.slots = list(store[key][1].slots)
    return runner, sig


def _build(cm, u, integrals):
    import casadi as ca
    path = cm.compiled_path
    made: list = []

    def signals(t):
        made.append(RuntimeSignals(cm, u, t))
        return made[-1]
    entry = path.build_rhs(u, signals)
    if isinstance(entry, str):
        return None, entry
    sig = made[0]
    zeros = path.zero_functions(entry)
    if isinstance(zeros, str):
        return None, zeros
    names, qexpr = path.quadratures(entry, tuple(integrals))
    # integrated: each distinct integrand once (a power sensor and the source it measures), none that is zero (an
    # ideal sensor's port), then the zero functions' total variations (scaled, VARIATION_SCALE)
    rows, distinct = [], []
    for i in range(len(names)):
        q = qexpr[i]
        if q.is_zero():
            rows.append(-1)
            continue
        same = [j for j, e in enumerate(distinct) if ca.is_equal(e, q, 64)]
        rows.append(same[0] if same else len(distinct))
        if not same:
            distinct.append(q)
    # the zero functions' variations, integrated whether or not an integral is (without them, every step is searched
    # at its interior points); where one is not defined in a step (a NaN), native_dae.c searches that step so
    variations = path.quadratures(entry, (), variation=True)[1] if zeros[0].numel() else None
    nq = len(distinct) + (0 if variations is None else variations.numel())
    parts = ([ca.cse(ca.vertcat(*distinct))] if distinct else []) + ([variations] if variations is not None else [])
    qexpr = ca.vertcat(*parts) if parts else None
    t, x, z, pds = entry["t"], entry["x"], entry["z"], entry["pds"]
    y = ca.vertcat(x, z)
    s = ca.vertcat(*sig.symbols) if sig.symbols else ca.SX(0, 1)
    ins = [t, y, pds, s]
    arguments = ca.vertcat(*sig.arguments) if sig.arguments else ca.SX(0, 1)
    if ca.depends_on(arguments, y) or ca.depends_on(arguments, s):
        return None, "a table input is read at an argument that depends on the states"
    f, alg = ca.densify(entry["f"]), ca.densify(entry["alg"])
    funcs = [ca.Function("acausal_dae", ins, [f, alg]),
             ca.Function("acausal_jac", ins, [ca.densify(ca.jacobian(ca.vertcat(f, alg), y))]),
             ca.Function("acausal_quad", ins, [ca.SX(0, 1) if qexpr is None else ca.densify(qexpr)]),
             ca.Function("acausal_zeros", ins, [ca.densify(zeros[0])]),
             ca.Function("acausal_arguments", [t, pds], [ca.densify(arguments)])]
    cg = ca.CodeGenerator("acausal_model", {"with_header": False})
    for fn in funcs:
        cg.add(fn)
    loop, why = _loop()
    model = None
    if loop is not None:
        model, why = try_shared_library(cg.dump(), flags=("-O1",))
    if model is None:
        return None, f"the native loop could not be built: {why}"
    lib = ctypes.CDLL(str(model))
    functions = (ctypes.c_void_p * (2 * len(FUNCTIONS)))(
        *[ctypes.cast(getattr(lib, name + tail), ctypes.c_void_p).value for tail in ("", "_work")
          for name in FUNCTIONS])
    model = (lib, functions, ctypes.addressof(functions))
    return SegmentRunner(loop, model, x.numel(), z.numel(), names, rows, nq, int(zeros[0].numel()), entry), sig


def _loop():
    """``(the loop's C function, None)``, or ``(None, why not)``: ``native_dae.c`` built once per machine (the
    library cache) and loaded once per process; every model's functions are passed to it by address."""
    if "loop" not in _LOOP:
        lib, why = try_shared_library(_SOURCE.read_text(), flags=("-O2",), libs=LIBS)
        if lib is None:
            _LOOP["loop"] = (None, why)
        else:
            fn = ctypes.CDLL(str(lib)).acausal_segment
            at = ctypes.c_void_p  # every array is passed by its address
            fn.argtypes = ([at] + [ctypes.c_long] * 6 + [ctypes.c_double] + [at] * 8 + [ctypes.c_long, at]
                           + [ctypes.c_double] * 4 + [ctypes.c_long] * 2 + [at] * 8 + [ctypes.c_long])
            fn.restype = ctypes.c_int
            _LOOP["loop"] = (fn, None)
    return _LOOP["loop"]


_LOOP: dict = {}  # the loaded loop (or why it could not be built), once per process
#: the generated functions the loop calls, in the order of native_dae.c's table
FUNCTIONS = ("acausal_dae", "acausal_jac", "acausal_quad", "acausal_zeros", "acausal_arguments")


FAILURES = {-1: "the solver failed", -2: "a model function failed", -4: f"more than {MAX_NUM_STEPS} steps",
            -5: "out of memory"}


def simulate_native(run, runner, sig, nodes=None):
    """The run (:class:`~acausal.simulation.run.Run`) of a model on the native loop, with the ``runner`` and
    signals ``sig`` of :func:`runner_for` (see the module; a model without state events is one segment); returns
    the Result (``nodes``: its :class:`~acausal.results.result.DenseOutput`'s). Raises :class:`SimulationError`
    where the solver fails (the caller then runs it on the CasADi path)."""
    return integrate_segments(run, NativeSegments(run, runner, sig, nodes))


class NativeSegments:
    """The native loop as a segment integrator (:mod:`acausal.simulation.loop`): each segment one call into
    ``native_dae.c``, which steps SUNDIALS in C, writes the outputs it passes and stops at the first crossing; a
    crossing that makes no event is passed by a new call from it (:data:`MAX_PASSES` per run at most)."""

    def __init__(self, run, runner, sig, nodes=None):
        cm = run.cm
        self.run, self.cm, self.runner, self.sig, self.nodes = run, cm, runner, sig, nodes
        self.names = runner.names
        # the algebraic variables at the outputs (IDAS's)
        self.Z = np.full((runner.nz, run.t_out.size), np.nan) if runner.nz else None
        self.done = {name: 0.0 for name in self.names}  # integral from t_start to where the loop is
        self.passes, self.z_end = 0, None
        self.mute = np.zeros(len(cm.event_zeros), dtype=np.int32)  # passed crossings at the start: none leaving 0

    def advance(self, loop):
        """The segment from ``(loop.t, loop.x)``: calls into the loop until a crossing makes an event (returned:
        ``(t_e, x_e, hits, new modes)``) or the run ends (None)."""
        cm, runner, run = self.cm, self.runner, self.run
        path, names, t_out, n = cm.compiled_path, self.names, run.t_out, len(loop.x)
        seg = loop.segment()
        p, d, u, off = seg.p, seg.d, seg.u, loop.off
        t, x = loop.t, loop.x
        while True:
            loop.outputs_at(t, x, self.done)
            if loop.finished:
                return None
            k_out = loop.k
            # the algebraic variables from where the segment before ended (an event moves them a little)
            z0 = path.algebraic_start(runner.entry, t, x, p, d, u, self.z_end) if runner.nz else np.zeros(0)
            # the start's signs as the other paths see them (an exact 0 in Python may be a round-off off it in C:
            # leaving it is then a crossing at the start, as there)
            g0 = zeros(cm, t, x, p, d, u, off=off) if cm.event_zeros else ()
            status, k, Xs, Qs, t_e, y_e, q_e, dirs, said = runner.run(
                self.sig, seg, t, np.concatenate([x, z0]), g0, self.mute, off, t_out[k_out:])
            if status < 0:
                if status == -3:  # a zero function without a sign: the scipy path's message, naming its event
                    zeros(cm, t_e, y_e[:n], p, d, u, off=off)
                raise SimulationError(f"native event loop: the segment from t = {t:g} s failed: "
                                      f"{FAILURES.get(status, status)}" + (f" ({said})" if said else ""))
            if runner.nz:
                self.Z[:, k_out:k_out + k] = Xs[n:]
            done = self.done
            loop.write(k_out + k, Xs[:n], {name: done[name] + Qs[j] for j, name in enumerate(names)})
            if status == 0:
                return None
            hits = [(t_e, int(i), bool(dirs[i] > 0)) for i in np.flatnonzero(dirs)]
            x_e, self.z_end = y_e[:n].copy(), y_e[n:].copy()
            self.done = {name: done[name] + q_e[j] for j, name in enumerate(names)}
            d_new = event_modes(seg, hits, t_e, x_e)
            if d_new is None:
                self.passes += 1
                if self.passes > MAX_PASSES:
                    raise SimulationError(f"native event loop: more than {MAX_PASSES} crossings that change no mode "
                                          f"by t = {t_e:.9g} s")
                self.mute = (dirs != 0).astype(np.int32)  # a zero function left at exactly 0 there leaves it unseen
                t, x = t_e, x_e
                continue
            self.mute[:] = 0
            return t_e, x_e, hits, d_new

    def result(self, loop):
        """The Result: the outputs, the quadratures (and more by running again, with dense output), the Newton
        blocks' start values from IDAS's algebraic variables."""
        from ...results.result import DenseOutput, Result
        run, cm, runner = self.run, self.cm, self.runner
        path, u = cm.compiled_path, run.u

        def later(more):  # the same run again, those integrated with the states
            more = path.integrable(list(more), u)
            if not more:
                return {}
            again, why = segment_runner(cm, u, more)
            if again is None:
                return {}
            return simulate_native(dataclasses.replace(run, dense_output=False), again, why).dense.integrals

        located = ", events located in its steps" if cm.event_zeros else ""
        return Result(cm, run.t_out, loop.X, run.p, u, loop.D if loop.events else loop.d, events=loop.events,
                      dense=DenseOutput(nodes=self.nodes, integrals=loop.Q,
                                        more=later if run.dense_output else None),
                      solver=f"{'IDAS' if runner.nz else 'CVODES'} (compiled path, native: the model compiled to C"
                             f"{located})", newton_starts=newton_starts(cm, runner, self.Z))


def newton_starts(cm, runner, Z) -> dict | None:
    """The Newton blocks' start values at the outputs (:class:`~acausal.results.result.Result`): IDAS's algebraic
    variables ``Z`` there, an output it did not give (one at a restart: the run's start, an event's time) taking
    its neighbour's. None without algebraic variables."""
    if not runner.nz or not np.isfinite(Z).any(axis=1).all():
        return None
    filled = Z.copy()
    for row in filled:
        given = np.isfinite(row)
        if not given.all():
            k = np.flatnonzero(given)
            row[:] = row[k[np.clip(np.searchsorted(k, np.arange(row.size)), 0, k.size - 1)]]
    names = [cm.unknown_names[i] for i in runner.entry["z_index"]]
    return dict(zip(names, filled))
