"""Shared tolerances and checks of the MSL conformance suite (the modules ``tests/test_msl_conformance*.py``; the
tolerances are explained in ``tests/msl/test_msl_conformance.py``'s docstring)."""
import numpy as np

BALANCE_TOL = 1e-5  # relative energy-balance residual: ten times the integrator's rtol (see the module docstring)
RTOL = 1e-6  # the library's default relative tolerance
ATOL = 1e-9  # the library's default absolute tolerance


def phase_tol(phase: float, rtol: float = RTOL) -> float:
    """Tolerance (fraction of a signal's peak) for a linear oscillating system: an integrator holding the local
    error to rtol leaves a phase error of about rtol per radian its slowest-decaying mode travels, and that error
    is not damped away within the mode's memory; ``phase`` [rad] is what the mode travels over the run (or over
    its decay time, if shorter). Four times rtol per radian, so a correct solver passes with margin, while a model
    with one parameter 1 % off fails it several times over (First, DCPM_Start: 5-9x)."""
    return 4 * rtol * phase


METHODS = ["auto", "BDF"]  # the default path, and the scipy path's BDF


def compiled_path_available() -> bool:
    from acausal.simulation.compiled import available
    return available()


def check_energy(res, sim, tol=BALANCE_TOL):
    """The energy balance closes to ``tol`` and every loss is >= 0 at every output (to round-off of its own scale)."""
    residual = res.energy_balance().residual
    assert abs(residual) < tol, res.energy_balance().table()
    for name in sim.accounts.losses:
        p = np.asarray(res[name])
        assert p.min() >= -1e-9 * max(1.0, np.abs(p).max()), f"{name} < 0: min {p.min():.3g} W at t = " \
                                                              f"{res.t[np.argmin(p)]:.6g} s"
