/* ---------------------------------------------------------------------------------------------------------
 * acausal FMI 2.0 runtime, events: acausal.simulation.events' rules in C, so that an FMU switches as simulate() does.
 *
 * check_indicators   modes.check_zeros: a NaN or infinite indicator is an error naming the event's component,
 *                    its zero function, the time and the modes (it has no sign to switch on)
 * crossed            modes.crossings: the direction of a crossing since the last event (leaving an exact zero
 *                    takes the direction it leaves to, reaching one the direction it came from)
 * settle_modes       modes.settle_modes: at initialisation, every event's assignments by its indicator's sign
 * event_update       one event (fmi2NewDiscreteStates): the crossings since the last event (hits) apply their
 *                    assignments; when a mode changed, the hits are logged and the cascade runs
 * look_ahead         at the start: the direction in which an indicator exactly at zero leaves it
 * cascade            modes.cascade: mode changes that flip other indicators apply theirs until nothing flips;
 *                    a return to modes already visited keeps the present modes when every flip that closes the
 *                    cycle is within KNEE of zero, and is otherwise an error naming the components that chatter
 * knee_offsets       modes.knee_offsets: after an event, the thresholds the indicators are watched at (m->off)
 * reinits            modes.apply_reinits: the rising crossings' Event.reinit restart states before the cascade
 * event limit        events.record_events: more than max_events events (the hits that change a mode, each
 *                    counted as Result.events lists it) are an error naming the limit, the time and the last
 *                    event's component
 * --------------------------------------------------------------------------------------------------------- */

/* KNEE (an indicator this close to zero is at its switching point), ROUNDOFF, MAX_CASCADE and MAX_SETTLE are
 * generated from acausal.simulation.events (KNEE, ROUNDOFF, CASCADE_ITER, SETTLE_ITER) */
#define MODES (m->r + OFF_D)
#define NO1 (NO > 0 ? NO : 1)

/* "name = value, ..." of the modes d, as modes.py's messages list them */
static const char *modes_text(const double *d, char *buf, size_t size) {
    size_t used = 0;
    int k;
    buf[0] = 0;
    for (k = 0; k < ND && used < size; k++) {
        int n = snprintf(buf + used, size - used, "%s%s = %g", k ? ", " : "", var_names[OFF_D + k], d[k]);
        if (n < 0) break;
        used += (size_t)n;
    }
    return buf;
}

/* modes.check_zeros on the current indicators (call after ensure) */
static int check_indicators(Inst *m) {
    char modes[1024];
    int i;
    for (i = 0; i < NZ; i++) {
        double z = m->z[i];
        if (isfinite(z)) continue;
        log_msg(m, fmi2Error, "logStatusError", "the zero function of an event of %s is %s at t = %.9g s: %s "
                "(modes %s); a NaN or infinite switching value has no sign to switch on (a division by a "
                "coefficient that is zero in this mode, or a function used outside its domain)",
                origin_names[event_origin[i]], isnan(z) ? "nan" : (z > 0 ? "inf" : "-inf"), m->time,
                event_zero[i], modes_text(MODES, modes, sizeof modes));
        return 1;
    }
    return 0;
}

/* evaluate if needed and check the indicators */
static int indicators(Inst *m) {
    return ensure(m) || check_indicators(m);
}

static int apply_event(Inst *m, int i, int rising) {
    if (ensure(m)) return 1;
    model_event(m, i, rising);
    m->valid = 0;
    return 0;
}

/* modes.crossings' rule between an indicator's value a at the last event and b now: 1 rising, 0 falling, -1 no
 * crossing; leaving an exact zero takes the direction of b, reaching one the direction from a */
static int crossed(double a, double b) {
    if (a == 0.0) return b != 0.0 ? b > 0 : -1;
    if ((a < 0 && b >= 0) || (a > 0 && b <= 0)) return a < 0;
    return -1;
}

static int modes_differ(const double *a, const double *b) {
    int k;
    for (k = 0; k < ND; k++) if (a[k] != b[k]) return 1;
    return 0;
}

/* modes.settle_modes: every event's assignments by the sign of its indicator until nothing changes */
static int settle_modes(Inst *m) {
    double before[ND1], zs[NZ1];
    char modes[1024];
    int it, i;
    for (it = 0; it < MAX_SETTLE; it++) {
        if (indicators(m)) return 1;
        memcpy(before, MODES, sizeof(double) * ND);
        memcpy(zs, m->z, sizeof(double) * NZ);
        for (i = 0; i < NZ; i++) {
            if (zs[i] > 0 && apply_event(m, i, 1)) return 1;
            if (zs[i] < 0 && apply_event(m, i, 0)) return 1;
        }
        if (!modes_differ(before, MODES)) return 0;
    }
    log_msg(m, fmi2Error, "logStatusError", "discrete modes do not settle at t = %.6g s: %s", m->time,
            modes_text(MODES, modes, sizeof modes));
    return 1;
}

/* At the start, an indicator exactly at zero (a diode at rest) that leaves it: simulate() sees it leave in its
 * first step and switches at the start time (modes.crossings). The FMU looks a short step h ahead along the
 * derivatives, in the present modes, for the direction: ahead[i] is the indicator there. */
static int look_ahead(Inst *m, double *ahead) {
    double x[NX1], t = m->time, h = 1e-6 * (fabs(t) > 1.0 ? fabs(t) : 1.0);
    int k, bad;
    if (ensure(m)) return 1;
    memcpy(x, m->r + OFF_X, sizeof(double) * NX);
    for (k = 0; k < NX; k++) m->r[OFF_X + k] = x[k] + h * m->r[der_vr[k]];
    m->time = t + h;
    m->valid = 0;
    bad = indicators(m);
    if (!bad) memcpy(ahead, m->z, sizeof(double) * NZ);
    memcpy(m->r + OFF_X, x, sizeof(double) * NX);  /* back to the present time and states */
    m->time = t;
    m->valid = 0;
    return bad;
}

/* modes.cascade after the hits that changed the modes from d_old; side: each indicator's sign before the event
 * (a hit exactly at zero: the side it crossed to). The modes visited are remembered: seen[0] = d_old, seen[1] the
 * modes after the hits, seen[s] the modes that step s of the iteration leaves. big[i]: the last step at which
 * event i flipped with |indicator| above KNEE; flipped[i]: whether it flipped at all. */
static int cascade(Inst *m, const double *d_old, double *side, int *kept) {
    double seen[MAX_CASCADE + 2][ND1], z[NZ1], before[ND1];
    int big[NZ1], flipped[NZ1], flips[NZ1], mark[NO1];
    int n_seen = 2, step, back = -1, i, k, n;
    char names[1024], modes[1024];
    size_t used = 0;
    memcpy(seen[0], d_old, sizeof(double) * ND);
    memcpy(seen[1], MODES, sizeof(double) * ND);
    for (i = 0; i < NZ; i++) { big[i] = -1; flipped[i] = 0; }
    for (step = 1; step <= MAX_CASCADE; step++) {
        double largest = 0.0;
        if (indicators(m)) return 1;
        memcpy(z, m->z, sizeof(double) * NZ);
        memcpy(before, MODES, sizeof(double) * ND);
        for (i = 0, n = 0; i < NZ; i++)  /* a flip: nonzero now, on the other side of a nonzero side */
            if (z[i] != 0.0 && side[i] != 0.0 && (z[i] > 0) != (side[i] > 0)) flips[n++] = i;
        if (n == 0) return 0;
        for (k = 0; k < n; k++)
            if (apply_event(m, flips[k], z[flips[k]] > 0)) return 1;
        if (!modes_differ(before, MODES)) return 0;
        for (k = 0; k < n; k++) {  /* how inconsistent the modes being left are */
            double size = fabs(z[flips[k]]);
            if (size > largest) largest = size;
            if (size > KNEE) big[flips[k]] = step;
            flipped[flips[k]] = 1;
        }
        for (k = 0; k < n_seen && back < 0; k++)
            if (!modes_differ(MODES, seen[k])) back = k;
        if (back >= 0) {
            if (largest <= KNEE) {  /* only round-off-small flips close the cycle: the present modes hold */
                memcpy(MODES, before, sizeof(double) * ND);
                m->valid = 0;
                for (k = 0; k < n; k++) kept[flips[k]] = 1;
                for (k = 0; k < n; k++)
                    log_msg(m, fmi2OK, "logEvents", "t = %.17g s: the event iteration keeps the present modes (the "
                            "flip of event %d (%s: %s) back to modes it visited is %g, within %g of zero)", m->time,
                            flips[k], origin_names[event_origin[flips[k]]], event_zero[flips[k]], z[flips[k]], KNEE);
                return 0;
            }
            break;
        }
        for (k = 0; k < n; k++)
            log_msg(m, fmi2OK, "logEvents", "t = %.17g s: the event iteration applies event %d (%s: %s) %s",
                    m->time, flips[k], origin_names[event_origin[flips[k]]], event_zero[flips[k]],
                    z[flips[k]] > 0 ? "rising" : "falling");
        memcpy(seen[n_seen++], MODES, sizeof(double) * ND);
        memcpy(side, z, sizeof(double) * NZ);
    }
    /* the components whose events close the cycle far from their knee (or, without a cycle in MAX_CASCADE steps,
     * every one that flipped), sorted and each once: origin_names is sorted */
    for (k = 0; k < NO; k++) mark[k] = 0;
    for (i = 0; i < NZ; i++)
        if (back >= 0 ? big[i] >= back : flipped[i]) mark[event_origin[i]] = 1;
    names[0] = 0;
    for (k = 0; k < NO && used < sizeof names; k++) {
        if (!mark[k]) continue;
        n = snprintf(names + used, sizeof names - used, "%s%s", used ? ", " : "", origin_names[k]);
        if (n < 0) break;
        used += (size_t)n;
    }
    log_msg(m, fmi2Error, "logStatusError", "discrete modes do not settle after an event at t = %.9g s: the events "
            "of %s switch back and forth (no mode is consistent there: the model chatters); modes %s", m->time,
            names, modes_text(back >= 0 ? before : MODES, modes, sizeof modes));
    return 1;
}

/* modes.knee_offsets: an indicator the knee rule overruled (kept), or one the event left within KNEE of zero on the
 * side that says leave the present modes, is watched at twice its value (at least ROUNDOFF further), so that
 * moving as far again the way it says to leave is a crossing; one exactly at zero, which
 * crossing one way would leave the present modes and the other not, at +-ROUNDOFF, so that leaving its zero by
 * round-off is not. */
static int knee_offsets(Inst *m, int *kept) {
    double z[NZ1], d[ND1];
    int i, up, down;
    if (indicators(m)) return 1;
    memcpy(z, m->z, sizeof(double) * NZ);
    memcpy(d, MODES, sizeof(double) * ND);
    for (i = 0; i < NZ; i++) {  /* at its knee on the leaving side without having flipped: watched as kept */
        if (kept[i] || z[i] == 0.0 || fabs(z[i]) > KNEE) continue;
        if (apply_event(m, i, z[i] > 0)) return 1;
        if (modes_differ(d, MODES)) kept[i] = 1;
        memcpy(MODES, d, sizeof(double) * ND);
        m->valid = 0;
    }
    for (i = 0; i < NZ; i++) {
        m->off[i] = 0.0;
        if (kept[i] && z[i] != 0.0) {
            double h = fabs(z[i]) > ROUNDOFF ? fabs(z[i]) : ROUNDOFF;  /* twice its value, at least ROUNDOFF on */
            m->off[i] = z[i] + (z[i] > 0 ? h : -h);
        } else if (z[i] == 0.0) {
            if (apply_event(m, i, 1)) return 1;
            up = modes_differ(d, MODES);
            memcpy(MODES, d, sizeof(double) * ND);
            if (apply_event(m, i, 0)) return 1;
            down = modes_differ(d, MODES);
            memcpy(MODES, d, sizeof(double) * ND);
            m->valid = 0;
            if (up != down) m->off[i] = up ? ROUNDOFF : -ROUNDOFF;
        }
    }
    return 0;
}

/* One event at the present time and states: the crossings since the last event (z_pre) apply their assignments
 * (modes.apply_hits); if a mode changed, each crossing is logged (as Result.events) and the cascade settles the
 * modes. At the initial event update an indicator still exactly at zero takes its direction from look_ahead. */
static int event_update(Inst *m, int initial) {
    double d_old[ND1], zs[NZ1], side[NZ1], ahead[NZ1], x_new[NX1];
    int hit[NZ1], rising[NZ1], kept[NZ1], nh = 0, at_rest = 0, i, k;
    if (indicators(m)) return 1;
    memcpy(d_old, MODES, sizeof(double) * ND);
    memcpy(side, m->z, sizeof(double) * NZ);
    for (i = 0; i < NZ; i++) { zs[i] = m->z[i] - m->off[i]; kept[i] = 0; }  /* relative to the watched thresholds */
    for (i = 0; i < NZ; i++) at_rest |= initial && m->z_pre[i] == 0.0 && zs[i] == 0.0;
    if (at_rest && look_ahead(m, ahead)) return 1;
    for (i = 0; i < NZ; i++) {
        double a = m->z_pre[i], b = zs[i];
        int r = crossed(a, at_rest && a == 0.0 && b == 0.0 ? ahead[i] : b);
        if (r >= 0) { hit[nh] = i; rising[nh] = r; nh++; }
    }
    /* modes.apply_reinits: the rising crossings' reinit values, from the values before the event (r is valid) */
    if (ensure(m)) return 1;
    memcpy(x_new, m->r + OFF_X, sizeof(double) * NX);
    for (k = 0; k < nh; k++)
        if (rising[k] && model_reinit(m, hit[k], x_new)) m->states_changed = 1;
    for (k = 0; k < nh; k++)
        if (apply_event(m, hit[k], rising[k])) return 1;
    if (m->states_changed) {  /* the states restart from there, before the modes are iterated */
        memcpy(m->r + OFF_X, x_new, sizeof(double) * NX);
        m->valid = 0;
    }
    if (nh && (modes_differ(d_old, MODES) || m->states_changed)) {
        for (k = 0; k < nh; k++) {
            log_msg(m, fmi2OK, "logEvents", "t = %.17g s: event %d (%s: %s) %s", m->time, hit[k],
                    origin_names[event_origin[hit[k]]], event_zero[hit[k]], rising[k] ? "rising" : "falling");
            if (side[hit[k]] == 0.0) side[hit[k]] = rising[k] ? 1.0 : -1.0;
        }
        m->n_events += nh;
        if (m->n_events > m->max_events) {  /* events.record_events' message */
            log_msg(m, fmi2Error, "logStatusError", "more than %d events by t = %.6g s (last from %s): the model "
                    "chatters", m->max_events, m->time, origin_names[event_origin[hit[nh - 1]]]);
            return 1;
        }
        if (cascade(m, d_old, side, kept)) return 1;
        if (knee_offsets(m, kept)) return 1;
    }
    if (indicators(m)) return 1;
    for (i = 0; i < NZ; i++) m->z_pre[i] = m->z[i] - m->off[i];
    return 0;
}
