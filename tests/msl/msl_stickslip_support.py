"""Shared checks of the MSL stick/slip conformance examples (``tests/msl/test_msl_conformance_stickslip.py``: the gear
demos; ``tests/msl/test_msl_conformance_friction.py``: Friction)."""
import numpy as np

from .msl_support import BALANCE_TOL, check_energy


# Shared by the four examples. A friction element's mode is +1 sliding forward, 0 stuck, -1 sliding backward
# (MSL's ``mode``); the library's PartialFriction elements carry it as ``stuck`` and ``forward``.
EVENT_T_TOL = 1e-6  # s: every mode change of a friction element (see the tests' docstrings for the margins)


def friction_mode(res, element: str) -> np.ndarray:
    """MSL's ``mode`` of a library stick/slip element at the outputs: 0 stuck, +1 forward, -1 backward."""
    return np.where(res[f"{element}.stuck"] == 1, 0, np.where(res[f"{element}.forward"] == 1, 1, -1))


def mode_changes(res, dense, element: str, side=1e-6) -> list:
    """Instants t > 0 where ``element`` changes mode: the events of ``res`` at which its mode ``side`` before
    differs from its mode ``side`` after, read from ``dense`` (the same run with outputs there, see
    :func:`check_losses_around_events`; or ``res`` itself, its outputs on either side of the event). A mode
    change can come from the element's own event (a stick, a breakaway) or from the event iteration after another
    one (a load that steps on at a time event breaks a stuck gear away), so it is read from the modes, not from
    which event fired."""
    mode = friction_mode(dense, element)
    out = []
    for t in sorted({float(t) for t, _, _ in res.events if t > 0}):
        k0 = np.searchsorted(dense.t, t - side, side="right") - 1  # the last output at or before t - side
        k1 = np.searchsorted(dense.t, t + side, side="left")  # the first at or after t + side
        if 0 <= k0 and k1 < dense.t.size and mode[k0] != mode[k1]:
            out.append(t)
    return out


def check_mode_changes(res, dense, element: str, ref_changes, t_tol=EVENT_T_TOL):
    """The element changes mode (:func:`mode_changes`) at the reference's instants t > 0, each within ``t_tol``;
    a stick followed by a breakaway at the same instant (a reversal passing straight through) counts once."""
    ref = sorted({round(t, 12) for t, _, _ in ref_changes if t > 0})
    got = mode_changes(res, dense, element)
    assert len(got) == len(ref), (element, got, ref)
    dt = np.max(np.abs(np.array(got) - np.array(ref))) if ref else 0.0
    assert dt < t_tol, (element, dt, got, ref)


def check_modes_at_outputs(res, element: str, ref_mode, ref_changes, clear=1e-5):
    """The element's mode equals the reference's at every output farther than ``clear`` from a mode change
    (there an instant off by ``EVENT_T_TOL`` may put the output on either side)."""
    t_change = np.array([t for t, _, _ in ref_changes] or [np.inf])
    far = np.min(np.abs(res.t[:, None] - t_change[None, :]), axis=1) > clear
    got = friction_mode(res, element)
    bad = far & (got != ref_mode)
    assert not bad.any(), f"{element}: mode {got[bad][:3]} against {ref_mode[bad][:3]} at t = {res.t[bad][:3]}"


def check_losses_around_events(sim, res, t_end, offsets=(-1e-6, -1e-8, 0.0, 1e-8, 1e-6), balance=True,
                               t_tol=EVENT_T_TOL, **kw):
    """``loss_power >= 0`` of every loss at the mode changes too: the run is repeated with outputs at each event
    of the first run and on both sides of it (1e-8 and 1e-6 s away); its events must be those of the first run
    (within ``t_tol``: where the outputs lie does not change the answer). ``kw``: the first run's settings.
    Returns the repeated run."""
    te = np.array([t for t, _, _ in res.events])
    extra = (te[:, None] + np.array(offsets)[None, :]).ravel()
    t_eval = np.unique(np.concatenate([res.t, extra[(extra >= 0) & (extra <= t_end)]]))
    dense = sim.simulate(t_end, t_eval=t_eval, **kw)
    got = [t for t, _, _ in dense.events]
    assert len(got) == len(te) and np.max(np.abs(np.array(got) - te), initial=0.0) < t_tol, (got, te)
    check_energy(dense, sim, BALANCE_TOL if balance else np.inf)
    return dense


def moved_residual(res) -> float:
    """The energy balance's residual [J] over the largest energy that moved (a boundary's work, a loss or a
    change of stored energy). ``Balance.residual`` divides by the energy *delivered*; in MSL Friction the
    drive delivers 24 J while the brake and clutch dissipate 9 kJ of the inertias' initial kinetic energy, so
    that ratio measures the dissipation's accuracy against the 24 J (the trust check divides as here)."""
    b = res.energy_balance()
    terms = [*b.sources.values(), *b.boundary.values(), *b.losses.values(), *b.stored.values()]
    return (sum(b.sources.values()) + sum(b.boundary.values()) - sum(b.losses.values())
            - sum(b.stored.values())) / max(abs(v) for v in terms)


# ---------------------------------------------------------------- the MSL LossyGear written out by hand
