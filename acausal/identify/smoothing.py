"""Smoothing measured signals before they are differentiated.

A replay prescribes measured angles; index reduction then asks for their first to third derivatives (motor
acceleration, and the inductance's di/dt). Encoder readings are quantised (a 14-bit encoder has steps of
2 pi / 16384 = 0.38 mrad) and noisy, and finite differences of them are useless. :class:`SmoothingSpline` fits a
least-squares B-spline of degree 5 with uniformly spaced knots (spacing ``knot_spacing``) to the samples. The knot
spacing is the smoothing parameter: it acts like a low-pass filter with a cut-off near ``1 / (2 knot_spacing)``
(25 ms -> about 20 Hz, well above the gait's content at 1.2-3 s per stride and below the quantisation and noise),
it has no phase lag (it is a fit, not a causal filter) and its derivatives up to the fourth are continuous. The
first and last knot span of a recording are less accurate (the fit is one-sided there): calibration leaves out a
margin of ``edge_margin(knot_spacing)`` at both ends.
"""
from __future__ import annotations

import numpy as np
from scipy.interpolate import PPoly, make_lsq_spline

from ..errors import DataError
from ..signals import PiecewisePolynomial, Signal

DEFAULT_KNOT_SPACING = 0.025  # s


def edge_margin(knot_spacing: float = DEFAULT_KNOT_SPACING) -> float:
    """Time to leave out at each end of a smoothed recording [s]."""
    return 2.0 * knot_spacing


class SmoothingSpline(Signal):
    """A least-squares quintic B-spline through samples ``(t, y)`` (see the module docstring); evaluates itself
    and its derivatives up to order 4, vectorised over time."""

    max_order = 4

    def __init__(self, t, y, knot_spacing: float = DEFAULT_KNOT_SPACING, degree: int = 5, name: str = "smoothed"):
        t = np.asarray(t, dtype=float)
        y = np.asarray(y, dtype=float)
        self.name = name
        if t.shape != y.shape or t.ndim != 1:
            raise DataError(f"{name}: time and values must be 1-d arrays of the same length")
        try:
            spacing = float(knot_spacing)
        except (TypeError, ValueError):
            spacing = np.nan
        if not 0 < spacing < np.inf:
            raise DataError(f"{name}: knot_spacing must be a positive number of seconds, got {knot_spacing!r}")
        if not isinstance(degree, (int, np.integer)) or not 1 <= degree <= 5:
            raise DataError(f"{name}: degree must be an integer from 1 to 5, got {degree!r}")
        span = t[-1] - t[0]
        n_int = max(1, int(round(span / spacing)))
        if len(t) < 2 * (n_int + degree):
            raise DataError(f"{name}: {len(t)} samples are too few for a knot spacing of {spacing} s "
                            f"over {span:.3g} s")
        inner = np.linspace(t[0], t[-1], n_int + 1)
        knots = np.r_[[t[0]] * degree, inner, [t[-1]] * degree]
        bspl = make_lsq_spline(t, y, knots, k=degree)
        self._pp = [PPoly.from_spline(bspl)]
        for _ in range(self.max_order):
            self._pp.append(self._pp[-1].derivative())
        self.t0, self.t1 = t[0], t[-1]

    def evaluate(self, t, order):
        return self._pp[order](t)

    def table(self):
        pp = self._pp[0]
        keep = np.diff(pp.x) > 0  # the repeated end knots give empty pieces
        return PiecewisePolynomial(np.append(pp.x[:-1][keep], pp.x[-1]), pp.c[:, keep], "extend")
