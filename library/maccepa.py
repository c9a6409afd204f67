"""Linkage math of the sliding-bar MACCEPA of the CYBERLEGs alpha ankle (paper, section 2, Eq. 1-3).

Symbols (Fig. 2 of the paper, reading of ``docs/parameters.md``), all SI:

* ``alpha`` [rad]: angle between the moment arm (a-c) and the foot (a-b), ``alpha = phi - theta``, positive in the
  plantarflexion direction (phi: moment-arm angle, theta: ankle angle, both plantarflexion-positive);
* ``B`` [m]: moment arm a-c; ``A`` [m]: connecting link c-b, opposite ``alpha``; ``C(alpha)`` [m]: distance a-b;
* ``P`` [m]: spring precompression (>= 0); ``k`` [N/m]: series spring constant (die spring: 132 N/mm = 132000 N/m);
* spring compression ``P + A + B - C(alpha)`` [m], equal to ``P`` at ``alpha = 0`` and larger elsewhere;
* ``T`` [N m]: torque of the linkage on the foot, positive in the plantarflexion direction. ``T`` is odd in alpha.

Eq. 1  ``C(alpha) = B cos(alpha) + A sqrt(1 - (B/A sin(alpha))^2)``
Eq. 2  ``f(alpha, P) = k B (P + A + B - C(alpha)) sin(alpha) / (A sqrt(1 - (B/A sin(alpha))^2))``
Eq. 3  ``T(alpha) = C(alpha) f(alpha, P)``

The linkage is conservative: ``T = dE/dalpha`` with ``E = k (P + A + B - C)^2 / 2``, and the stiffness at
``alpha = 0`` is ``k B (A + B) P / A`` (zero when ``P = 0``: then ``T ~ alpha^3``).

Numerics: ``A + B - C`` is evaluated as ``2 B sin^2(alpha/2) + (B^2/A) sin^2(alpha) / (1 + W)`` with
``W = sqrt(1 - (B/A sin alpha)^2)``, algebraically identical to Eq. 1 but free of cancellation at small alpha.
When ``B > A`` the linkage has a dead point at ``|alpha| = asin(A/B)``; angles beyond it are rejected.
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from acausal import Eq, Parameter, Variable
from acausal.errors import ModelError
from acausal.model.partials import PartialCompliant, PartialCompliantWithRelativeStates

__all__ = [
    "link_length", "spring_compression", "perpendicular_force", "torque", "spring_energy", "stiffness",
    "max_torque", "inverse_torque", "alpha_limit", "torque_expr", "energy_expr",
]

_GRID = 512          # grid points on (0, alpha_limit] to bracket the first torque maximum
_CHUNK = 4096        # precompression values per grid evaluation (memory bound: _CHUNK * _GRID floats)


# ----------------------------------------------------------------------------------------------- validation
def _scalar(name: str, value, unit: str) -> float:
    arr = np.asarray(value, dtype=float)
    if arr.ndim != 0:
        raise ModelError(f"MACCEPA: parameter {name} must be a scalar, got an array of shape {arr.shape}")
    v = float(arr)
    if not np.isfinite(v) or v <= 0.0:
        raise ModelError(f"MACCEPA: parameter {name} must be finite and > 0, got {name} = {v!r} {unit}")
    return v


def _geometry(A, B) -> tuple[float, float]:
    return _scalar("A", A, "m"), _scalar("B", B, "m")


def _precompression(P) -> np.ndarray:
    P = np.asarray(P, dtype=float)
    bad = ~(np.isfinite(P) & (P >= 0.0))
    if np.any(bad):
        flat = np.flatnonzero(bad)[0]
        raise ModelError(f"MACCEPA: parameter P (precompression) must be finite and >= 0, got P = "
                         f"{float(P.flat[flat])!r} m" + (f" at index {_index(flat, P.shape)}" if P.ndim else ""))
    return P


def _index(flat: int, shape: tuple) -> int | tuple:
    if len(shape) <= 1:
        return int(flat)
    return tuple(int(i) for i in np.unravel_index(flat, shape))


def alpha_limit(A, B) -> float:
    """Largest |alpha| the linkage can reach [rad]: ``asin(A/B)`` (dead point) if ``B >= A``, else ``pi``."""
    A, B = _geometry(A, B)
    return float(np.arcsin(A / B)) if B >= A else float(np.pi)


def _angle(alpha, A: float, B: float) -> np.ndarray:
    alpha = np.asarray(alpha, dtype=float)
    if B >= A:
        bad = np.abs(np.sin(alpha)) * (B / A) > 1.0
        if np.any(bad):
            flat = np.flatnonzero(bad)[0]
            raise ModelError(f"MACCEPA: alpha = {float(alpha.flat[flat])!r} rad" + (
                f" at index {_index(flat, alpha.shape)}" if alpha.ndim else "")
                + f" is beyond the dead point asin(A/B) = {np.arcsin(A / B):.6g} rad (A = {A} m, B = {B} m)")
    return alpha


def _parts(alpha, A: float, B: float):
    """sin, cos, W = sqrt(1 - (B/A sin)^2), C (Eq. 1) and A + B - C (cancellation-free)."""
    s, c = np.sin(alpha), np.cos(alpha)
    W = np.sqrt(np.maximum(1.0 - (B / A * s) ** 2, 0.0))
    C = B * c + A * W
    excess = 2.0 * B * np.sin(0.5 * alpha) ** 2 + (B * B / A) * s * s / (1.0 + W)
    return s, c, W, C, excess


def _out(x):
    x = np.asarray(x)
    return x[()] if x.ndim == 0 else x


# ----------------------------------------------------------------------------------------------- numpy forms
def link_length(alpha, A, B):
    """Eq. 1: distance a-b along the foot, ``C(alpha) = B cos(alpha) + A sqrt(1 - (B/A sin alpha)^2)`` [m]."""
    A, B = _geometry(A, B)
    return _out(_parts(_angle(alpha, A, B), A, B)[3])


def spring_compression(alpha, P, A, B):
    """Spring compression ``P + A + B - C(alpha)`` [m] (Eq. 2's bracket); ``= P`` at alpha = 0, ``>= P``."""
    A, B = _geometry(A, B)
    P = _precompression(P)
    return _out(P + _parts(_angle(alpha, A, B), A, B)[4])


def perpendicular_force(alpha, P, k, A, B):
    """Eq. 2: force perpendicular to link C, ``k B (P + A + B - C) sin(alpha) / (A W)`` [N], odd in alpha."""
    A, B = _geometry(A, B)
    k = _scalar("k", k, "N/m")
    P = _precompression(P)
    s, _, W, _, excess = _parts(_angle(alpha, A, B), A, B)
    return _out(k * B * (P + excess) * s / (A * W))


def torque(alpha, P, k, A, B):
    """Eq. 3: ``T = C(alpha) f(alpha, P)`` [N m], plantarflexion-positive torque on the foot; equals dE/dalpha."""
    A, B = _geometry(A, B)
    k = _scalar("k", k, "N/m")
    P = _precompression(P)
    return _out(_torque(_angle(alpha, A, B), P, k, A, B))


def _torque(alpha, P, k, A, B):
    s, _, W, C, excess = _parts(alpha, A, B)
    return k * B * (P + excess) * s * C / (A * W)


def spring_energy(alpha, P, k, A, B):
    """Energy stored in the spring ``E = k (P + A + B - C(alpha))^2 / 2`` [J] (including the precompression)."""
    A, B = _geometry(A, B)
    k = _scalar("k", k, "N/m")
    P = _precompression(P)
    return _out(0.5 * k * (P + _parts(_angle(alpha, A, B), A, B)[4]) ** 2)


def _stiffness(alpha, P, k, A, B):
    # T = (k B / A) D g with D = P + A + B - C, g = sin(alpha) C / W = A s + B s c / W, and dD/dalpha = (B/A) g.
    s, c, W, C, excess = _parts(alpha, A, B)
    g = s * C / W
    r2 = (B / A) ** 2
    dg = A * c + B * ((c * c - s * s) / W + r2 * s * s * c * c / W ** 3)
    return (k * B / A) * ((B / A) * g * g + (P + excess) * dg)


def stiffness(alpha, P, k, A, B):
    """``dT/dalpha`` [N m/rad] (analytic); at alpha = 0 it is ``k B (A + B) P / A``."""
    A, B = _geometry(A, B)
    k = _scalar("k", k, "N/m")
    P = _precompression(P)
    return _out(_stiffness(_angle(alpha, A, B), P, k, A, B))


# ----------------------------------------------------------------------------------------------- reach and inverse
def max_torque(P, k, A, B):
    """Largest |T| on the monotonic branch through alpha = 0, and where it occurs: ``(T_max, alpha_at_max)``.

    ``T_max`` [N m] is the first maximum of T on (0, alpha_limit) (T is odd, so ``-T_max`` is reached at
    ``-alpha_at_max``); vectorised over ``P``. Found by sampling dT/dalpha on a grid of 512 angles and bisecting
    its first sign change (a maximum/minimum pair narrower than the grid spacing would be missed). If T grows up to
    a dead point (``B > A``), ``T_max = inf`` and ``alpha_at_max = asin(A/B)``.
    """
    A, B = _geometry(A, B)
    k = _scalar("k", k, "N/m")
    P = _precompression(P)
    uniq, inv = np.unique(P.ravel(), return_inverse=True)
    tmax, amax = np.empty_like(uniq), np.empty_like(uniq)
    lim = alpha_limit(A, B)
    dead = B >= A
    grid = lim * np.arange(1, _GRID + 1) / _GRID
    if dead:
        grid[-1] = lim * (1.0 - 1e-12)
    for lo in range(0, uniq.size, _CHUNK):
        p = uniq[lo:lo + _CHUNK, None]
        K = _stiffness(grid[None, :], p, k, A, B)
        down = K <= 0.0
        has = down.any(axis=1)
        j = np.argmax(down, axis=1)
        a = np.where(j > 0, grid[np.maximum(j - 1, 0)], 0.0)       # K(a) > 0 (or a = 0)
        b = grid[j]                                                 # K(b) <= 0
        pp = p[:, 0]
        for _ in range(200):
            m = 0.5 * (a + b)
            if not np.any((m > a) & (m < b)):
                break
            pos = _stiffness(m, pp, k, A, B) > 0.0
            a, b = np.where(pos, m, a), np.where(pos, b, m)
        at = np.where(has, 0.5 * (a + b), lim)
        # the maximum of T sits where dT/dalpha changes sign: take the larger T of the two bracket ends
        T = np.maximum(_torque(a, pp, k, A, B), _torque(b, pp, k, A, B))
        tmax[lo:lo + _CHUNK] = np.where(has, T, np.inf)
        amax[lo:lo + _CHUNK] = at
    return _out(tmax[inv].reshape(P.shape)), _out(amax[inv].reshape(P.shape))


def inverse_torque(T, P, k, A, B, tol=1e-12, reach=None):
    """alpha(T, P) [rad] on the monotonic branch through alpha = 0 (``|alpha| <= alpha_at_max``), inverting Eq. 3.

    ``T`` and ``P`` broadcast. All samples are solved at once by safeguarded Newton iteration: a Newton step
    that leaves the current bracket (or meets a non-positive stiffness) is replaced by bisection, so P = 0
    (zero stiffness at alpha = 0, ``T ~ alpha^3``) converges too. Stops per sample when
    ``|T(alpha) - T| <= tol |T|`` or the bracket is a few ulps wide.
    Raises :class:`ModelError` naming the count, first index, torque and reachable maximum of samples with
    ``|T| > T_max(P)``, and naming any invalid parameter. ``reach``: :func:`max_torque` of these ``P``, ``k``, ``A``,
    ``B`` when the caller has it already (several inversions at the same precompressions).
    """
    A, B = _geometry(A, B)
    k = _scalar("k", k, "N/m")
    P = _precompression(P)
    T = np.asarray(T, dtype=float)
    if not np.all(np.isfinite(T)):
        flat = np.flatnonzero(~np.isfinite(T))[0]
        raise ModelError(f"MACCEPA inverse: torque T = {float(T.flat[flat])!r} N m" +
                         (f" at index {_index(flat, T.shape)}" if T.ndim else "") + " is not finite")
    reach = [np.asarray(x) for x in (max_torque(P, k, A, B) if reach is None else reach)]  # per precompression
    T, P, tmax, amax = np.broadcast_arrays(T, P, *reach)
    target = np.abs(T)
    out = target > tmax * (1.0 + 1e-14)
    if np.any(out):
        n = int(out.sum())
        flat = np.flatnonzero(out)[0]
        where = f"index {_index(flat, T.shape)}" if T.ndim else "the scalar input"
        raise ModelError(
            f"MACCEPA inverse: {n} sample{'s' if n != 1 else ''} out of reach; first at {where}: "
            f"T = {T.flat[flat]:.6g} N m exceeds the maximum {tmax.flat[flat]:.6g} N m reachable at "
            f"P = {P.flat[flat]:.6g} m (k = {k:g} N/m, A = {A:g} m, B = {B:g} m)")
    t, p = target.ravel(), P.ravel()
    lo = np.zeros_like(t)
    hi = amax.ravel().astype(float).copy()
    if B >= A:                                    # never evaluate exactly at the dead point
        hi = np.minimum(hi, alpha_limit(A, B) * (1.0 - 1e-12))
    alpha = np.where(t > 0.0, 0.5 * (lo + hi), 0.0)
    active = t > 0.0
    for _ in range(400):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        x, pi, ti = alpha[idx], p[idx], t[idx]
        f = _torque(x, pi, k, A, B) - ti
        done = np.abs(f) <= tol * ti
        l, h = np.where(f < 0.0, x, lo[idx]), np.where(f > 0.0, x, hi[idx])
        done |= (h - l) <= 4.0 * np.finfo(float).eps * np.maximum(h, 1e-300)
        K = _stiffness(x, pi, k, A, B)
        with np.errstate(divide="ignore", invalid="ignore"):
            newton = x - f / K
        ok = (K > 0.0) & (newton > l) & (newton < h)
        nxt = np.where(ok, newton, 0.5 * (l + h))
        lo[idx], hi[idx] = l, h
        alpha[idx] = np.where(done, x, nxt)
        active[idx[done]] = False
    return _out((np.sign(T.ravel()) * alpha).reshape(T.shape))


# ----------------------------------------------------------------------------------------------- sympy forms
def _sym_check(k, A, B, P) -> None:
    for name, v, unit, strict in (("k", k, "N/m", True), ("A", A, "m", True), ("B", B, "m", True),
                                  ("P", P, "m", False)):
        v = sp.sympify(v)
        if v.is_number:
            x = float(v) if v.is_extended_real else float("nan")
            if not np.isfinite(x) or x < 0.0 or (strict and x == 0.0):
                raise ModelError(f"MACCEPA: parameter {name} must be real, finite and {'> 0' if strict else '>= 0'}, "
                                 f"got {name} = {v} {unit}")


def _sym_parts(alpha, P, A, B):
    s = sp.sin(alpha)
    W = sp.sqrt(1 - (B / A * s) ** 2)
    C = B * sp.cos(alpha) + A * W                                              # Eq. 1
    compression = P + 2 * B * sp.sin(alpha / 2) ** 2 + B ** 2 * s ** 2 / (A * (1 + W))  # = P + A + B - C
    return s, W, C, compression


def torque_expr(alpha, P, k, A, B):
    """Eq. 3 as a sympy expression, ``C(alpha) * k B (P + A + B - C) sin(alpha) / (A W)`` [N m].

    Arguments are sympy symbols/expressions or numbers (for component equations). ``A + B - C`` is written in the
    cancellation-free form of the module docstring, algebraically identical to the paper's.
    """
    _sym_check(k, A, B, P)
    s, W, C, compression = _sym_parts(alpha, P, A, B)
    return C * k * B * compression * s / (A * W)


def energy_expr(alpha, P, k, A, B):
    """Spring energy ``k (P + A + B - C(alpha))^2 / 2`` [J] as a sympy expression; its alpha-derivative is Eq. 3."""
    _sym_check(k, A, B, P)
    return k * _sym_parts(alpha, P, A, B)[3] ** 2 / 2


# ---------------------------------------------------------------------------------------------------- component


class Maccepa(PartialCompliant):
    """Sliding-bar MACCEPA linkage (paper Fig. 2, Eq. 1-3) between the foot and the moment arm.

    ``flange_a`` is the foot / ankle joint (angle theta), ``flange_b`` the moment arm (angle phi, driven through
    the gears); ``alpha = phi - theta = phi_rel``. The linkage exerts ``T(alpha, P)`` (Eq. 3) on the foot, in the
    plantarflexion sense, and ``-T`` on the moment arm: ``flange_b.tau = T`` acts on the linkage at the arm,
    ``flange_a.tau = -T`` at the foot. It is conservative: ``T = dE/dalpha`` with the spring energy
    ``E = k (P + A + B - C(alpha))^2 / 2``, so the power into it equals ``dE/dt``. Both ends turn about the same
    joint axis, so no torque reaches the lower leg through the linkage itself (no support flange). The linkage
    with the friction of its bar and pivots is :class:`FrictionalMaccepa`.

    Defaults: k = 132 N/mm die spring (paper, section 2); A = 0.100 m, B = 0.060 m (not published: a proposal
    of docs/parameters.md, low-medium confidence); P = 8 mm (the paper's Table 1 condition).
    """

    k = Parameter(132e3, unit="N/m", min=0.0, doc="spring stiffness (paper: die spring 132 N/mm)",
                  device="CYBERLEGs ankle MACCEPA")
    A = Parameter(0.100, unit="m", min=0.0, doc="connecting link length c-b (assumption, parameters.md)",
                  device="CYBERLEGs ankle MACCEPA")
    B = Parameter(0.060, unit="m", min=0.0, doc="moment arm length a-c (assumption, parameters.md)",
                  device="CYBERLEGs ankle MACCEPA")
    P = Parameter(0.008, unit="m", min=0.0, max=0.03, doc="spring precompression (the paper adjusts 0-18 mm; up to 30 mm "
                  "allowed, so an actual precompression above the nominal one can be modelled)",
                  device="CYBERLEGs ankle MACCEPA")
    alpha = Variable(unit="rad", doc="angle between moment arm and foot, phi - theta")
    T = Variable(unit="N.m", doc="torque on the foot, Eq. 3 (plantarflexion positive)")
    energy = Variable(unit="J", doc="energy stored in the spring")
    compression = Variable(unit="m", doc="spring compression P + A + B - C(alpha)")

    def equations(self):
        k, A, B, P, a = self.k, self.A, self.B, self.P, self.alpha
        return [*super().equations(), Eq(a, self.phi_rel), Eq(self.T, torque_expr(a, P, k, A, B)),
                Eq(self.tau, self.T + self.friction_torque()), Eq(self.energy, energy_expr(a, P, k, A, B)),
                Eq(self.compression, _sym_parts(a, P, A, B)[3])]

    def friction_torque(self):
        """Friction torque on the relative motion, in parallel with the spring [N m]: none (lossless linkage)."""
        return 0


class FrictionalMaccepa(Maccepa, PartialCompliantWithRelativeStates):
    """The MACCEPA linkage with the friction of its sliding bar and pivots, a swap-in for :class:`Maccepa`.

    The spring force ``F = k (P + A + B - C(alpha))`` (>= 0: the spring is always compressed) loads the sliding
    bar in its guide and the pivots at a, b and c, so their Coulomb friction is proportional to it; a constant
    part ``tau_0`` (seals, bearing preload) adds to it, and a viscous part ``d w_rel`` (lubricant shear in the
    bar's guide) grows with speed. Lumped on the relative motion ``w_rel = der(alpha)``, with the library's smooth
    direction law (as :class:`~acausal.library.rotational.BearingFriction`)::

        tau_f = (tau_0 + r_f F) tanh(w_rel / w_c) + d w_rel
        tau   = T(alpha) + tau_f            (flange_b.tau = tau, flange_a.tau = -tau, as in Maccepa)
        loss_power = tau_f w_rel >= 0

    The friction acts like a damper in parallel with the conservative linkage: the power into the two flanges,
    ``tau w_rel``, is ``der(energy) + loss_power`` with ``energy`` the spring energy of :class:`Maccepa`. The
    law is smooth, so replays may differentiate it (a replay differentiates the moment-arm angle 3 times; the
    friction torque needs ``der(w_rel)``, i.e. also the second derivative of the joint angle); below a few ``w_c``
    it is a steep viscous law and creeps instead of sticking (docs/friction-and-gears.md).

    Why a subclass and not friction parameters on :class:`Maccepa`: the paper's Eq. 1-3 linkage stays
    conservative and exactly as before (no zero ``loss_power`` account in every model's balance, no extra
    derivative of the joint angle in its replays), and the swap-in keeps the parameter names ``k``, ``A``,
    ``B``, ``P`` on which presets and the planned trajectory rely. ``r_f = tau_0 = 0`` gives the lossless
    linkage's torque and energy.

    The paper (section 4.2.3, Fig. 12) measured an average loss of about 20 % between moment arm and joint, over
    50 % at high precompression and short strides; the defaults below are a priori (handbook friction
    coefficients, assumed levers), not fitted to it. The loss grows with precompression through ``F``; its Coulomb
    part does not depend on speed, so on the same motion it is the same at every stride time, while the viscous
    part ``d`` grows as the stride gets shorter (per stride, in inverse proportion to the stride time).
    """

    r_f = Parameter(1e-3, unit="m", min=0.0, doc="effective friction radius of bar and pivots, friction coefficient "
                    "times lever about the joint (assumption: mu 0.1, lubricated plain bearing / steel slide, times "
                    "a 10 mm pin or bar lever; plausible range mu 0.05-0.3 times 5-20 mm: 0.25-6 mm)")
    tau_0 = Parameter(0.0, unit="N.m", min=0.0, doc="friction torque independent of the spring force (seals, "
                      "bearing preload; not measured, 0 by default)")
    w_c = Parameter(0.05, unit="rad/s", min=1e-12, doc="speed scale of the smooth direction law (assumption: "
                    "1-2.5 % of the linkage's peak relative speed in the ankle's gait replay, 2-5 rad/s at 3-1.2 "
                    "s/stride; smaller is closer to Coulomb friction and makes the replayed motor current steeper "
                    "at reversals)")
    d = Parameter(0.0, unit="N.m.s/rad", min=0.0, doc="viscous friction on the relative motion (lubricant shear; "
                  "not measured, 0 by default: a speed-dependent loss for the paper's short-stride worst case)")
    spring_force = Variable(unit="N", doc="spring force k (P + A + B - C(alpha)), the friction's normal load")
    tau_f = Variable(unit="N.m", doc="friction torque on the relative motion, in the direction of w_rel")
    loss_power = Variable(unit="W", doc="dissipated power tau_f w_rel (>= 0)")

    def equations(self):
        return [*super().equations(),  # w_rel = der(phi_rel) from PartialCompliantWithRelativeStates
                Eq(self.spring_force, self.k * self.compression),
                Eq(self.tau_f, (self.tau_0 + self.r_f * self.spring_force) * sp.tanh(self.w_rel / self.w_c)
                   + self.d * self.w_rel),
                Eq(self.loss_power, self.tau_f * self.w_rel)]

    def friction_torque(self):
        return self.tau_f
