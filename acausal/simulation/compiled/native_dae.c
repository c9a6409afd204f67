/* The native loop of acausal (acausal/simulation/compiled/native_loop.py): one segment of a run (between two state events,
 * or the whole run of a model without them), integrated by SUNDIALS (variable-order BDF: CVODES for an ODE, IDAS
 * where there are algebraic variables) from a consistent start until the last output time or the first zero
 * crossing, whichever comes first. The outputs are read off the solver's interpolating polynomial; the energy
 * integrals are quadratures whose error test is scaled by the step's largest flow.
 *
 * The model is y = (x, z): n states x with x' = f(t, x, z), and nz algebraic variables z with 0 = g(t, x, z) (the
 * Newton blocks; nz = 0 for an ODE). Its functions are CasADi's generated C, built into a library of the model's
 * own; the caller passes their addresses (`functions`: these five, then their work-size queries, in this order):
 *   acausal_dae(t, y, pd, s)   -> f (n), g (nz)
 *   acausal_jac(t, y, pd, s)   -> d(f, g)/dy, dense, by columns
 *   acausal_quad(t, y, pd, s)  -> the integrands of the quadratures (nq)
 *   acausal_zeros(t, y, pd, s) -> the event zero functions (ng)
 *   acausal_arguments(t, pd)   -> the arguments the table inputs are read at (ns; time, or an expression of it)
 * with pd the parameters and modes, and s the values of the table inputs at their arguments (piecewise
 * polynomials, their numbers passed at run time, so that one compiled library serves every recording).
 *
 * Crossings are looked for at the end of every solver step, and at `substeps` interior points of it (the solver's
 * interpolating polynomial) where a zero function crossed or its total variation over the step (the last nv
 * quadratures) says it may have left zero and come back. The first crossing is located by the Illinois method on
 * that polynomial; crossings within 1e-9 (relative) of the first are taken together, at the latest of their times
 * (acausal.simulation.events.together), a hair past the root when the root itself is still on the old side
 * (acausal.simulation.events.crossings). This file is built once per machine and serves every model (its functions are
 * called through their addresses), so a model's first run compiles only its own functions.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cvodes/cvodes.h>
#include <idas/idas.h>
#include <nvector/nvector_serial.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sundials/sundials_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#ifndef casadi_real
#define casadi_real double
#endif
#ifndef casadi_int
#define casadi_int long long int
#endif

/* the generated functions, from the model's own library (their addresses passed in `functions`, in this order:
 * the five functions, then their work-size queries) */
typedef int (*Generated)(const casadi_real** arg, casadi_real** res, casadi_int* iw, casadi_real* w, int mem);
typedef int (*WorkSizes)(casadi_int* sz_arg, casadi_int* sz_res, casadi_int* sz_iw, casadi_int* sz_w);
enum { F_DAE, F_JAC, F_QUAD, F_ZEROS, F_ARGUMENTS, FUNCTIONS };

enum { TAB_N, TAB_DEGREE, TAB_OUTSIDE, TAB_BREAKS, TAB_ROWS, TAB_WIDTH, TAB_FIELDS };
/* the zero functions' variations are integrated scaled by this: far below any tolerance, they never steer the
 * steps (acausal.simulation.compiled.path.VARIATION_SCALE) */
#define VARIATION 1e250

enum { OUTSIDE_EXTRAPOLATE = 0, OUTSIDE_HOLD = 1, OUTSIDE_PERIODIC = 2 };

typedef struct {
  long n, nz, nq, nv, ng, ns;
  const double* pd;
  const double* off;      /* thresholds the zero functions are watched at */
  const long* tables;     /* TAB_FIELDS per table */
  const long* slots;      /* (table, derivative order) per table value in s */
  const double* tdata;    /* breaks and rows of the tables */
  double t0;              /* IDAS integrates in the time since t0 (its quadratures' dense output is wrong at
                           * negative times: IDAS 6 takes the fuzz of tn + h without its absolute value) */
  double s_time;          /* time at which s was last evaluated */
  double* s;
  double* at;             /* the arguments of the table values */
  const casadi_real** arg;
  casadi_real** res;
  casadi_int* iw;
  casadi_real* w;
  double *f, *g, *jac;
  double *znew, *dz;       /* Newton on the algebraic variables (consistent): the iterate and its step */
  SUNMatrix gz;            /* ... and d g / d z, factored by SUNDIALS's dense LU with the pivots piv */
  sunindextype* piv;
  double* dz0;             /* the first step's guess: the rates at the start */
  Generated fn[FUNCTIONS]; /* the model's functions */
  int failed;             /* a generated function reported an error */
  int undefined;          /* a zero function's variation was not defined somewhere in the step */
} Model;

/* one table input (or one of its derivatives) at time t: the piece by binary search over the breaks, then Horner's
 * rule on its row; the same arithmetic as acausal.backends.casadi.Signals._table */
static double table_value(const Model* m, long k, long order, double t) {
  const long* tab = m->tables + TAB_FIELDS * k;
  long n = tab[TAB_N], deg = tab[TAB_DEGREE], outside = tab[TAB_OUTSIDE], width = tab[TAB_WIDTH];
  const double* breaks = m->tdata + tab[TAB_BREAKS];
  const double* rows = m->tdata + tab[TAB_ROWS];
  double b0 = breaks[0], bn = breaks[n], tau = t, y = 0.0, x;
  long lo = 0, hi = n, i, j, start = 1;
  if (outside == OUTSIDE_PERIODIC) {
    double span = bn - b0;
    tau = t - span * floor((t - b0) / span);
  } else if (outside == OUTSIDE_HOLD) {
    tau = t < b0 ? b0 : (t > bn ? bn : t);
  }
  while (hi - lo > 1) { /* the last break at or before tau */
    long mid = (lo + hi) / 2;
    if (breaks[mid] <= tau) lo = mid; else hi = mid;
  }
  i = (tau >= bn) ? n - 1 : lo;
  if (i < 0) i = 0;
  if (i > n - 1) i = n - 1;
  const double* row = rows + i * width;
  x = tau - row[0];
  for (j = 0; j < order; j++) start += deg + 1 - j;
  if (order <= deg)
    for (j = 0; j < deg + 1 - order; j++) y = y * x + row[start + j];
  if (outside == OUTSIDE_HOLD && order > 0 && !(t >= b0 && t < bn)) y = 0.0;
  return y;
}

static int signals_at(Model* m, double t) {
  long j;
  double tt = t;
  if (m->ns == 0 || t == m->s_time) return 0;
  m->arg[0] = &tt; m->arg[1] = m->pd; m->res[0] = m->at;
  if (m->fn[F_ARGUMENTS](m->arg, m->res, m->iw, m->w, 0)) { m->failed = 1; return -1; }
  for (j = 0; j < m->ns; j++) m->s[j] = table_value(m, m->slots[2 * j], m->slots[2 * j + 1], m->at[j]);
  m->s_time = t;
  return 0;
}

/* call one generated function at (t0 + t, y): outputs res0 (and res1) */
static int call(Model* m, Generated fn, double t,
                const double* y, double* res0, double* res1) {
  double tt = m->t0 + t;
  t = tt;
  if (signals_at(m, t)) return -1;
  m->arg[0] = &tt; m->arg[1] = y; m->arg[2] = m->pd; m->arg[3] = m->s;
  m->res[0] = res0; m->res[1] = res1;
  if (fn(m->arg, m->res, m->iw, m->w, 0)) { m->failed = 1; return -1; }
  return 0;
}

/* the quadratures' integrands at (t, y): the energy integrands, then the zero functions' variations (the last nv).
 * A variation that is not defined there (a zero function's rate is NaN or infinite: a square root of a state that
 * went negative) is integrated as 0, and the step is marked to be searched point by point, as without variations
 * (the search then finds the zero function itself not finite and says where) */
static int quad_values(Model* m, double t, const double* y, double* out) {
  long i;
  if (call(m, m->fn[F_QUAD], t, y, out, 0)) return -1;
  for (i = m->nq - m->nv; i < m->nq; i++)
    if (!isfinite(out[i])) { out[i] = 0.0; m->undefined = 1; }
  return 0;
}

static int rate_quadrature(double t, N_Vector yy, N_Vector rq, void* data) {
  return quad_values((Model*)data, t, N_VGetArrayPointer(yy), N_VGetArrayPointer(rq)) ? -1 : 0;
}

static int quadrature(double t, N_Vector yy, N_Vector yp, N_Vector rq, void* data) {
  (void)yp;
  return quad_values((Model*)data, t, N_VGetArrayPointer(yy), N_VGetArrayPointer(rq)) ? -1 : 0;
}

static int residual(double t, N_Vector yy, N_Vector yp, N_Vector rr, void* data) {
  Model* m = (Model*)data;
  double *y = N_VGetArrayPointer(yy), *dy = N_VGetArrayPointer(yp), *r = N_VGetArrayPointer(rr);
  long i;
  if (call(m, m->fn[F_DAE], t, y, m->f, m->g)) return -1;
  for (i = 0; i < m->n; i++) r[i] = dy[i] - m->f[i];
  for (i = 0; i < m->nz; i++) r[m->n + i] = m->g[i];
  for (i = 0; i < m->n + m->nz; i++) if (!isfinite(r[i])) return 1; /* recoverable: IDAS tries a smaller step */
  return 0;
}

static int jacobian(double t, double cj, N_Vector yy, N_Vector yp, N_Vector rr, SUNMatrix J, void* data,
                    N_Vector t1, N_Vector t2, N_Vector t3) {
  Model* m = (Model*)data;
  long ny = m->n + m->nz, i, j;
  (void)yp; (void)rr; (void)t1; (void)t2; (void)t3;
  if (call(m, m->fn[F_JAC], t, N_VGetArrayPointer(yy), m->jac, 0)) return -1;
  for (j = 0; j < ny; j++) {
    double* col = SUNDenseMatrix_Column(J, j);
    for (i = 0; i < ny; i++) col[i] = (i < m->n ? -1.0 : 1.0) * m->jac[j * ny + i];
    if (j < m->n) col[j] += cj;
  }
  return 0;
}

/* the ODE's right-hand side, Jacobian and quadratures for CVODES (a model without algebraic variables) */
static int rate(double t, N_Vector yy, N_Vector dy, void* data) {
  Model* m = (Model*)data;
  double* r = N_VGetArrayPointer(dy);
  long i;
  if (call(m, m->fn[F_DAE], t, N_VGetArrayPointer(yy), r, m->g)) return -1;
  for (i = 0; i < m->n; i++) if (!isfinite(r[i])) return 1; /* recoverable: CVODES tries a smaller step */
  return 0;
}

static int rate_jacobian(double t, N_Vector yy, N_Vector fy, SUNMatrix J, void* data, N_Vector t1, N_Vector t2,
                         N_Vector t3) {
  Model* m = (Model*)data;
  long n = m->n, j;
  (void)fy; (void)t1; (void)t2; (void)t3;
  if (call(m, m->fn[F_JAC], t, N_VGetArrayPointer(yy), m->jac, 0)) return -1;
  for (j = 0; j < n; j++) memcpy(SUNDenseMatrix_Column(J, j), m->jac + j * n, sizeof(double) * n);
  return 0;
}

/* The algebraic variables of y made consistent with its states at t (Newton on their residuals from the values in y,
 * which between two solver steps are IDAS's interpolation: the algebraic variables are not in its error test, and
 * where the states rest while time moves them, a single step can span their whole change). The zero functions are
 * then those of the states, as on the other paths; y is left as it is where Newton does not converge. */
static void consistent(Model* m, double t, double* y) {
  long ny = m->n + m->nz, i, j, it;
  double* z = m->znew;
  if (!m->nz) return;
  memcpy(z, y, sizeof(double) * ny);
  for (it = 0; it < 20; it++) {
    double size = 0, step = 0;
    if (call(m, m->fn[F_DAE], t, z, m->f, m->g)) return;
    if (call(m, m->fn[F_JAC], t, z, m->jac, 0)) return;
    double** cols = SUNDenseMatrix_Cols(m->gz);
    for (j = 0; j < m->nz; j++)     /* d g / d z: rows and columns n.. of the Jacobian of (f, g) */
      for (i = 0; i < m->nz; i++) cols[j][i] = m->jac[(m->n + j) * ny + m->n + i];
    for (i = 0; i < m->nz; i++) m->dz[i] = m->g[i];
    if (SUNDlsMat_denseGETRF(cols, m->nz, m->nz, m->piv)) return;  /* singular */
    SUNDlsMat_denseGETRS(cols, m->nz, m->piv, m->dz);
    for (i = 0; i < m->nz; i++) {
      z[m->n + i] -= m->dz[i];
      step = fmax(step, fabs(m->dz[i]));
      size = fmax(size, fabs(z[m->n + i]));
    }
    if (!isfinite(step)) return;
    if (step <= 1e-14 * (size > 1 ? size : 1)) { memcpy(y, z, sizeof(double) * ny); return; }
  }
}

/* the zero functions at (t, y), relative to their thresholds; y interpolated within a step (between the solver's
 * points) has its algebraic variables made consistent first */
static int zeros_at(Model* m, double t, double* y, double* out, int interpolated) {
  long i;
  if (interpolated) consistent(m, t, y);
  if (call(m, m->fn[F_ZEROS], t, y, out, 0)) return -1;
  for (i = 0; i < m->ng; i++) out[i] -= m->off[i];
  return 0;
}

/* The first step when none is given: the rule of scipy's BDF (Hairer, Norsett and Wanner's estimate for order 1,
 * ||.|| the RMS of the states scaled by atol + rtol |x|): h0 = 0.01 ||x|| / ||x'||, then sqrt(0.01 / ||x''||) with the
 * second derivative from a trial Euler step, at most 100 h0 and the span. IDAS's own first step, 0.5 / ||x'||, is
 * about 50 rtol times shorter: right after an event its first steps then resolve the round-off of a zero function
 * that the event left at its knee (an ideal diode just turned on, its current a difference of two large numbers),
 * and such an excursion counts as a crossing. */
static double first_step_guess(Model* m, const double* y0, double rtol, double atol, double span) {
  long n = m->n, ny = m->n + m->nz, i;
  double d0 = 0, d1 = 0, d2 = 0, h0, h1;
  double *f0 = m->dz0, *y1 = m->znew;
  if (call(m, m->fn[F_DAE], 0.0, y0, m->f, m->g)) return 0.0;
  for (i = 0; i < n; i++) {
    double sc = atol + rtol * fabs(y0[i]);
    f0[i] = m->f[i];
    d0 += (y0[i] / sc) * (y0[i] / sc);
    d1 += (f0[i] / sc) * (f0[i] / sc);
  }
  d0 = sqrt(d0 / n); d1 = sqrt(d1 / n);
  h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
  if (h0 > span) h0 = span;
  memcpy(y1, y0, sizeof(double) * ny);
  for (i = 0; i < n; i++) y1[i] += h0 * f0[i];
  if (call(m, m->fn[F_DAE], h0, y1, m->f, m->g)) return 0.0;
  for (i = 0; i < n; i++) {
    double sc = atol + rtol * fabs(y0[i]), dd = (m->f[i] - f0[i]) / sc;
    d2 += dd * dd;
  }
  d2 = sqrt(d2 / n) / h0;
  h1 = (d1 <= 1e-15 && d2 <= 1e-15) ? fmax(1e-6, h0 * 1e-3) : sqrt(0.01 / fmax(d1, d2));
  h1 = fmin(100 * h0, h1);
  h1 = fmin(h1, span);
  return isfinite(h1) && h1 > 0 ? h1 : 0.0;
}

/* where a call's solver messages go (the caller's buffer: each call its own) */
typedef struct {
  char* text;
  long size;
} Messages;

static void on_error(int code, const char* module, const char* function, char* msg, void* data) {
  Messages* box = (Messages*)data;
  if (box && box->text && box->size > 0)
    snprintf(box->text, (size_t)box->size, "%s %s (%d): %s", module, function, code, msg);
}

/* the solver's interpolation and quadratures: ode says CVODES (an ODE), else IDAS */
static int get_dky(void* mem, int ode, double t, N_Vector out) {
  return ode ? CVodeGetDky(mem, t, 0, out) : IDAGetDky(mem, t, 0, out);
}

/* the state at t within the last step (the solver's interpolating polynomial), or at the step's end t_cur itself;
 * a step so short that the solver takes t for outside it (a few units in the last place) gives its end values */
static void state_at(void* mem, int ode, double t, double t_cur, N_Vector y_cur, N_Vector out) {
  if (t == t_cur || get_dky(mem, ode, t, out) < 0) N_VScale(1.0, y_cur, out);
}

static int get_quad_dky(void* mem, int ode, double t, N_Vector out) {
  return ode ? CVodeGetQuadDky(mem, t, 0, out) : IDAGetQuadDky(mem, t, 0, out);
}

static int get_quad(void* mem, int ode, N_Vector out) {
  double t_q;
  return ode ? CVodeGetQuad(mem, &t_q, out) : IDAGetQuad(mem, &t_q, out);
}

/* the quadratures at t within the last step, as state_at */
static void quad_at(void* mem, int ode, double t, double t_cur, N_Vector out) {
  if (t == t_cur || get_quad_dky(mem, ode, t, out) < 0) get_quad(mem, ode, out);
}

/* The quadratures' error test: each step's error within rtol of the largest gain of an energy integral in the step
 * before (plus atol), not rtol of each whole integral so far (SUNDIALS's relative tolerance, which lets the error
 * grow with the run: an energy off by 3e-5 at rtol 1e-6 over a second of a 45 Hz source). The energies' errors are
 * then rtol of the largest flow, the scale of the balance they enter (a gain: what the step added, or its length
 * times the integrand at its end if more); the zero functions' variations (the last nv) keep their own scale. The
 * CasADi event path's integrals came out as accurate by restarting with every run of at most 64-187 outputs. */
static void quad_tolerances(void* mem, int ode, const double* gain, long nv, double rtol, double atol,
                            N_Vector tol) {
  long i, nq = N_VGetLength(tol);
  double largest = 0;
  for (i = 0; i < nq - nv; i++) largest = fmax(largest, gain[i]);
  for (i = 0; i < nq; i++) N_VGetArrayPointer(tol)[i] = atol + rtol * (i < nq - nv ? largest : gain[i]);
  if (ode) CVodeQuadSVtolerances(mem, 0.0, tol); else IDAQuadSVtolerances(mem, 0.0, tol);
}

static int crossed(double a, double b) {
  return (a < 0 && b >= 0) || (a > 0 && b <= 0) || (a == 0 && b != 0);
}

/* zero function i crosses between ga and gb, unless it is muted: at an exact zero since the start, where a crossing
 * that changed nothing was just passed (it leaves that zero without a crossing) */
#define CROSSES(i, a, b) (crossed((a)[i], (b)[i]) && !(muted[i] && (a)[i] == 0))

/* Returns 0 (the last output reached), 1 (a crossing: t_event, y_event, q_event, dirs), or a failure: -1 IDAS
 * or CVODES (message in msg), -2 a generated function failed, -3 a zero function not finite (at t_event,
 * y_event), -4 the step limit, -5 out of memory. Outputs at times <= the crossing are written to X (ny per
 * output) and Q (nq per output, integrals from t0); *written says how many. Nothing is kept between calls (the
 * messages go to msg through the solver's own handler data), so threads may run segments at once. */
int acausal_segment(void* const* functions, long n, long nz, long nq, long nv, long ng, long ns, double t0,
                    const double* y0, const double* pd, const double* off, const double* g0, const int* mute,
                    const long* tables, const long* slots, const double* tdata, long n_out,
                    const double* t_out, double rtol, double atol, double max_step, double first_step,
                    long max_steps, long substeps, double* X, double* Q, long* written, double* t_event,
                    double* y_event, double* q_event, int* dirs, char* msg, long msg_size) {
  long ny = n + nz, i, k = 0, steps = 0, sz;
  int status = 0, flag, ode = nz == 0;  /* ode: CVODES, else IDAS */
  Messages box = {msg, msg_size};
  casadi_int sz_arg = 4, sz_res = 2, sz_iw = 0, sz_w = 0, a, r, iw_, w_;
  SUNContext ctx = NULL;
  void* mem = NULL;
  N_Vector yy = NULL, yp = NULL, id = NULL, tmp = NULL, yq = NULL, tmpq = NULL, tolq = NULL;
  SUNMatrix A = NULL;
  SUNLinearSolver LS = NULL;
  Model m;
  int* muted = NULL;
  double *ga = NULL, *gb = NULL, *gt = NULL, *gm = NULL, *te = NULL, *v_prev = NULL, *qgain = NULL;
  double* buf = NULL;
  double t_prev, t_cur, t_end = t_out[n_out - 1] - t0;  /* times since t0 from here on */

  memset(&m, 0, sizeof(m));
  if (msg_size > 0) msg[0] = 0;
  *written = 0;
  m.n = n; m.nz = nz; m.nq = nq; m.nv = nv; m.ng = ng; m.ns = ns; m.pd = pd; m.off = off; m.tables = tables;
  m.slots = slots;
  m.tdata = tdata; m.s_time = NAN; m.t0 = t0;
  for (i = 0; i < FUNCTIONS; i++) {
    m.fn[i] = (Generated)functions[i];
    ((WorkSizes)functions[FUNCTIONS + i])(&a, &r, &iw_, &w_);
    if (a > sz_arg) sz_arg = a;
    if (r > sz_res) sz_res = r;
    if (iw_ > sz_iw) sz_iw = iw_;
    if (w_ > sz_w) sz_w = w_;
  }
  /* one buffer: s, at (ns each), f (n), g (nz), jac (ny^2), znew (ny), dz (nz), dz0 (n), ga, gb, gt, gm, te,
   * v_prev (ng each), qgain (nq); laid out below in that order */
  sz = 2 * ns + 2 * n + 2 * nz + ny * ny + ny + nq + 6 * ng + 1;
  m.arg = malloc(sizeof(*m.arg) * sz_arg);
  m.res = malloc(sizeof(*m.res) * sz_res);
  m.iw = malloc(sizeof(*m.iw) * (sz_iw + 1));
  m.w = malloc(sizeof(*m.w) * (sz_w + 1));
  buf = malloc(sizeof(double) * sz);
  if (!m.arg || !m.res || !m.iw || !m.w || !buf) { status = -5; goto done; }
  m.s = buf; m.at = m.s + ns; m.f = m.at + ns; m.g = m.f + n; m.jac = m.g + nz;
  m.znew = m.jac + ny * ny; m.dz = m.znew + ny; m.dz0 = m.dz + nz;
  ga = m.dz0 + n; gb = ga + ng; gt = gb + ng; gm = gt + ng; te = gm + ng; v_prev = te + ng; qgain = v_prev + ng;
  memset(v_prev, 0, sizeof(double) * (ng + nq));
  muted = calloc(ng + 1, sizeof(int));
  if (!muted) { status = -5; goto done; }
  for (i = 0; i < ng; i++) muted[i] = mute[i];

  if (SUNContext_Create(NULL, &ctx)) { status = -5; goto done; }
  if (nz) {
    m.gz = SUNDenseMatrix(nz, nz, ctx);
    m.piv = malloc(sizeof(sunindextype) * nz);
    if (!m.gz || !m.piv) { status = -5; goto done; }
  }
  yy = N_VNew_Serial(ny, ctx); yp = N_VNew_Serial(ny, ctx); id = N_VNew_Serial(ny, ctx);
  tmp = N_VNew_Serial(ny, ctx);
  if (!yy || !yp || !id || !tmp) { status = -5; goto done; }
  memcpy(N_VGetArrayPointer(yy), y0, sizeof(double) * ny);
  if (call(&m, m.fn[F_DAE], 0.0, y0, m.f, m.g)) { status = -2; goto done; }
  for (i = 0; i < ny; i++) {
    N_VGetArrayPointer(yp)[i] = i < n ? m.f[i] : 0.0;
    N_VGetArrayPointer(id)[i] = i < n ? 1.0 : 0.0;
  }
  mem = ode ? CVodeCreate(CV_BDF, ctx) : IDACreate(ctx);
  if (!mem) { status = -5; goto done; }
  A = SUNDenseMatrix(ny, ny, ctx);
  LS = SUNLinSol_Dense(yy, A, ctx);
  if (!A || !LS) { status = -5; goto done; }
  double h0 = first_step > 0 ? first_step : first_step_guess(&m, y0, rtol, atol, t_end);
  if (nq) {
    yq = N_VNew_Serial(nq, ctx); tmpq = N_VNew_Serial(nq, ctx); tolq = N_VNew_Serial(nq, ctx);
    if (!yq || !tmpq || !tolq) { status = -5; goto done; }
    N_VConst(0.0, yq);
  }
  if (ode) {
    CVodeSetErrHandlerFn(mem, on_error, &box);
    if (CVodeInit(mem, rate, 0.0, yy) || CVodeSStolerances(mem, rtol, atol) || CVodeSetUserData(mem, &m) ||
        CVodeSetLinearSolver(mem, LS, A) || CVodeSetJacFn(mem, rate_jacobian)) { status = -1; goto done; }
    if (isfinite(max_step)) CVodeSetMaxStep(mem, max_step);
    CVodeSetInitStep(mem, h0);
    if (nq && (CVodeQuadInit(mem, rate_quadrature, yq) || CVodeQuadSStolerances(mem, rtol, atol) ||
               CVodeSetQuadErrCon(mem, SUNTRUE))) { status = -1; goto done; }
  } else {
    IDASetErrHandlerFn(mem, on_error, &box);
    if (IDAInit(mem, residual, 0.0, yy, yp) || IDASStolerances(mem, rtol, atol) || IDASetUserData(mem, &m) ||
        IDASetLinearSolver(mem, LS, A) || IDASetJacFn(mem, jacobian)) { status = -1; goto done; }
    if (isfinite(max_step)) IDASetMaxStep(mem, max_step);
    IDASetInitStep(mem, h0);
    IDASetId(mem, id);
    IDASetSuppressAlg(mem, SUNTRUE);
    if (nq && (IDAQuadInit(mem, quadrature, yq) || IDAQuadSStolerances(mem, rtol, atol) ||
               IDASetQuadErrCon(mem, SUNTRUE))) { status = -1; goto done; }
  }
  memcpy(ga, g0, sizeof(double) * ng);  /* the start's values, as the caller has them */
  t_prev = 0.0;
  /* the steps end at the last output, not beyond (the outputs before it are read off the interpolating polynomial:
   * a stop at each one truncated the steps of a dense grid and cost the whole chain 1.7x its time) */
  if (t_end > 0) { if (ode) CVodeSetStopTime(mem, t_end); else IDASetStopTime(mem, t_end); }
  while (k < n_out) {
    if (nq) quad_tolerances(mem, ode, qgain, nv, rtol, atol, tolq);
    flag = ode ? CVode(mem, t_end, yy, &t_cur, CV_ONE_STEP) : IDASolve(mem, t_end, &t_cur, yy, yp, IDA_ONE_STEP);
    if (flag < 0) { status = m.failed ? -2 : -1; goto done; }
    if (++steps > max_steps) { status = -4; goto done; }
    /* a crossing in (t_prev, t_cur]: the first sub-interval [ta, tb] of the step that shows one (ga: the zero
     * functions at ta, gb: at tb). The step's end first; its interior where a zero function crossed there, or where
     * its total variation over the step (a quadrature, the last nv of them) reaches |g(t_prev)| + |g(t_cur)|: it may
     * have gone to zero and back */
    long hit = 0, suspect = 0, j;
    double ta = t_prev, tb = t_cur;
    if (nq) { /* the integrals after the step, and what they gained in it */
      for (i = 0; i < nq; i++) qgain[i] = -N_VGetArrayPointer(yq)[i];
      get_quad(mem, ode, yq);
      /* the scale of the next step's error: the step's gain, or its length times the integrand at its end if more (an
       * integrand through zero gains little in a step, and its own size still bounds the next one's); the integrand
       * evaluated there, not read off the interpolant (a tenth of the solver's time went to that) */
      if (quad_values(&m, t_cur, N_VGetArrayPointer(yy), N_VGetArrayPointer(tmpq))) {
        status = -2; goto done;
      }
      for (i = 0; i < nq; i++)
        qgain[i] = fmax(fabs(qgain[i] + N_VGetArrayPointer(yq)[i]),
                        (t_cur - t_prev) * fabs(N_VGetArrayPointer(tmpq)[i]));
    }
    if (ng) {
      N_VScale(1.0, yy, tmp);
      if (zeros_at(&m, t_cur, N_VGetArrayPointer(tmp), gb, 0)) { status = -2; goto done; }
      for (i = 0; i < ng; i++) {
        if (!isfinite(gb[i])) suspect = 1;
        else if (CROSSES(i, ga, gb)) suspect = 1;
        else if (!nv || m.undefined) suspect = 1;  /* no variations, or one not defined: the step is searched */
        else if (ga[i] != 0 && (N_VGetArrayPointer(yq)[nq - nv + i] - v_prev[i]) * VARIATION
                 >= (fabs(ga[i]) + fabs(gb[i])) * (1 - 1e-9)) suspect = 1;
      }
      if (nv) memcpy(v_prev, N_VGetArrayPointer(yq) + nq - nv, sizeof(double) * nv);
      m.undefined = 0;
    }
    for (j = 1; suspect && j <= substeps + 1; j++) {
      double tj = j <= substeps ? t_prev + (t_cur - t_prev) * j / (substeps + 1) : t_cur;
      state_at(mem, ode, tj, t_cur, yy, tmp);
      if (zeros_at(&m, tj, N_VGetArrayPointer(tmp), gt, tj != t_cur)) { status = -2; goto done; }
      for (i = 0; i < ng; i++) {
        if (!isfinite(gt[i])) {
          *t_event = t0 + tj; memcpy(y_event, N_VGetArrayPointer(tmp), sizeof(double) * ny); status = -3; goto done;
        }
        if (CROSSES(i, ga, gt)) hit = 1;
      }
      if (hit) { tb = tj; memcpy(gb, gt, sizeof(double) * ng); break; }
      memcpy(ga, gt, sizeof(double) * ng);
      ta = tj;
      for (i = 0; i < ng; i++) if (ga[i] != 0) muted[i] = 0;
    }
    if (ng && !suspect) memcpy(ga, gb, sizeof(double) * ng);
    for (i = 0; i < ng && !hit; i++) if (ga[i] != 0) muted[i] = 0;
    double t_stop = t_cur;
    if (hit) {
      double first = INFINITY, last = -INFINITY, together;
      for (i = 0; i < ng; i++) {
        te[i] = NAN;
        if (!CROSSES(i, ga, gb)) continue;
        if (ga[i] == 0) { te[i] = ta; }       /* leaving an exact zero: the direction at the bracket's end decides */
        else if (gb[i] == 0) { te[i] = tb; }  /* reaching zero at the bracket's end */
        else {                                /* Illinois on the interpolating polynomial */
          double lo = ta, hi = tb, flo = ga[i], fhi = gb[i], tm, fm;
          double tol = 1e-13 * (fabs(t0 + tb) > 1 ? fabs(t0 + tb) : 1);
          int side = 0, it;
          for (it = 0; it < 200 && hi - lo > tol; it++) {
            tm = hi - fhi * (hi - lo) / (fhi - flo);
            if (!(tm > lo && tm < hi)) tm = 0.5 * (lo + hi);
            state_at(mem, ode, tm, t_cur, yy, tmp);
            if (zeros_at(&m, tm, N_VGetArrayPointer(tmp), gm, 1)) { status = -2; goto done; }
            fm = gm[i];
            if (fm == 0) { lo = hi = tm; break; }
            if ((fm < 0) == (fhi < 0)) { hi = tm; fhi = fm; if (side == -1) flo /= 2; side = -1; }
            else { lo = tm; flo = fm; if (side == 1) fhi /= 2; side = 1; }
          }
          te[i] = hi; /* on the far side (or at the zero) */
        }
        if (te[i] < first) first = te[i];
      }
      together = 1e-9 * (fabs(t0 + first) > 1 ? fabs(t0 + first) : 1);
      for (i = 0; i < ng; i++) /* those within 1e-9 of the first cross together, at the latest of their times */
        if (!isnan(te[i]) && te[i] <= first + together && te[i] > last)
          last = te[i];
      for (i = 0; i < ng; i++) {
        dirs[i] = 0;
        if (!isnan(te[i]) && te[i] <= first + together)
          dirs[i] = ga[i] != 0 ? (ga[i] < 0 ? 1 : -1) : (gb[i] > 0 ? 1 : -1);
      }
      t_stop = last;
    }
    /* outputs up to the step's end (or the crossing) */
    while (k < n_out && t_out[k] - t0 <= t_stop) {
      state_at(mem, ode, t_out[k] - t0, t_cur, yy, tmp);
      memcpy(X + k * ny, N_VGetArrayPointer(tmp), sizeof(double) * ny);
      if (nq) {
        quad_at(mem, ode, t_out[k] - t0, t_cur, tmpq);
        memcpy(Q + k * nq, N_VGetArrayPointer(tmpq), sizeof(double) * nq);
      }
      k++;
    }
    if (hit) {
      *t_event = t0 + t_stop;
      state_at(mem, ode, t_stop, t_cur, yy, tmp);
      memcpy(y_event, N_VGetArrayPointer(tmp), sizeof(double) * ny);
      if (nq) {
        quad_at(mem, ode, t_stop, t_cur, tmpq);
        memcpy(q_event, N_VGetArrayPointer(tmpq), sizeof(double) * nq);
      }
      status = 1;
      goto done;
    }
    if (t_cur >= t_end) break;
    t_prev = t_cur;
  }
done:
  *written = k;
  if (mem) { if (ode) CVodeFree(&mem); else IDAFree(&mem); }
  if (LS) SUNLinSolFree(LS);
  if (A) SUNMatDestroy(A);
  if (m.gz) SUNMatDestroy(m.gz);
  free(m.piv);
  if (yy) N_VDestroy(yy);
  if (yp) N_VDestroy(yp);
  if (id) N_VDestroy(id);
  if (tmp) N_VDestroy(tmp);
  if (yq) N_VDestroy(yq);
  if (tmpq) N_VDestroy(tmpq);
  if (tolq) N_VDestroy(tolq);
  if (ctx) SUNContext_Free(&ctx);
  free(m.arg); free(m.res); free(m.iw); free(m.w); free(buf); free(muted);
  return status;
}
