"""The fixed step in native code: a model's rate function (states and sensitivities) printed as C by CasADi, with
a loop that takes the classical RK4 steps over a whole recording, compiled by the machine's C compiler once per
function (:func:`acausal.backends.ccompiler.shared_library`) and called through ctypes.

The arithmetic is CasADi's own code for the same expression graph, and the loop takes the steps in the order of
:class:`~acausal.simulation.compiled.fixed_step.FixedStep`'s unrolled CasADi step (stage times ``t_i + j h/2``, the same
sums), so the two give the same numbers (bit for bit on the servo replays; ``tests/simulation/test_fixed_step.py`` checks
1e-14); the loop runs about ten times faster than CasADi's virtual machine evaluating the unrolled step (a whole
servo replay, inputs and outputs included, five times), and one library serves every substep count. Without a C
compiler, or where it refuses the source, the fixed step stays on CasADi's virtual machine (:func:`rk4_driver`
returns None).
"""
from __future__ import annotations

import ctypes

import casadi as ca
import numpy as np

from ...backends.ccompiler import try_shared_library

#: the RK4 loop around the generated ``rate(t, y, pd, u)``: ``stages`` holds one column per output interval
#: (its start, its length, then the inputs at the 2k+1 stage times, input by input), as
#: :meth:`~acausal.simulation.compiled.fixed_step.FixedStep.stage_values` lays them out
DRIVER = r"""
#include <stdlib.h>
#include <string.h>

int acausal_rk4(const double* y0, const double* stages, const double* pd, long n_out, long k, long ny, long m,
                double* out) {
  casadi_int sz_arg, sz_res, sz_iw, sz_w;
  long i, j, r, rows = 2 + m * (2 * k + 1);
  int status = 0;
  double ts;
  rate_work(&sz_arg, &sz_res, &sz_iw, &sz_w);
  const double** arg = malloc(sizeof(double*) * (sz_arg > 4 ? sz_arg : 4));
  double** res = malloc(sizeof(double*) * (sz_res > 1 ? sz_res : 1));
  casadi_int* iw = malloc(sizeof(casadi_int) * (sz_iw + 1));
  double* w = malloc(sizeof(double) * (sz_w + 6 * ny + 1));
  if (!arg || !res || !iw || !w) { status = 2; goto done; }
  double *y = w + sz_w, *k1 = y + ny, *k2 = k1 + ny, *k3 = k2 + ny, *k4 = k3 + ny, *tmp = k4 + ny;
  memcpy(y, y0, sizeof(double) * ny);
  arg[0] = &ts; arg[1] = tmp; arg[2] = pd;
  for (i = 0; i < n_out; i++) {
    const double* col = stages + i * rows;
    const double* us = col + 2;
    double h = col[1] / k;
    for (j = 0; j < k; j++) {
      double t0 = col[0] + j * h;
      ts = t0; memcpy(tmp, y, sizeof(double) * ny); arg[3] = us + 2 * j * m; res[0] = k1;
      if (rate(arg, res, iw, w, 0)) { status = 1; goto done; }
      for (r = 0; r < ny; r++) tmp[r] = y[r] + h / 2 * k1[r];
      ts = t0 + h / 2; arg[3] = us + (2 * j + 1) * m; res[0] = k2;
      if (rate(arg, res, iw, w, 0)) { status = 1; goto done; }
      for (r = 0; r < ny; r++) tmp[r] = y[r] + h / 2 * k2[r];
      res[0] = k3;
      if (rate(arg, res, iw, w, 0)) { status = 1; goto done; }
      for (r = 0; r < ny; r++) tmp[r] = y[r] + h * k3[r];
      ts = t0 + h; arg[3] = us + (2 * j + 2) * m; res[0] = k4;
      if (rate(arg, res, iw, w, 0)) { status = 1; goto done; }
      for (r = 0; r < ny; r++) y[r] = y[r] + h / 6 * (k1[r] + 2 * k2[r] + 2 * k3[r] + k4[r]);
    }
    memcpy(out + i * ny, y, sizeof(double) * ny);
  }
done:
  free(arg); free(res); free(iw); free(w);
  return status;
}
"""

_DOUBLES = ctypes.POINTER(ctypes.c_double)
#: loaded drivers by library path
_LOADED: dict = {}


class NativeRK4:
    """The compiled RK4 loop of one rate function (``ny`` values: states, then sensitivities by columns; ``m``
    inputs); call with the start ``y0``, the stage columns, the parameter and mode vector and the substeps."""

    def __init__(self, path, ny: int, m: int):
        self.path, self.ny, self.m = str(path), int(ny), int(m)
        if self.path not in _LOADED:
            fn = ctypes.CDLL(self.path).acausal_rk4
            fn.argtypes = [_DOUBLES, _DOUBLES, _DOUBLES, ctypes.c_long, ctypes.c_long, ctypes.c_long,
                           ctypes.c_long, _DOUBLES]
            fn.restype = ctypes.c_int
            _LOADED[self.path] = fn
        self._fn = _LOADED[self.path]

    def __call__(self, y0, stages, pd, substeps: int) -> np.ndarray:
        """The values after each output interval, shape ``(ny, intervals)``."""
        y0 = np.ascontiguousarray(y0, dtype=float)
        stages = np.asfortranarray(stages, dtype=float)  # one interval's column contiguous
        pd = np.ascontiguousarray(pd, dtype=float)
        n_out = stages.shape[1]
        if y0.size != self.ny or stages.shape[0] != 2 + self.m * (2 * substeps + 1):
            raise ValueError(f"native RK4: {y0.size} start values and {stages.shape[0]} stage rows do not fit "
                             f"{self.ny} values, {self.m} inputs and {substeps} substeps")
        out = np.empty((n_out, self.ny))
        status = self._fn(y0.ctypes.data_as(_DOUBLES), stages.ctypes.data_as(_DOUBLES), pd.ctypes.data_as(_DOUBLES),
                          n_out, int(substeps), self.ny, self.m, out.ctypes.data_as(_DOUBLES))
        if status:
            raise RuntimeError(f"native RK4 ({self.path}) failed with status {status}")
        return out.T


def rk4_driver(rate: ca.Function) -> NativeRK4 | None:
    """The compiled RK4 loop around ``rate`` (a CasADi function ``(t, y, pd, u) -> dy/dt``), or None where it
    cannot be built here (no C compiler, or the compiler refuses the source: the caller stays on CasADi's virtual
    machine)."""
    if rate.name() != "rate":  # the driver calls it by that name
        raise ValueError(f"native RK4: the rate function must be named 'rate', got {rate.name()!r}")
    cg = ca.CodeGenerator("acausal_rate", {"with_header": False})
    cg.add(rate)
    source = cg.dump() + DRIVER
    path, _ = try_shared_library(source)
    if path is None:  # no compiler, or it refused the source (remembered: not tried again in this process)
        return None
    return NativeRK4(path, rate.size1_in(1), rate.size1_in(3))
