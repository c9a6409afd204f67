"""Trust checks on every simulation: a result that the integrator's own accuracy cannot vouch for is flagged.

Three checks run after each :func:`~acausal.simulation.simulate.simulate` (``trust="raise"``, the default: a
:class:`UntrustedResult` error; ``"warn"``: a :class:`UntrustedResultWarning`; ``"off"``: none). What they found
is kept as :attr:`Result.trust <acausal.results.result.Result.trust>` (an empty list when the result passed).

* **Finite values.** A state that is not finite at any output time, or a variable that is not finite at one of the
  sampled output times (a zero resistance across a source: an infinite current; the square root of a state that
  crossed zero): named with where it starts and its solved equation. The other checks are skipped then.
* **Conditioning of the energy accounts.** Every loss power, source power and stored energy is a function of the
  states. At a sample of output times each state is moved by its own error tolerance (``atol + rtol |x|``, what
  the integrator lets it be off by) and these variables evaluated again: one that moves by more than
  :data:`CONDITION_LIMIT` of its range over the run is not determined by the integration (the loss of a 1 nohm
  resistor, whose current is the difference of two nearly equal potentials divided by the resistance: the states
  are right to 1e-6 V, the current is off by amperes). The message names the variables, their equations, the
  state they hang on and the parameters in the equations. Other variables are not checked: an acceleration that
  is zero at every output (a drive in steady state) is, relative to itself, just as undetermined, and harmless.
* **Energy balance** (models with energy accounts, runs with ``dense_output``): source = losses + output +
  change in stored energy, relative to the largest energy that moved, within :func:`balance_limit` of the run's
  ``rtol`` (1000 ``rtol``, at least 1e-5; a run moving less than 1e-12 J is not checked). An integrator that took steps
  its error test should not have accepted (a stiff system on an explicit or a badly conditioned implicit method) breaks
  it.

  A residual that no account explains is told apart as a loose tolerance or a model stiff for the integrator by
  runs 100 and 10^4 times tighter. These runs share a budget (:data:`acausal.simulation.simulate.RETRY_STEPS`
  steps, ``RETRY_SECONDS`` seconds; :class:`acausal.simulation.run.Budget`) and never fall back to a slower path:
  where the first of them spends it (a thermostat's switch on a state, which chatters and takes steps that grow as
  fast as the tolerance tightens), the check says it could not conclude, as an :class:`UncheckedResultWarning`
  (its finding an :class:`Unconcluded`), and the result is returned.

The step-count guard of the scipy path (``max_steps``) is in :mod:`acausal.simulation.simulate`: a run that would take
longer than any sensible one (a stiff model on an explicit method) stops with an error instead of running on.
"""
from __future__ import annotations

import functools
import warnings

import numpy as np

from . import finite
from ..errors import AcausalError, BudgetExceeded, SimulationError
from ..backends.numpy.runtime import rows

CONDITION_LIMIT = 0.1  # a variable may move by this fraction of its range when the states move by their tolerance
SAMPLES = 21  # output times at which the conditioning is checked (evenly spread, both ends included)
MODES = ("raise", "warn", "off")
ENERGY_FLOOR = 1e-12  # J: a run that moves less energy than this has no balance to check


class UntrustedResult(SimulationError):
    """A simulation whose result the trust checks reject (see :mod:`acausal.results.trust`)."""


class UntrustedResultWarning(UserWarning):
    """A simulation whose result the trust checks flag, run with ``trust="warn"``."""


class UncheckedResultWarning(UntrustedResultWarning):
    """A simulation a trust check could not conclude on within its budget (:class:`Unconcluded`), whatever
    ``trust`` (but ``"off"``) says: the result is returned, the warning names what could not be checked and why."""


class Unconcluded(str):
    """A finding (in :attr:`Result.trust <acausal.results.result.Result.trust>`, a string like the others) that says
    a check could not conclude: warned about, never raised (unless with other findings)."""


def check_mode(trust) -> str:
    if trust not in MODES:
        from ..errors import ModelError
        raise ModelError(f"simulate: trust must be one of {', '.join(map(repr, MODES))}, got {trust!r}")
    return trust


def balance_limit(rtol: float) -> float:
    """The largest relative energy-balance residual a run at ``rtol`` may leave: 1000 rtol, at least 1e-5 (an
    oscillator's energy, passed back and forth for many periods, gathers the local errors of every step)."""
    return max(1000.0 * float(np.max(rtol)), 1e-5)


def check(res, rtol, atol, trust: str, dense_output: bool, retry=None) -> None:
    """Run the checks on ``res`` and act on ``trust``; the findings go to ``res.trust``. ``retry``: see
    :func:`energy_balance`."""
    res.trust = []
    if trust == "off":
        return
    findings = _once(res, ("nonfinite",), lambda: nonfinite(res)) or _once(res, ("poles",), lambda: poles(res))
    if not findings:  # a NaN, an infinity or a pole makes the other checks meaningless
        findings = conditioning(res, rtol, atol)
        if dense_output:
            findings += energy_balance(res, rtol, retry)
    res.trust = findings
    if not findings:
        return
    refused = [f for f in findings if not isinstance(f, Unconcluded)]
    head = f"simulate {res.model.flat.name} ({res.solver or 'no integrator'}): " + \
        ("the result cannot be trusted: " if refused else "")
    text = head + "; ".join(findings)
    if trust == "raise" and refused:
        raise UntrustedResult(text + ' (simulate(..., trust="warn") returns it with a warning)')
    warnings.warn(text, UntrustedResultWarning if refused else UncheckedResultWarning, stacklevel=4)


def nonfinite(res) -> list:
    """A state that is not finite at some output time, or a variable that is not finite at one of the
    :data:`SAMPLES` output times the conditioning samples (a zero resistance across a source, the square root of
    a state that crossed zero): one finding naming the first few, where from, and their solved equations. A result
    that has not evaluated its unknowns has only those evaluated whose equation can leave the finite numbers
    (:mod:`acausal.results.finite`), where its states, parameters and divisors allow that analysis."""
    cm = res.model
    N = res.t.size
    if N == 0:
        return []
    X = np.asarray(res.states, dtype=float)
    bad = _first_nonfinite(cm.state_names, X, res.t)
    if not bad and cm.unknown_names:
        k = _samples(N)
        names = cm.unknown_names
        if res.evaluated():  # the outputs' values are there
            vals = np.array([res[name][k] for name in names])
        else:
            D = res.modes if np.ndim(res.modes) == 1 else np.asarray(res.modes)[:, k]
            if finite.moderate(cm, X, res.params, D if np.ndim(D) == 1 else D[:, 0], res.inputs, res.t[0]):
                names = finite.plan(cm)[0]  # the others are finite by construction (acausal.results.finite)
            with np.errstate(all="ignore"):
                vals = rows(cm.generator.values_function(list(names))(res.t[k], X[:, k], res.params, D, res.inputs),
                            k.size) if names else np.zeros((0, k.size))
        bad = _first_nonfinite(names, vals, res.t[k])
    if not bad:
        return []
    items = []
    for name, t, v in bad[:3]:
        expr = None if name in cm.state_names else _solved(cm, name)[0]
        eq = "" if expr is None else f" ({name} = {expr})"
        items.append(f"{name} is {v} from t = {t:g} s{eq}")
    more = f" and {len(bad) - 3} more" if len(bad) > 3 else ""
    return [f"not finite: {'; '.join(items)}{more} (a division by zero or a square root of a negative number in "
            "the model's equations: check the parameters named there)"]


def poles(res) -> list:
    """A variable solved as a quotient whose divisor changes sign between two output times: it went through a
    pole there (``y = 1/x`` with ``x`` crossing zero gives a huge value, then one of the other sign, both finite).
    One finding naming the first few, with the divisor and the times. Divisors of parameters only are the
    parameters' checks (:class:`~acausal.model.components.Parameter` ``min``, ``nonzero``)."""
    import sympy as sp

    cm = res.model
    found = cm.derived.get("trust: divisors")
    if found is None:
        from ..compile.solve import Assign
        found = []
        for st in cm.steps:
            if not isinstance(st, Assign) or not isinstance(st.expr, sp.Basic):
                continue
            for pw in st.expr.atoms(sp.Pow):
                base, ex = pw.args
                if ex.is_number and ex.is_negative and any(not cm.has_parameter(str(x)) and str(x) != "time"
                                                           for x in base.free_symbols):
                    found.append((str(st.var), base))
        cm.derived["trust: divisors"] = found
    if not found or res.t.size < 2:
        return []
    items = []
    for name, base in found:
        try:
            values = {str(x): res[str(x)] for x in base.free_symbols if not cm.has_parameter(str(x))
                      and str(x) != "time"}
            with np.errstate(all="ignore"):
                v = np.broadcast_to(np.asarray(cm.eval_expr(base, values, res.params, None, res.t), dtype=float),
                                    res.t.shape)
        except (KeyError, AcausalError, TypeError, ValueError):  # a divisor the result cannot evaluate: not judged
            continue
        flip = np.flatnonzero(v[:-1] * v[1:] < 0)
        if flip.size:
            k = int(flip[0])
            items.append(f"{name} (its divisor {base} changes sign between t = {res.t[k]:.6g} and "
                         f"{res.t[k + 1]:.6g} s)")
    if not items:
        return []
    more = f" and {len(items) - 3} more" if len(items) > 3 else ""
    return [f"through a pole: {'; '.join(items[:3])}{more}: its values there are meaningless (a division by a "
            "variable that crosses zero: check the model's equations or its range of operation)"]


def _first_nonfinite(names, values, t) -> list:
    """``(name, time, value)`` where each row of ``values`` (at times ``t``) is first not finite."""
    finite = np.isfinite(values)
    if finite.all():
        return []
    rows = np.flatnonzero(~finite.all(axis=1))
    first = np.argmax(~finite[rows], axis=1)
    return [(names[i], float(t[c]), float(values[i, c])) for i, c in zip(rows, first)]


def conditioning(res, rtol, atol) -> list:
    """The variables that move by more than :data:`CONDITION_LIMIT` of their range when a state moves by its
    error tolerance: one finding naming the worst three, their equations and the states they hang on."""
    cm = res.model
    n = len(cm.state_names)
    watched, power, names = _watched(cm)
    N = res.t.size
    if n == 0 or N == 0 or not watched:
        return []
    T, XX, D, tol = _moved_samples(res, rtol, atol)
    kk = _moved_layout(N, n)[0][N:]
    with np.errstate(all="ignore"):
        if res.evaluated():  # the outputs' values are there: every unknown at the moved samples
            R = np.array([res[name] for name in names])
            vals = np.array(res.unknowns_at(T[N:], XX[:, N:], D if np.ndim(D) == 1 else D[:, N:], near=kk))[watched]
        else:  # only the watched variables (a slice of the steps), at the outputs and the moved samples at once
            both = rows(cm.generator.values_function(names)(T, XX, res.params, D, res.inputs), T.size)
            R, vals = both[:, :N], both[:, N:]
        dv = np.abs(vals - R[:, kk])  # [variable, moved sample]
        top, low = R.max(axis=1), R.min(axis=1)
    dv[~np.isfinite(dv)] = 0.0
    peak = dv.max(axis=1)
    scale, ratio = _scales(top, low, power, peak)
    if not ratio.max() > CONDITION_LIMIT:
        return []
    # the range on the output grid can miss a transient between two outputs (a stiff spring's millisecond on a grid
    # of 0.25 s): judged again on the range over the integrator's steps
    steps_top, steps_low = _range_on_steps(res, names, power)
    with np.errstate(invalid="ignore"):
        scale, ratio = _scales(np.fmax(top, steps_top), np.fmin(low, steps_low), power, peak)
    if not ratio.max() > CONDITION_LIMIT:
        return []
    dv = dv.reshape(len(watched), n, -1)  # [variable, state, sample]
    moved = dv.max(axis=1)  # [variable, sample]
    t = res.t[_samples(N)]
    worst = dv.argmax(axis=1)  # [variable, sample]: the state that moves it most
    duration = float(res.t[-1] - res.t[0]) or 1.0
    negligible = peak * np.where(power, duration, 1.0) < ENERGY_FLOOR
    bad = [q for q in np.argsort(-ratio, kind="stable") if ratio[q] > CONDITION_LIMIT and not negligible[q]]
    if not bad:
        return []
    items, states, params = [], [], set()
    for q in bad[:3]:
        col = int(np.argmax(moved[q]))
        j = int(worst[q, col])
        name = cm.unknown_names[watched[q]]
        expr, used = _solved(cm, name)
        params |= used
        for sym in getattr(expr, "free_symbols", ()):  # one level down: a loss v*i, its i = v/R
            params |= _solved(cm, str(sym))[1]
        states.append(f"{cm.state_names[j]!r} by {tol[j, col]:.3g}")
        items.append(f"{name!r} by {moved[q, col]:.3g} (its range {scale[q]:.3g}; at t = {t[col]:.6g} s"
                     f"{'; ' + name + ' = ' + str(expr) if expr is not None else ''})")
    more = f" and {len(bad) - 3} more" if len(bad) > 3 else ""
    culprits = f"; parameters in these equations: {', '.join(sorted(params))}" if params else ""
    return [f"variables not determined by the integration: {', '.join(items)}{more} move by more than "
            f"{CONDITION_LIMIT:g} of their range when a state moves by its error tolerance "
            f"({', '.join(dict.fromkeys(states))}): tighten atol/rtol, or make the model less stiff{culprits}"]


def _scales(top, low, power, peak) -> tuple:
    """``(scale, peak / scale)`` of the watched variables whose largest and smallest values over the run are ``top``
    and ``low`` and that move by ``peak`` when a state moves by its tolerance: the scale a variable's move is judged
    against (its range; one that barely changes: its size; one that stays near zero: the largest swing of its kind,
    powers or stored energies, in the model, a millionth of it: an inductor that never carries current)."""
    with np.errstate(invalid="ignore"):
        span, size = top - low, np.maximum(np.abs(top), np.abs(low))
    if not np.isfinite(span).all():
        span, size = span.copy(), size.copy()
        span[~np.isfinite(span)], size[~np.isfinite(size)] = 0.0, 0.0
    spans = span.tolist()
    kinds = power.tolist()
    floor = np.where(power, max((s for s, pw in zip(spans, kinds) if pw), default=0.0),
                     max((s for s, pw in zip(spans, kinds) if not pw), default=0.0))
    scale = np.maximum(np.maximum(span, 1e-3 * size), 1e-6 * floor)
    return scale, peak / np.where(scale > 0, scale, np.inf)  # a variable that never moves: 0


def _range_on_steps(res, names, power) -> tuple:
    """``(largest, smallest)`` value of each watched variable ``names`` over the integrator's steps, where the run
    keeps them (``-inf``, ``inf`` where it does not): on the scipy path at the Gauss nodes of its accepted steps (the
    states on their interpolants); where the energies were integrated with the states (the compiled path's
    quadratures, the scipy path's energies as states), a power's mean over each output interval, which its largest
    value is no less than and its smallest no more than."""
    cm = res.model
    top, low = np.full(len(names), -np.inf), np.full(len(names), np.inf)
    if res.t.size < 2:
        return top, low
    with np.errstate(all="ignore"):
        if res.dense.steps and res.dense.nodes is None:
            _, tn, _, _, Xn, Dn = res._node_samples()
            if tn.size:
                vals = rows(cm.generator.values_function(names)(tn.ravel(), Xn, res.params, Dn, res.inputs), tn.size)
                vals = np.where(np.isfinite(vals), vals, np.nan)
                seen = ~np.all(np.isnan(vals), axis=1)
                top[seen] = np.nanmax(vals[seen], axis=1)
                low[seen] = np.nanmin(vals[seen], axis=1)
        dt = np.diff(res.t)
        wide = dt > 0
        for i, name in enumerate(names):
            q = res.dense.integrals.get(name) if power[i] else None
            if q is None or not wide.any():
                continue
            mean = (np.diff(np.asarray(q, dtype=float))[wide]) / dt[wide]
            mean = mean[np.isfinite(mean)]
            if mean.size:
                top[i], low[i] = max(top[i], float(mean.max())), min(low[i], float(mean.min()))
    return top, low


def _watched(cm) -> tuple:
    """``(indices into cm.unknown_names, is-a-power mask, names)`` of the variables the conditioning check watches:
    the model's loss and source powers and stored energies (found once per model)."""
    found = cm.derived.get("trust: watched")
    if found is None:
        acc = cm.accounts
        index = {name: i for i, name in enumerate(cm.unknown_names)}
        names = [] if acc is None else [v for v in dict.fromkeys(acc.losses + acc.sources + acc.stored) if v in index]
        found = ([index[v] for v in names], np.array([v in acc.losses or v in acc.sources for v in names], dtype=bool),
                 names)
        cm.derived["trust: watched"] = found
    return found


def _moved_samples(res, rtol, atol) -> tuple:
    """``(times, states, modes, tolerances)`` of the conditioning check: the outputs, then the :func:`_samples`
    output times once per state, state ``j`` moved by its error tolerance ``atol + rtol |x_j|`` in the ``j``-th
    copy (the columns ``N + j m`` to ``N + (j + 1) m``); the tolerances as ``[state, sample]``."""
    n = len(res.model.state_names)
    at, r, c = _moved_layout(res.t.size, n)
    XX = np.asarray(res.states, dtype=float)[:, at]
    x = XX[r, c]  # state j in its own copy
    if isinstance(atol, float) and isinstance(rtol, float):
        tol = atol + rtol * np.abs(x)
    else:
        tol = np.broadcast_to(np.asarray(atol, dtype=float), (n,))[r] + \
            np.broadcast_to(np.asarray(rtol, dtype=float), (n,))[r] * np.abs(x)
    XX[r, c] = x + tol
    D = res.modes if np.ndim(res.modes) == 1 else np.asarray(res.modes)[:, at]
    return res.t[at], XX, D, tol.reshape(n, -1)


@functools.lru_cache(maxsize=64)
def _moved_layout(size: int, n: int) -> tuple:
    """``(outputs, rows, columns)`` of :func:`_moved_samples` for ``n`` states and ``size`` outputs: the output
    index of each point (every output, then the :func:`_samples` once per state) and where in ``[state, point]``
    the moved state sits."""
    k = _samples(size)
    at = np.concatenate([np.arange(size), np.tile(k, n)])
    r, c = np.repeat(np.arange(n), k.size), size + np.arange(n * k.size)
    for a in (at, r, c):
        a.setflags(write=False)
    return at, r, c


@functools.lru_cache(maxsize=64)
def _samples(size: int) -> np.ndarray:
    """The output indices the conditioning is checked at: :data:`SAMPLES` evenly spread, both ends included."""
    k = np.unique(np.linspace(0, size - 1, min(SAMPLES, size)).astype(int))
    k.setflags(write=False)
    return k


def _solved(cm, name: str):
    """``(expression, its parameters)`` of the solved equation of ``name`` (the usual culprit of an
    ill-conditioned variable: a tiny resistance, a huge gain), or ``(None, set())`` when it is solved in a block."""
    expr = cm.program.assignment(name)
    if expr is None:
        return None, set()
    return expr, {str(s) for s in expr.free_symbols if cm.has_parameter(str(s))}


def integration_fault(res, rtol) -> bool:
    """Whether a scipy-path result (``res.scipy_method``) fails the energy balance only by the integration of its
    energies: every value finite, no pole, every component's account holding at each instant
    (:func:`wrong_accounts`), the energies integrated on the steps' interpolants.
    :func:`~acausal.simulation.simulate.simulate` then runs again with the energies as states
    (:mod:`acausal.simulation.scipy.quadratures`)."""
    if getattr(res, "scipy_method", None) is None or res.dense.integrals:
        return False
    if _once(res, ("nonfinite",), lambda: nonfinite(res)) or _once(res, ("poles",), lambda: poles(res)):
        return False
    return bool(energy_balance(res, rtol)) and not wrong_accounts(res)


def balance_scale(res) -> float | None:
    """The largest energy that moved in ``res`` [J] (the energy balance's scale), or None: no balance to check."""
    found = _residual(res)
    return None if found is None else float(found[1])


def _once(res, key, find) -> list:
    """``find()``'s findings on ``res``, found once per result (the re-run decision and the check share them)."""
    key = ("trust:",) + key
    if key not in res._cache:
        res._cache[key] = find()
    return res._cache[key]


def energy_balance(res, rtol, retry=None) -> list:
    """The energy balance residual relative to the largest energy that moved (through an account, or between the
    forms inside one: :func:`_exchanged`), if over :func:`balance_limit` (found once per result and tolerance).
    With ``retry`` (``retry(k)`` runs the model again with both tolerances divided by ``k``, unchecked), a residual
    that no account explains is told apart by runs :data:`TIGHTER` times tighter: closed by one (within its own
    :func:`balance_limit`), the tolerance is too loose for this balance and the message gives that rtol; open in
    all, the model is stiff for the integrator."""
    key = ("balance", float(np.max(rtol)), retry is not None)
    return _once(res, key, lambda: _energy_balance(res, rtol, retry))


#: how much tighter (both tolerances divided by each in turn) the runs are that tell a loose tolerance from a stiff
#: model: closed by one of them (within that run's own limit), the tolerance was too loose
TIGHTER = (100.0, 10_000.0)


def _residual(res) -> tuple | None:
    """(unaccounted energy [J], the largest energy that moved [J], their ratio), or None: no balance to check
    (:func:`acausal.results.run_balance.residual`: the run's totals where it integrated them)."""
    from .run_balance import residual
    return residual(res, ENERGY_FLOOR)


def _energy_balance(res, rtol, retry) -> list:
    found = _residual(res)
    limit = balance_limit(rtol)
    if found is None or found[2] <= limit:
        return []
    total, scale, rel = found
    wrong = wrong_accounts(res)
    left = (f"the energy balance leaves {total:.3g} J of {scale:.3g} J unaccounted (relative {rel:.2g} > {limit:.2g}, "
            f"the limit at rtol {float(np.max(rtol)):g})")
    if wrong:
        return [left + ": an account is wrong: " + "; ".join(wrong) + ": check the sign and the factor of its "
                "loss_power, energy or source_power equation (or a port it leaves out)"]
    cause = _integration_cause(res, rtol, limit, retry)
    if isinstance(cause, Unconcluded):
        return [Unconcluded(f"the energy balance could not be checked: it leaves {total:.3g} J of {scale:.3g} J "
                            f"unaccounted (relative {rel:.2g} > {limit:.2g}, the limit at rtol "
                            f"{float(np.max(rtol)):g}) with every component's account holding at each instant, "
                            f"and {cause}")]
    return [left + ": every component's account holds at each instant, so the residual is the integration's: " + cause]


def _integration_cause(res, rtol, limit, retry) -> str:
    """Too loose a tolerance, or a model stiff for the integrator: told apart by a tighter run when ``retry``; an
    :class:`Unconcluded` where the first tighter run spent the budget of the check's own runs
    (:data:`acausal.simulation.simulate.RETRY_STEPS`, ``RETRY_SECONDS``) before it ended."""
    if "compiled path" in (res.solver or "") or res.dense.integrals:  # energies integrated under the error control
        stiff = "the integrator accepted steps it should not have (a stiff model)"
    else:
        stiff = ("the scipy path integrates energies on its steps' interpolants, which a stiff model (a switch "
                 "through a tiny resistance) leaves uncertain: the compiled path (method='auto', with CasADi) "
                 "integrates them under the integrator's error control")
    if retry is None:
        return stiff + "; or tighten rtol/atol"
    tried = []
    for k in TIGHTER:
        tight = float(np.max(rtol)) / k
        try:
            found = _residual(retry(k))
        except BudgetExceeded as e:
            if tried:  # a tighter run left it open: stiff, whatever the next would have said
                tried.append(f"a run at rtol {tight:g} {e}")
                break
            return Unconcluded(
                f"the run at rtol {tight:g} that tells a loose tolerance from a model stiff for the integrator {e} "
                "(the check's own runs stop there): the states may be right, the energies are uncertain by that "
                "residual. A right-hand side that jumps with a state (a Piecewise of a state, which makes no "
                "event: the integrator steps across the jump again and again) takes steps that grow as fast as the "
                "tolerance tightens; make the switch an Event, or check the run at a tighter rtol yourself")
        except AcausalError as e:
            tried.append(f"a run at rtol {tight:g} failed ({e})")
            break
        left = 0.0 if found is None else found[2]
        if left <= balance_limit(tight):
            return (f"the tolerance is too loose for this balance: a run at rtol {tight:g} (atol divided by {k:g} "
                    f"too) leaves {left:.2g}, within its limit {balance_limit(tight):.2g}: pass rtol={tight:g}")
        tried.append(f"at rtol {tight:g} {left:.2g}")
    return f"{stiff} (a tighter tolerance does not close it: {', '.join(tried)})"


#: a component's power balance off by more than this fraction of its largest term at some output time is wrong
#: (a correct account holds to round-off at every instant, whatever the integration's error; the margin covers a
#: stored energy whose rate the model does not compute and that is differentiated on the output grid)
ACCOUNT_LIMIT = 0.01


def wrong_accounts(res) -> list:
    """The components whose own account does not hold at the output times: the power into the component through
    its physical ports plus its ``source_power`` differs from its ``loss_power`` (unless the loss leaves through
    its heat ports, which are then among the ports) plus the rate of its stored ``energy`` by more than
    :data:`ACCOUNT_LIMIT` of the largest of these terms. Each named with the worst mismatch and its time."""
    acc = res.model.accounts
    owners: dict = {}
    for kind, names in (("loss", acc.losses), ("stored", acc.stored), ("source", acc.sources)):
        for name in names:
            owners.setdefault(name.rsplit(".", 1)[0], {}).setdefault(kind, []).append(name)
    out = []
    for comp, parts in owners.items():
        try:
            ports = res._through(comp)
            flows = [np.asarray(res.power(p), dtype=float) for p in ports]
            heat = any(f"{p}.Q_flow" in res._known_names() for p in ports)
            terms = flows + [np.asarray(res[n], dtype=float) for n in parts.get("source", [])]
            terms += [-np.asarray(res[n], dtype=float) for n in parts.get("loss", []) if not heat]
            terms += [-np.asarray(res.der(n), dtype=float) for n in parts.get("stored", [])]
        except (KeyError, ValueError, AcausalError):  # a port the result cannot give a power for: not judged
            continue
        terms = [np.broadcast_to(v, res.t.shape) for v in terms]
        size = max(float(np.max(np.abs(v))) for v in terms) if terms else 0.0
        if not size > 0:
            continue
        r = np.sum(terms, axis=0)
        k = int(np.argmax(np.abs(r)))
        if abs(r[k]) > ACCOUNT_LIMIT * size:
            out.append(f"{comp!r}: the power into it through {', '.join(ports)} and its accounts differ by "
                       f"{r[k]:.3g} W at t = {res.t[k]:.6g} s (its largest term {size:.3g} W)")
    return out
