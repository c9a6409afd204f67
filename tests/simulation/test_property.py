"""Property-based tests: random linear networks against their exact (matrix-exponential) solutions.

Each test draws a linear network (an electrical RLC ladder or a rotational inertia chain), builds it from
library components, compiles and simulates it tightly (``rtol=1e-10, atol=1e-12``), and compares every
capacitor voltage / inductor current, or every inertia angle / speed, with ``expm`` of the state-space form
``x' = A x + B u`` that the test assembles itself from the drawn values (independently of the compiler).

Inputs are handled with the augmented-matrix trick: a constant input ``u`` is an extra state with ``u' = 0``;
``u0 sin(w t)`` is two extra states ``s' = w c, c' = -w s`` (``s(0) = 0, c(0) = 1``) with the input ``u0 s``.
"""
from __future__ import annotations

import functools

import numpy as np
import pytest
import sympy as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.linalg import expm

from acausal import Model, Start, compile_model, connect, time
from acausal.library.electrical import (Capacitor, ConstantVoltage, Ground, Inductor, PrescribedVoltage,
                                        Resistor)
from acausal.library.rotational import Damper, Fixed, Inertia, Spring, SpringDamper, TorqueSource

RTOL_SIM, ATOL_SIM = 1e-10, 1e-12
REL_ERR = 1e-6
N_TIMES = 25
SCALE_FLOOR = 1e-4

SETTINGS = settings(max_examples=60, deadline=None, derandomize=True, print_blob=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def log_uniform(lo, hi):
    """Floats log-uniformly distributed in [lo, hi] (drawn as the exponent)."""
    return st.floats(np.log10(lo), np.log10(hi), allow_nan=False, allow_infinity=False).map(lambda e: 10.0 ** e)


def exact_solution(A, B, x0, u, times):
    """States of ``x' = A x + B u(t)`` at ``times`` by expm of the augmented matrix.

    ``u`` is ("const", u0) or ("sin", u0, w).
    """
    n = A.shape[0]
    if u[0] == "const":
        M = np.zeros((n + 1, n + 1))
        M[:n, :n], M[:n, n] = A, B * u[1]
        z0 = np.append(x0, 1.0)
    else:
        _, u0, w = u
        M = np.zeros((n + 2, n + 2))
        M[:n, :n], M[:n, n] = A, B * u0  # input u0 * s
        M[n, n + 1], M[n + 1, n] = w, -w  # s' = w c, c' = -w s
        z0 = np.concatenate([x0, [0.0, 1.0]])
    return np.array([(expm(M * t) @ z0)[:n] for t in times]).T


def assert_close(res, names, X_exact, times):
    """Each simulated trajectory within REL_ERR of the exact one, relative to that trajectory's magnitude
    (floored by a small fraction of the largest magnitude of all, so a variable that stays ~0 is judged
    against the scale of the problem rather than against 0, and by SCALE_FLOOR: the drawn values are O(1), and
    the integrator's atol makes absolute errors below ~1e-10 meaningless)."""
    global_scale = max(np.max(np.abs(X_exact)), SCALE_FLOOR)
    for name, exact in zip(names, X_exact):
        got = np.asarray(res[name])
        scale = max(np.max(np.abs(exact)), 1e-3 * global_scale, SCALE_FLOOR)
        err = np.max(np.abs(got - exact)) / scale
        assert err < REL_ERR, (f"{name}: relative error {err:.3g} (max |exact| = {scale:.3g}); "
                               f"sim {got[:4]}..., exact {exact[:4]}...")


# ============================================================================ electrical ladders
SERIES = ("R", "L", "RL")
SHUNT = ("C", "CR")


@st.composite
def ladders(draw):
    """A ladder: sections of (series element, shunt element) with physically sane values.

    Values are drawn as a characteristic resistance and time constants in [0.01, 1] s for a 1 s horizon,
    so eigenvalues stay within about three decades of the horizon.
    """
    n = draw(st.integers(1, 4))
    sections = []
    for _ in range(n):
        series = draw(st.sampled_from(SERIES))
        shunt = draw(st.sampled_from(SHUNT))
        R0 = draw(log_uniform(1.0, 100.0))  # characteristic resistance of the section
        sec = {"series": series, "shunt": shunt,
               "C": draw(log_uniform(0.01, 1.0)) / R0,  # R0 C in [0.01, 1] s
               "v0": draw(st.floats(-2.0, 2.0))}
        if "R" in series:
            sec["R"] = R0 * draw(log_uniform(0.3, 3.0))
        if "L" in series:
            sec["L"] = R0 * draw(log_uniform(0.01, 1.0))  # L / R0 in [0.01, 1] s
            sec["i0"] = draw(st.floats(-0.05, 0.05))
        if shunt == "CR":
            sec["Rp"] = R0 * draw(log_uniform(0.3, 10.0))
        sections.append(sec)
    if draw(st.booleans()):
        u = ("const", draw(st.floats(-10.0, 10.0).filter(lambda v: abs(v) > 0.1)))
    else:
        u = ("sin", draw(st.floats(1.0, 10.0)), draw(st.floats(1.0, 20.0)))
    return sections, u


def ladder_model(sections, u):
    """The acausal model of a ladder: src -> [series_k -> node_k -> shunt_k to ground] for k = 1..N."""

    class Ladder(Model):
        def build(self):
            self.gnd = Ground()
            if u[0] == "const":
                self.src = ConstantVoltage(V=u[1])
            else:
                self.src = PrescribedVoltage(v_ref=u[1] * sp.sin(u[2] * time))
            connect(self.src.n, self.gnd.p)
            node = self.src.p
            for k, sec in enumerate(sections, start=1):
                if "R" in sec["series"]:
                    r = Resistor(R=sec["R"])
                    setattr(self, f"R{k}", r)
                    connect(node, r.p)
                    node = r.n
                if "L" in sec["series"]:
                    ind = Inductor(L=sec["L"], i=Start(sec["i0"]))
                    setattr(self, f"L{k}", ind)
                    connect(node, ind.p)
                    node = ind.n
                cap = Capacitor(C=sec["C"], v=Start(sec["v0"]))
                setattr(self, f"C{k}", cap)
                connect(node, cap.p)
                connect(cap.n, self.gnd.p)
                if sec["shunt"] == "CR":
                    rp = Resistor(R=sec["Rp"])
                    setattr(self, f"Rp{k}", rp)
                    connect(node, rp.p)
                    connect(rp.n, self.gnd.p)
                node = cap.p

    return Ladder()


def ladder_state_space(sections):
    """x = [C1.v .. CN.v, inductor currents in section order]; u = source voltage.

    Section k joins node k-1 (node 0 = source) and node k by a series element carrying current i_k:
    R only: i_k = (v_{k-1} - v_k) / R (algebraic); L / R+L: L i_k' = v_{k-1} - v_k - R i_k (state).
    Node k: C_k v_k' = i_k - i_{k+1} - v_k / Rp_k.
    Each current is written as a row vector over [x, u]: currents[k] @ [x; u].
    """
    n = len(sections)
    l_index = {}
    for k, sec in enumerate(sections):
        if "L" in sec["series"]:
            l_index[k] = n + len(l_index)
    m = n + len(l_index)
    names = [f"C{k + 1}.v" for k in range(n)] + [f"L{k + 1}.i" for k in l_index]
    x0 = np.array([s["v0"] for s in sections] + [sections[k]["i0"] for k in l_index])

    def v_row(k):  # node voltage v_k as a row over [x, u]; node 0 is the source
        r = np.zeros(m + 1)
        r[m if k == 0 else k - 1] = 1.0
        return r

    A = np.zeros((m + 1, m + 1))  # last row/column: u (dropped at the end)
    currents = []
    for k, sec in enumerate(sections):
        drop = v_row(k) - v_row(k + 1)
        if k in l_index:
            j = l_index[k]
            cur = np.zeros(m + 1)
            cur[j] = 1.0
            A[j] = drop / sec["L"]
            if "R" in sec["series"]:
                A[j, j] -= sec["R"] / sec["L"]
        else:
            cur = drop / sec["R"]
        currents.append(cur)
    for k, sec in enumerate(sections):
        net = currents[k] - (currents[k + 1] if k + 1 < n else 0.0)
        if sec["shunt"] == "CR":
            net = net - v_row(k + 1) / sec["Rp"]
        A[k] = net / sec["C"]
    return A[:m, :m], A[:m, m], x0, names


@pytest.mark.slow
@SETTINGS
@given(ladders())
def test_random_ladder_matches_expm(case):
    sections, u = case
    A, B, x0, names = ladder_state_space(sections)
    times = np.linspace(0.0, 1.0, N_TIMES)
    sim = compile_model(ladder_model(sections, u))
    res = sim.simulate(1.0, t_eval=times, rtol=RTOL_SIM, atol=ATOL_SIM)
    X = exact_solution(A, B, x0, u, times)
    assert_close(res, names, X, times)


# ============================================================================ rotational chains
COUPLINGS = ("Spring", "Damper", "SpringDamper")


@st.composite
def chains(draw):
    """N inertias in a row joined by compliant elements; optionally the first tied to a Fixed flange by one
    more element; a torque source (constant or sine) on one of the inertias."""
    n = draw(st.integers(1, 4))
    J = [draw(log_uniform(0.1, 1.0)) for _ in range(n)]
    fixed = draw(st.booleans())
    n_links = n - 1 + (1 if fixed else 0)
    links = []
    for _ in range(n_links):
        kind = draw(st.sampled_from(COUPLINGS))
        links.append({"kind": kind,
                      "c": draw(log_uniform(0.5, 50.0)) if "Spring" in kind else 0.0,
                      "d": draw(log_uniform(0.05, 5.0)) if "Damper" in kind else 0.0})
    phi0 = [draw(st.floats(-1.0, 1.0)) for _ in range(n)]
    w0 = [draw(st.floats(-2.0, 2.0)) for _ in range(n)]
    at = draw(st.integers(0, n - 1))
    if draw(st.booleans()):
        u = ("const", draw(st.floats(-5.0, 5.0).filter(lambda v: abs(v) > 0.1)))
    else:
        u = ("sin", draw(st.floats(0.5, 5.0)), draw(st.floats(1.0, 10.0)))
    return J, fixed, links, phi0, w0, at, u


def chain_model(J, fixed, links, phi0, w0, at, u):
    classes = {"Spring": Spring, "Damper": Damper, "SpringDamper": SpringDamper}

    def make_link(spec):
        kw = {}
        if "Spring" in spec["kind"]:
            kw["c"] = spec["c"]
        if "Damper" in spec["kind"]:
            kw["d"] = spec["d"]
        return classes[spec["kind"]](**kw)

    class Chain(Model):
        def build(self):
            inertias = []
            for k in range(len(J)):
                inertia = Inertia(J=J[k], phi=Start(phi0[k]), w=Start(w0[k]))
                setattr(self, f"J{k + 1}", inertia)
                inertias.append(inertia)
            links_left = list(links)
            if fixed:
                self.fixed = Fixed()
                self.e0 = make_link(links_left.pop(0))
                connect(self.fixed.flange, self.e0.flange_a)
                connect(self.e0.flange_b, inertias[0].flange_a)
            for k, spec in enumerate(links_left, start=1):
                e = make_link(spec)
                setattr(self, f"e{k}", e)
                connect(inertias[k - 1].flange_b, e.flange_a)
                connect(e.flange_b, inertias[k].flange_a)
            tau = u[1] if u[0] == "const" else u[1] * sp.sin(u[2] * time)
            self.src = TorqueSource(tau=tau)
            connect(self.src.flange, inertias[at].flange_b)

    return Chain()


def chain_state_space(J, fixed, links, phi0, w0, at):
    """x = [phi_1..phi_N, w_1..w_N]; phi_k' = w_k; J_k w_k' = sum of link torques + u on inertia ``at``.

    A link with flange_a on body a and flange_b on body b carries tau = c (phi_b - phi_a) + d (w_b - w_a);
    it acts with +tau on a and -tau on b (the Fixed flange is a body at rest at angle 0).
    """
    n = len(J)
    A = np.zeros((2 * n, 2 * n))
    B = np.zeros(2 * n)
    A[:n, n:] = np.eye(n)
    pairs = ([(None, 0)] if fixed else []) + [(k, k + 1) for k in range(n - 1)]
    for (a, b), spec in zip(pairs, links):
        tau = np.zeros(2 * n)  # row over x
        tau[b] += spec["c"]
        tau[n + b] += spec["d"]
        if a is not None:
            tau[a] -= spec["c"]
            tau[n + a] -= spec["d"]
            A[n + a] += tau / J[a]
        A[n + b] -= tau / J[b]
    B[n + at] = 1.0 / J[at]
    names = [f"J{k + 1}.phi" for k in range(n)] + [f"J{k + 1}.w" for k in range(n)]
    return A, B, np.array(list(phi0) + list(w0)), names


@pytest.mark.slow
@SETTINGS
@given(chains())
def test_random_rotational_chain_matches_expm(case):
    J, fixed, links, phi0, w0, at, u = case
    A, B, x0, names = chain_state_space(J, fixed, links, phi0, w0, at)
    times = np.linspace(0.0, 2.0, N_TIMES)
    sim = compile_model(chain_model(*case))
    res = sim.simulate(2.0, t_eval=times, rtol=RTOL_SIM, atol=ATOL_SIM)
    X = exact_solution(A, B, x0, u, times)
    assert_close(res, names, X, times)


# ============================================================================ parameter overrides
_OVERRIDE_SECTIONS = [
    {"series": "R", "shunt": "C", "R": 50.0, "C": 4e-3, "v0": 0.5},
    {"series": "RL", "shunt": "CR", "R": 20.0, "L": 2.0, "i0": 0.01, "C": 5e-3, "Rp": 200.0, "v0": -1.0},
]
_OVERRIDE_U = ("const", 5.0)


@functools.lru_cache(maxsize=None)
def _override_model():
    """Compiled once for the whole test: every example reuses this very CompiledModel."""
    return compile_model(ladder_model(_OVERRIDE_SECTIONS, _OVERRIDE_U))


@settings(max_examples=8, deadline=None, derandomize=True)
@given(st.lists(log_uniform(2.0, 500.0), min_size=2, max_size=2, unique=True))
def test_parameter_override_without_recompiling(r_values):
    sim = _override_model()
    source_before = sim.source
    times = np.linspace(0.0, 1.0, N_TIMES)
    for r1 in r_values:
        sections = [dict(_OVERRIDE_SECTIONS[0], R=r1), _OVERRIDE_SECTIONS[1]]
        A, B, x0, names = ladder_state_space(sections)
        res = sim.simulate(1.0, t_eval=times, params={"R1.R": r1}, rtol=RTOL_SIM, atol=ATOL_SIM)
        assert res.model is sim
        np.testing.assert_allclose(res["R1.R"], r1)
        assert_close(res, names, exact_solution(A, B, x0, _OVERRIDE_U, times), times)
    assert _override_model() is sim and sim.source == source_before  # same object, nothing regenerated
    # and the defaults still hold afterwards (overrides do not stick)
    A, B, x0, names = ladder_state_space(_OVERRIDE_SECTIONS)
    res = sim.simulate(1.0, t_eval=times, rtol=RTOL_SIM, atol=ATOL_SIM)
    assert_close(res, names, exact_solution(A, B, x0, _OVERRIDE_U, times), times)


def test_state_space_helpers_agree_on_a_hand_example():
    """Sanity check of the test's own reference: one RC section, constant input, closed form."""
    sec = [{"series": "R", "shunt": "C", "R": 100.0, "C": 1e-3, "v0": 0.0}]
    A, B, x0, names = ladder_state_space(sec)
    times = np.linspace(0.0, 1.0, 11)
    X = exact_solution(A, B, x0, ("const", 10.0), times)
    np.testing.assert_allclose(X[0], 10.0 * (1 - np.exp(-times / 0.1)), rtol=1e-12, atol=1e-12)
    # sine input, RC: compare with scipy ODE integration of the same A, B
    from scipy.integrate import solve_ivp
    sol = solve_ivp(lambda t, x: A @ x + B * 3.0 * np.sin(7.0 * t), (0, 1), x0, t_eval=times, rtol=1e-12,
                    atol=1e-14)
    np.testing.assert_allclose(exact_solution(A, B, x0, ("sin", 3.0, 7.0), times), sol.y, rtol=1e-8, atol=1e-10)


if __name__ == "__main__":  # pragma: no cover
    pytest.main([__file__, "-q"])
