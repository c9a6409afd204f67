/* ---------------------------------------------------------------------------------------------------------
 * acausal FMI 2.0 Model Exchange runtime: the same for every exported model. The model's part (above: sizes,
 * start values, names; below: model_bound_parameters, model_check_parameter, model_check_assertions, model_evaluate,
 * model_event) is generated from the compiled model's solved equations.
 *
 * Every real variable lives in r[] at the index of its value reference: parameters, states, unknowns (state
 * derivatives included), aliases, discrete modes. model_evaluate computes unknowns, aliases and event indicators
 * from time, states, parameters and modes; the runtime evaluates lazily (values are valid until time, a state, a
 * parameter or a mode changes). A Newton block is solved as simulate() solves it (solve_newton): the damped
 * iteration of acausal.backends.numpy.runtime.newton, from the block's last converged solution, and from its start
 * values where that fails.
 *
 * Initialisation (fmi2ExitInitializationMode) follows acausal's simulate(): bound parameters computed and every
 * parameter checked against its bounds; the states start at their start values, and variables with a fixed start
 * that are not states are met by a minimum-norm Gauss-Newton iteration on the states that are neither fixed nor
 * set through fmi2SetReal; the modes are settled by the signs of the event indicators, and the states initialised
 * again with the settled modes.
 *
 * Events (fmi2NewDiscreteStates) follow acausal.simulation.events, in fmi2_events.c (after this file): the crossings since the
 * last event apply their assignments, and the event iteration runs to its end in the same call (a cycle of modes
 * is kept at the knee or is an error naming the components; a NaN or infinite indicator is an error naming it).
 * More events than the Integer parameter max_events (simulate()'s max_events and its default) are an error
 * naming the limit, the time and the last event's component, as simulate() raises it: a chattering model stops
 * instead of stepping on from event to event.
 * --------------------------------------------------------------------------------------------------------- */

#define NX1 (NX > 0 ? NX : 1)
#define NZ1 (NZ > 0 ? NZ : 1)
#define ND1 (ND > 0 ? ND : 1)
#define NT1 (NT > 0 ? NT : 1)
#define VR_MAX_EVENTS NR     /* the one Integer variable, max_events: its value reference follows every Real's */
#define NNB1 (NNB > 0 ? NNB : 1)
#define NNY1 (NNY > 0 ? NNY : 1)

enum { PHASE_INSTANTIATED, PHASE_INIT, PHASE_EVENT, PHASE_CONTINUOUS, PHASE_TERMINATED, PHASE_ERROR };

typedef struct {
    double r[NR];
    double z[NZ1];
    double z_pre[NZ1];       /* the indicators relative to off at the last event */
    double off[NZ1];         /* thresholds the indicators are watched at (modes.knee_offsets); 0 normally */
    double x_start[NX1];
    double time;
    int given[NX1];          /* state start set through fmi2SetReal: fixed at initialisation */
    int phase;
    int valid;               /* r holds unknowns, aliases and indicators of the current inputs */
    int initial;             /* the next fmi2NewDiscreteStates is the initial event update */
    int states_changed;      /* the last event update reinitialised states (Event.reinit) */
    int max_events;          /* the event limit (parameter max_events; simulate()'s max_events) */
    double newton_y[NNY1];   /* each Newton block's tear variables where it last converged (block b at the offset
                              * its solve_newton call passes), its start values before */
    int newton_solved[NNB1]; /* block b has converged since the start: its next iteration starts from there */
    long n_events;           /* events since initialisation, counted as simulate() counts Result.events */
    int logging;
    fmi2CallbackLogger logger;
    fmi2CallbackFreeMemory free_memory;
    fmi2ComponentEnvironment env;
    char name[128];
    char message[2048];      /* why the last evaluation failed */
} Inst;

static void model_bound_parameters(Inst *m);
static int model_check_parameter(Inst *m, int vr);
static int model_check_assertions(Inst *m);
static int model_evaluate(Inst *m);
static void model_event(Inst *m, int i, int rising);
static int model_reinit(Inst *m, int i, double *x);  /* event i's Event.reinit into x (states); 1 if it has any */
static int check_indicators(Inst *m);  /* fmi2_events.c */
static int settle_modes(Inst *m);
static int event_update(Inst *m, int initial);
static int crossed(double a, double b);

#include <stdarg.h>

static void log_msg(Inst *m, fmi2Status status, const char *category, const char *fmt, ...) {
    char text[4096], escaped[8192];
    va_list ap;
    size_t i, k = 0;
    if (!m || !m->logger || (status == fmi2OK && !m->logging)) return;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    for (i = 0; text[i] && k + 2 < sizeof escaped; i++) {  /* the logger takes a format string: keep % as is */
        if (text[i] == '%') escaped[k++] = '%';
        escaped[k++] = text[i];
    }
    escaped[k] = 0;
    m->logger(m->env, m->name, status, category, escaped);
}

/* ------------------------------------------------------------------------------------- numeric helpers */
/* A y = b by Gaussian elimination with partial pivoting (A row-major n x n, overwritten; b becomes y). */
MAYBE_UNUSED static int solve_linear(int n, double *A, double *b) {
    int i, j, k, p;
    for (k = 0; k < n; k++) {
        double best = fabs(A[k * n + k]);
        p = k;
        for (i = k + 1; i < n; i++)
            if (fabs(A[i * n + k]) > best) { best = fabs(A[i * n + k]); p = i; }
        if (!(best > 0.0)) return 1;
        if (p != k) {
            for (j = 0; j < n; j++) { double s = A[k * n + j]; A[k * n + j] = A[p * n + j]; A[p * n + j] = s; }
            { double s = b[k]; b[k] = b[p]; b[p] = s; }
        }
        for (i = k + 1; i < n; i++) {
            double f = A[i * n + k] / A[k * n + k];
            if (f == 0.0) continue;
            for (j = k; j < n; j++) A[i * n + j] -= f * A[k * n + j];
            b[i] -= f * b[k];
        }
    }
    for (k = n - 1; k >= 0; k--) {
        double s = b[k];
        for (j = k + 1; j < n; j++) s -= A[k * n + j] * b[j];
        b[k] = s / A[k * n + k];
    }
    return 0;
}

typedef void (*residual_fn)(Inst *m, const double *y, double *res, double *jac);

/* max |r_i| (NaN when one is NaN, as numpy's max) */
static double max_abs(int n, const double *r) {
    double w = 0.0;
    int i;
    for (i = 0; i < n; i++) if (!(fabs(r[i]) <= w)) w = fabs(r[i]);
    return w;
}

/* acausal.backends.numpy.runtime.newton from y (overwritten with the last iterate; res with its residuals): damped
 * Newton with the exact Jacobian, NEWTON_MAXITER iterations at most; each solves J dy = -r and takes the full step
 * where max |r_i| does not grow there, else halves it up to NEWTON_HALVINGS times; converged when every step is
 * below NEWTON_TOL relative to 1 + |y_i|; after the last iteration accepted when every residual is below
 * NEWTON_ACCEPT. 0 when converged, else 1 with why the iteration failed in why (start: what y was, for it). */
static int newton_iterate(Inst *m, int n, double *y, double *res, residual_fn f, const char *start, char *why,
                          size_t size) {
    double jac[NEWTON_MAX * NEWTON_MAX], A[NEWTON_MAX * NEWTON_MAX], dy[NEWTON_MAX], y_new[NEWTON_MAX];
    double r_new[NEWTON_MAX], nr, nr_new;
    int it, i, h;
    f(m, y, res, jac);
    nr = max_abs(n, res);
    if (!isfinite(nr)) { snprintf(why, size, "the residual is not finite at %s", start); return 1; }
    for (it = 0; it < NEWTON_MAXITER; it++) {
        double step = 0.0;
        memcpy(A, jac, sizeof(double) * n * n);
        for (i = 0; i < n; i++) dy[i] = -res[i];
        if (solve_linear(n, A, dy)) { snprintf(why, size, "singular Jacobian"); return 1; }
        for (i = 0; i < n; i++) {
            double s;
            y_new[i] = y[i] + dy[i];
            s = fabs(dy[i]) / (1.0 + fabs(y_new[i]));
            if (!(s <= step)) step = s;  /* NaN propagates */
        }
        if (!isfinite(step)) {
            snprintf(why, size, "non-finite Newton step (the Jacobian is not finite or nearly singular)");
            return 1;
        }
        if (step < NEWTON_TOL) { memcpy(y, y_new, sizeof(double) * n); return 0; }
        f(m, y_new, r_new, jac);
        nr_new = max_abs(n, r_new);
        if (!(nr_new <= nr)) {  /* worse, or not finite: backtrack */
            double lam = 1.0;
            for (h = 0; h < NEWTON_HALVINGS; h++) {
                lam *= 0.5;
                for (i = 0; i < n; i++) y_new[i] = y[i] + lam * dy[i];
                f(m, y_new, r_new, jac);
                nr_new = max_abs(n, r_new);
                if (nr_new <= nr) break;
            }
            if (!isfinite(nr_new)) {
                snprintf(why, size, "the residual is not finite on the Newton step nor on the shortest damped step");
                return 1;
            }
        }
        memcpy(y, y_new, sizeof(double) * n);
        memcpy(res, r_new, sizeof(double) * n);
        nr = nr_new;
    }
    if (nr < NEWTON_ACCEPT) return 0;
    snprintf(why, size, "did not converge in %d iterations (residual %.3g)", NEWTON_MAXITER, nr);
    return 1;
}

/* "'name' = value, ..." of a block's tear variables to 6 digits (names NULL: "value, ..." to digits) */
static void values_text(char *buf, size_t size, int n, const char *const *names, const double *y, int digits) {
    size_t used = 0;
    int i;
    buf[0] = 0;
    for (i = 0; i < n && used < size; i++) {
        int k = names ? snprintf(buf + used, size - used, "%s'%s' = %.6g", i ? ", " : "", names[i], y[i])
                      : snprintf(buf + used, size - used, "%s%.*g", i ? ", " : "", digits, y[i]);
        if (k < 0) break;
        used += (size_t)k;
    }
}

/* Newton block b (n tear variables called names, from offset at in newton_guess and m->newton_y) solved as
 * simulate() solves it: from its last converged solution where it has one (as IDAS carries a block's variables
 * from step to step, and a segment after an event starts from where the one before ended), else from its start
 * values; when the iteration fails from the last solution, once more from the start values (as a failed run on
 * the compiled path runs again on the scipy path, which starts every evaluation from them). The solution is in
 * m->newton_y + at; a failure's message (why from the start values, and from the last solution where tried; the
 * last iterate beside the start values, the residuals) is in m->message, and m->newton_y keeps the last solution. */
MAYBE_UNUSED static int solve_newton(Inst *m, int n, int b, int at, residual_fn f, const char *label,
                                     const char *const *names) {
    double y[NEWTON_MAX], res[NEWTON_MAX];
    const double *guess = newton_guess + at;
    char why[256], first[256], before[768], last[512], iterate[512], starts[512], residuals[512], who[512];
    size_t used = 0;
    int i;
    before[0] = 0;
    if (n > NEWTON_MAX) {
        snprintf(m->message, sizeof m->message, "%s: more than %d tear variables", label, NEWTON_MAX);
        return 1;
    }
    if (m->newton_solved[b]) {
        memcpy(y, m->newton_y + at, sizeof(double) * n);
        if (!newton_iterate(m, n, y, res, f, "the last solution", why, sizeof why)) {
            memcpy(m->newton_y + at, y, sizeof(double) * n);
            return 0;
        }
        values_text(last, sizeof last, n, names, m->newton_y + at, 6);
        memcpy(first, why, sizeof first);
        snprintf(before, sizeof before, "; from the last solution %s: %s", last, first);
    }
    memcpy(y, guess, sizeof(double) * n);
    if (!newton_iterate(m, n, y, res, f, "the start values", why, sizeof why)) {
        if (m->newton_solved[b])
            log_msg(m, fmi2OK, "logNewton", "t = %.17g s: Newton iteration for %s from the last solution %s: %s; "
                    "solved from the start values", m->time, label, last, first);
        memcpy(m->newton_y + at, y, sizeof(double) * n);
        m->newton_solved[b] = 1;
        return 0;
    }
    values_text(iterate, sizeof iterate, n, names, y, 6);
    values_text(residuals, sizeof residuals, n, NULL, res, 3);
    values_text(starts, sizeof starts, n, NULL, guess, 6);
    who[0] = 0;
    for (i = 0; i < n && used < sizeof who; i++) {
        int k = snprintf(who + used, sizeof who - used, "%s'%s'", i ? ", " : "", names[i]);
        if (k < 0) break;
        used += (size_t)k;
    }
    snprintf(m->message, sizeof m->message, "Newton iteration for %s: %s%s; last iterate %s (start %s), "
             "residuals %s. Hint: give %s a start value near the solution (Start(value) where the "
             "component is made, or Variable(start=...) in its class) and export again; if the importing tool's "
             "integrator stepped far (a trial state), try a smaller step", label, why, before, iterate, starts,
             residuals, who);
    return 1;
}

/* A table signal: piece i covers breaks[i] <= tau < breaks[i+1], value sum_k coef[i][k] (tau - breaks[i])^(deg-k).
 * outside: 0 periodic, 1 hold (end values held, derivatives zero), 2 extend (end pieces continue). */
MAYBE_UNUSED static double table_value(const double *breaks, const double *coef, int pieces, int degree, int outside,
                          double arg, int order) {
    double b0 = breaks[0], bn = breaks[pieces], tau = arg, x, y = 0.0;
    int lo = 0, hi = pieces, i, k;
    if (outside == 0) {
        double span = bn - b0;
        tau = arg - span * floor((arg - b0) / span);
    } else if (outside == 1) {
        if (order > 0 && !(arg >= b0 && arg < bn)) return 0.0;
        tau = arg < b0 ? b0 : (arg > bn ? bn : arg);
    }
    while (hi - lo > 1) {  /* the last break <= tau */
        int mid = (lo + hi) / 2;
        if (breaks[mid] <= tau) lo = mid; else hi = mid;
    }
    i = lo;
    x = tau - breaks[i];
    for (k = 0; k <= degree - order; k++) {
        int power = degree - k, j;
        double c = coef[i * (degree + 1) + k];
        for (j = 0; j < order; j++) c *= (double)(power - j);
        y = y * x + c;
    }
    return y;
}

/* ------------------------------------------------------------------------------------- evaluation */
static int ensure(Inst *m) {
    if (m->valid) return 0;
    m->message[0] = 0;
    if (model_evaluate(m)) {
        log_msg(m, fmi2Error, "logStatusError", "at t = %.9g s: %s", m->time, m->message);
        return 1;
    }
    m->valid = 1;
    return 0;
}

/* the first unknown (in the order the model computes them) that is not finite, or -1 */
static int first_non_finite(Inst *m) {
    int k;
    for (k = 0; k < NV; k++)
        if (!isfinite(m->r[order_vr[k]])) return order_vr[k];
    return -1;
}

/* acausal.simulation.simulate.initialize: states at their start values; fixed starts of other variables (targets) met by
 * a minimum-norm Gauss-Newton iteration on the free states (finite-difference Jacobian). */
static int initialize_states(Inst *m) {
    double want[NT1], res[NT1], res2[NT1], J[NT1 * NX1], G[NT1 * NT1 > NX1 * NX1 ? NT1 * NT1 : NX1 * NX1];
    double rhs[NT1 > NX1 ? NT1 : NX1], scale[NT1];
    int free_idx[NX1], nf = 0, i, j, k, it;
    memcpy(m->r + OFF_X, m->x_start, sizeof(double) * NX);
    m->valid = 0;
    if (NT == 0) return 0;
    for (i = 0; i < NX; i++) if (!state_fixed[i] && !m->given[i]) free_idx[nf++] = i;
    for (k = 0; k < NT; k++) {
        want[k] = target_value[k];
        scale[k] = fabs(want[k]) > 1.0 ? fabs(want[k]) : 1.0;
    }
#define RESIDUAL(out)                                                          \
    do {                                                                       \
        m->valid = 0;                                                          \
        if (ensure(m)) return 1;                                               \
        for (k = 0; k < NT; k++) (out)[k] = m->r[target_vr[k]] - want[k];      \
    } while (0)
    for (it = 0; it < 50; it++) {
        int done = 1;
        double big = 0.0, largest = 1.0;
        RESIDUAL(res);
        for (k = 0; k < NT; k++) if (!(fabs(res[k]) <= 1e-10 * scale[k])) done = 0;
        if (done || nf == 0) break;
        for (j = 0; j < nf; j++) {
            double *x = &m->r[OFF_X + free_idx[j]], keep = *x;
            double h = 1e-7 * (fabs(keep) > 1.0 ? fabs(keep) : 1.0);
            *x = keep + h;
            RESIDUAL(res2);
            *x = keep;
            for (k = 0; k < NT; k++) J[k * nf + j] = (res2[k] - res[k]) / h;
        }
        /* minimum-norm least squares: (J J^T) y = -res, step = J^T y (as many targets as free states or fewer),
         * else the normal equations (J^T J) step = -J^T res; a tiny ridge keeps a rank-deficient J solvable */
        if (NT <= nf) {
            double tr = 0.0;
            for (i = 0; i < NT; i++)
                for (k = 0; k < NT; k++) {
                    double s = 0.0;
                    for (j = 0; j < nf; j++) s += J[i * nf + j] * J[k * nf + j];
                    G[i * NT + k] = s;
                }
            for (i = 0; i < NT; i++) tr += G[i * NT + i];
            for (i = 0; i < NT; i++) { G[i * NT + i] += 1e-14 * tr + 1e-300; rhs[i] = -res[i]; }
            if (solve_linear(NT, G, rhs)) break;
            for (j = 0; j < nf; j++) {
                double s = 0.0;
                for (k = 0; k < NT; k++) s += J[k * nf + j] * rhs[k];
                m->r[OFF_X + free_idx[j]] += s;
                if (fabs(s) > big) big = fabs(s);
            }
        } else {
            double tr = 0.0;
            for (i = 0; i < nf; i++) {
                for (j = 0; j < nf; j++) {
                    double s = 0.0;
                    for (k = 0; k < NT; k++) s += J[k * nf + i] * J[k * nf + j];
                    G[i * nf + j] = s;
                }
                rhs[i] = 0.0;
                for (k = 0; k < NT; k++) rhs[i] -= J[k * nf + i] * res[k];
            }
            for (i = 0; i < nf; i++) tr += G[i * nf + i];
            for (i = 0; i < nf; i++) G[i * nf + i] += 1e-14 * tr + 1e-300;
            if (solve_linear(nf, G, rhs)) break;
            for (j = 0; j < nf; j++) {
                m->r[OFF_X + free_idx[j]] += rhs[j];
                if (fabs(rhs[j]) > big) big = fabs(rhs[j]);
            }
        }
        for (j = 0; j < nf; j++)
            if (fabs(m->r[OFF_X + free_idx[j]]) > largest) largest = fabs(m->r[OFF_X + free_idx[j]]);
        if (big < 1e-14 * largest) break;
    }
    RESIDUAL(res);
#undef RESIDUAL
    for (k = 0; k < NT; k++) {
        if (!(fabs(res[k]) <= 1e-7 * scale[k])) {
            log_msg(m, fmi2Error, "logStatusError", "inconsistent initial conditions: cannot meet %s (wanted %.6g, "
                    "got %.6g) with the %d states that are neither fixed nor set free", var_names[target_vr[k]],
                    want[k], want[k] + res[k], nf);
            return 1;
        }
    }
    return 0;
}

static int nonfinite_error(Inst *m, const char *what) {
    int bad = first_non_finite(m);
    if (bad >= 0)
        log_msg(m, fmi2Error, "logStatusError", "non-finite value at t = %.9g s: %s = %g (%s)", m->time,
                var_names[bad], m->r[bad], what);
    else
        log_msg(m, fmi2Error, "logStatusError", "non-finite %s at t = %.9g s", what, m->time);
    return 1;
}

/* ------------------------------------------------------------------------------------- FMI 2.0 functions */
#define INST ((Inst *)c)
#define CHECK_INST if (!c) return fmi2Error
#define FAIL(...) do { log_msg(INST, fmi2Error, "logStatusError", __VA_ARGS__); return fmi2Error; } while (0)

FMI2_EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }
FMI2_EXPORT const char *fmi2GetVersion(void) { return "2.0"; }

FMI2_EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                                           const fmi2String categories[]) {
    (void)nCategories; (void)categories;
    CHECK_INST;
    INST->logging = loggingOn;
    return fmi2OK;
}

static void reset_instance(Inst *m) {
    memcpy(m->r, start_values, sizeof(double) * NR);
    memcpy(m->x_start, start_values + OFF_X, sizeof(double) * NX);
    memset(m->given, 0, sizeof m->given);
    memset(m->off, 0, sizeof m->off);
    m->time = 0.0;
    m->phase = PHASE_INSTANTIATED;
    m->valid = 0;
    m->initial = 0;
    m->max_events = MAX_EVENTS_DEFAULT;
    m->n_events = 0;
    memcpy(m->newton_y, newton_guess, sizeof(double) * NNY);
    memset(m->newton_solved, 0, sizeof m->newton_solved);
    model_bound_parameters(m);
}

FMI2_EXPORT fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                                          fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                                          fmi2Boolean visible, fmi2Boolean loggingOn) {
    Inst *m;
    (void)fmuResourceLocation; (void)visible;
    if (!functions) return NULL;
    if (fmuType != fmi2ModelExchange) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError",
                              "this FMU supports Model Exchange only (no Co-Simulation)");
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, MODEL_GUID) != 0) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError",
                              "the GUID does not match this binary's modelDescription.xml");
        return NULL;
    }
    m = functions->allocateMemory ? (Inst *)functions->allocateMemory(1, sizeof(Inst))
                                  : (Inst *)calloc(1, sizeof(Inst));
    if (!m) return NULL;
    m->logger = functions->logger;
    m->free_memory = functions->allocateMemory ? functions->freeMemory : free;
    m->env = functions->componentEnvironment;
    m->logging = loggingOn;
    snprintf(m->name, sizeof m->name, "%s", instanceName ? instanceName : MODEL_IDENTIFIER);
    reset_instance(m);
    return m;
}

FMI2_EXPORT void fmi2FreeInstance(fmi2Component c) {
    if (c) INST->free_memory(c);
}

FMI2_EXPORT fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                                           fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    CHECK_INST;
    INST->time = startTime;
    INST->valid = 0;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    CHECK_INST;
    INST->phase = PHASE_INIT;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Inst *m = INST;
    int k, bad = 0;
    CHECK_INST;
    model_bound_parameters(m);
    for (k = 0; k < NP; k++) bad |= model_check_parameter(m, k);
    if (!bad) bad = model_check_assertions(m);
    if (bad) { m->phase = PHASE_ERROR; return fmi2Error; }
    for (k = 0; k < NPT; k++)
        if (m->r[tabulated_vr[k]] != tabulated_value[k])
            log_msg(m, fmi2Warning, "logStatusWarning", "parameter %s = %g differs from the value %g its input "
                    "table was built with at export: the table is not rebuilt (export again to change it)",
                    var_names[tabulated_vr[k]], m->r[tabulated_vr[k]], tabulated_value[k]);
    memcpy(m->x_start, m->r + OFF_X, sizeof(double) * NX);
    if (initialize_states(m)) { m->phase = PHASE_ERROR; return fmi2Error; }
    if (NZ > 0) {
        if (settle_modes(m)) { m->phase = PHASE_ERROR; return fmi2Error; }
        if (ND > 0 && initialize_states(m)) { m->phase = PHASE_ERROR; return fmi2Error; }
    }
    if (ensure(m)) { m->phase = PHASE_ERROR; return fmi2Error; }
    memcpy(m->z_pre, m->z, sizeof(double) * NZ);
    m->n_events = 0;
    m->initial = 1;
    m->phase = PHASE_EVENT;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2Terminate(fmi2Component c) {
    CHECK_INST;
    INST->phase = PHASE_TERMINATED;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2Reset(fmi2Component c) {
    CHECK_INST;
    reset_instance(INST);
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    size_t i;
    CHECK_INST;
    for (i = 0; i < nvr; i++) {
        if (vr[i] >= NR) FAIL("fmi2GetReal: no variable has the value reference %u", vr[i]);
        if (vr[i] >= OFF_V && vr[i] < OFF_D && ensure(INST)) return fmi2Error;
        value[i] = INST->r[vr[i]];
    }
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                   const fmi2Real value[]) {
    Inst *m = INST;
    size_t i;
    int params = 0;
    CHECK_INST;
    for (i = 0; i < nvr; i++) {
        unsigned int k = vr[i];
        if (k >= NR) FAIL("fmi2SetReal: no variable has the value reference %u", k);
        if (k < OFF_X) {
            if (bound_message[k]) FAIL("fmi2SetReal: %s", bound_message[k]);
            if (m->phase > PHASE_INIT)
                FAIL("fmi2SetReal: parameter %s is fixed: set it before fmi2ExitInitializationMode", var_names[k]);
            m->r[k] = value[i];
            if (model_check_parameter(m, (int)k)) return fmi2Error;
            params = 1;
        } else if (k < OFF_V) {
            if (m->phase > PHASE_INIT)
                FAIL("fmi2SetReal: the state %s is set through fmi2SetContinuousStates after initialisation",
                     var_names[k]);
            m->r[k] = value[i];
            m->given[k - OFF_X] = 1;
        } else {
            FAIL("fmi2SetReal: %s is computed by the model (causality %s): it cannot be set", var_names[k],
                 k >= OFF_D ? "local" : "output");
        }
        m->valid = 0;
    }
    if (params) model_bound_parameters(m);
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      fmi2Integer value[]) {
    size_t i;
    CHECK_INST;
    for (i = 0; i < nvr; i++) {
        if (vr[i] != VR_MAX_EVENTS)
            FAIL("fmi2GetInteger: no Integer variable has the value reference %u (the one Integer variable is "
                 "max_events, %u)", vr[i], (unsigned int)VR_MAX_EVENTS);
        value[i] = INST->max_events;
    }
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      fmi2Boolean value[]) {
    (void)vr; (void)value;
    CHECK_INST;
    if (nvr) FAIL("fmi2GetBoolean: the model has no Boolean variables");
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                     fmi2String value[]) {
    (void)vr; (void)value;
    CHECK_INST;
    if (nvr) FAIL("fmi2GetString: the model has no String variables");
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      const fmi2Integer value[]) {
    size_t i;
    CHECK_INST;
    for (i = 0; i < nvr; i++) {
        if (vr[i] != VR_MAX_EVENTS)
            FAIL("fmi2SetInteger: no Integer variable has the value reference %u (the one Integer variable is "
                 "max_events, %u)", vr[i], (unsigned int)VR_MAX_EVENTS);
        if (INST->phase > PHASE_INIT)
            FAIL("fmi2SetInteger: max_events is fixed: set it before fmi2ExitInitializationMode");
        if (value[i] < 0) FAIL("fmi2SetInteger: max_events = %d is negative (the number of events allowed, 0 or "
                               "more; simulate()'s default is %d)", value[i], MAX_EVENTS_DEFAULT);
        INST->max_events = value[i];
    }
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      const fmi2Boolean value[]) {
    (void)vr; (void)value;
    CHECK_INST;
    if (nvr) FAIL("fmi2SetBoolean: the model has no Boolean variables");
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                     const fmi2String value[]) {
    (void)vr; (void)value;
    CHECK_INST;
    if (nvr) FAIL("fmi2SetString: the model has no String variables");
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    Inst *copy;
    CHECK_INST;
    copy = *state ? (Inst *)*state : (Inst *)malloc(sizeof(Inst));
    if (!copy) FAIL("fmi2GetFMUstate: out of memory");
    memcpy(copy, c, sizeof(Inst));
    *state = copy;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    CHECK_INST;
    if (!state) FAIL("fmi2SetFMUstate: no state given");
    memcpy(c, state, sizeof(Inst));
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    (void)c;
    if (state && *state) { free(*state); *state = NULL; }
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size) {
    (void)state; (void)size;
    CHECK_INST;
    FAIL("fmi2SerializedFMUstateSize: not supported (canSerializeFMUstate is false)");
}

FMI2_EXPORT fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    (void)state; (void)bytes; (void)size;
    CHECK_INST;
    FAIL("fmi2SerializeFMUstate: not supported (canSerializeFMUstate is false)");
}

FMI2_EXPORT fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size,
                                               fmi2FMUstate *state) {
    (void)bytes; (void)size; (void)state;
    CHECK_INST;
    FAIL("fmi2DeSerializeFMUstate: not supported (canSerializeFMUstate is false)");
}

FMI2_EXPORT fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                                    size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                                    size_t nKnown, const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    CHECK_INST;
    FAIL("fmi2GetDirectionalDerivative: not supported (providesDirectionalDerivative is false)");
}

/* ---------------------------------------------------------------------------------- Model Exchange */
FMI2_EXPORT fmi2Status fmi2EnterEventMode(fmi2Component c) {
    CHECK_INST;
    INST->phase = PHASE_EVENT;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info) {
    Inst *m = INST;
    int initial;
    CHECK_INST;
    info->newDiscreteStatesNeeded = fmi2False;
    info->terminateSimulation = fmi2False;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = fmi2False;
    info->nextEventTimeDefined = fmi2False;
    info->nextEventTime = 0.0;
    initial = m->initial;
    m->initial = 0;
    if (NZ == 0) return fmi2OK;
    m->states_changed = 0;
    if (event_update(m, initial)) { m->phase = PHASE_ERROR; return fmi2Error; }
    if (m->states_changed) info->valuesOfContinuousStatesChanged = fmi2True;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    CHECK_INST;
    INST->phase = PHASE_CONTINUOUS;
    return fmi2OK;
}

/* An indicator that left an exact zero (a diode at rest at the start) shows no sign change to the environment's
 * root finding: the step that leaves it asks for an event, in which its direction applies its assignments (as
 * acausal.simulation.events.crossings does when a step leaves an exact zero). */
FMI2_EXPORT fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                                   fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation) {
    int i;
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK_INST;
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    if (NZ == 0) return fmi2OK;
    if (ensure(INST) || check_indicators(INST)) return fmi2Error;
    for (i = 0; i < NZ; i++)
        if (crossed(INST->z_pre[i], INST->z[i] - INST->off[i]) >= 0) *enterEventMode = fmi2True;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    CHECK_INST;
    if (INST->time != time) { INST->time = time; INST->valid = 0; }
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    CHECK_INST;
    if (nx != NX) FAIL("fmi2SetContinuousStates: %d states expected, got %d", NX, (int)nx);
    if (NX) memcpy(INST->r + OFF_X, x, sizeof(double) * NX);
    INST->valid = 0;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    Inst *m = INST;
    size_t i;
    CHECK_INST;
    if (nx != NX) FAIL("fmi2GetDerivatives: %d states expected, got %d", NX, (int)nx);
    if (ensure(m)) return fmi2Error;
    for (i = 0; i < nx; i++) {
        derivatives[i] = m->r[der_vr[i]];
        if (!isfinite(derivatives[i])) { nonfinite_error(m, "a state derivative"); return fmi2Error; }
    }
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    size_t i;
    CHECK_INST;
    if (ni != NZ) FAIL("fmi2GetEventIndicators: %d indicators expected, got %d", NZ, (int)ni);
    if (NZ == 0) return fmi2OK;
    if (ensure(INST)) return fmi2Error;
    if (check_indicators(INST)) return fmi2Error;
    for (i = 0; i < NZ; i++) eventIndicators[i] = INST->z[i] - INST->off[i];  /* watched at off (knee_offsets) */
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    CHECK_INST;
    if (nx != NX) FAIL("fmi2GetContinuousStates: %d states expected, got %d", NX, (int)nx);
    if (NX) memcpy(x, INST->r + OFF_X, sizeof(double) * NX);
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    size_t i;
    CHECK_INST;
    if (nx != NX) FAIL("fmi2GetNominalsOfContinuousStates: %d states expected, got %d", NX, (int)nx);
    for (i = 0; i < nx; i++) x_nominal[i] = state_nominal[i];
    return fmi2OK;
}
