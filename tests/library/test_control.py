"""Control blocks: a PID closing a position loop around a DC motor built from library parts (saturation and
anti-windup, sine tracking against the analytic closed-loop error, the control law checked by hand at given
states), the small blocks against closed forms, and the cascade servo on a maxon EC-4pole 30."""
import numpy as np
import pytest
import sympy as sp

from acausal import Model, ModelError, Start, compile_model, connect, time
from acausal.library.blocks import SignalSource
from acausal.library.control import (PID, Add, CascadeServo, Feedback, FirstOrder, Limiter, PIDVariableLimit,
                                     VelocityAccelerationFeedForward, cascade_gains)
from acausal.library.electrical import EMF, CurrentSensor, Ground, Inductor, Resistor, SignalVoltage
from acausal.library.rotational import AngleSensor, Damper, Fixed, Inertia, SpeedSensor
from acausal.results.result import Result

# a small DC motor (round numbers): mechanical time constant J R / k^2 = 40 ms, electrical L / R = 1 ms
R, L, K, J, D = 1.0, 1e-3, 0.05, 1e-4, 1e-4
KP, KI, KD, TD = 20.0, 300.0, 0.5, 1e-3  # V/rad, V/(rad s), V s/rad, s
STEP = sp.Piecewise((0, time < 0.01), (1, True))  # 1 rad at t = 10 ms


class PositionLoop(Model):
    """SignalSource setpoint -> PID -> SignalVoltage -> R, L, EMF -> inertia + damper -> AngleSensor -> PID."""

    def __init__(self, setpoint, phi0=0.0, **pid):
        super().__init__()
        self.setpoint, self.phi0, self.pid_kw = setpoint, phi0, pid

    def build(self):
        self.ref = SignalSource(signal=self.setpoint)
        self.pid = PID(**self.pid_kw)
        self.src = SignalVoltage()
        self.R = Resistor(R=R)
        self.L = Inductor(L=L, i=Start(0.0))
        self.emf = EMF(k=K)
        self.J = Inertia(J=J, phi=Start(self.phi0), w=Start(0.0))
        self.damper = Damper(d=D)
        self.fixed = Fixed()
        self.gnd = Ground()
        self.sensor = AngleSensor()
        connect(self.src.p, self.R.p)
        connect(self.R.n, self.L.p)
        connect(self.L.n, self.emf.p)
        connect(self.emf.n, self.src.n, self.gnd.p)
        connect(self.emf.flange, self.J.flange_a)
        connect(self.J.flange_b, self.damper.flange_b, self.sensor.flange)
        connect(self.damper.flange_a, self.fixed.flange)
        connect(self.ref.y, self.pid.setpoint)
        connect(self.sensor.phi, self.pid.measurement)
        connect(self.pid.y, self.src.u)


def error_response(w):
    """Closed-loop e/r at s = j w of the unsaturated loop (derivative on the measurement):
    e = r (1 + P Dd) / (1 + P (C + Dd)), P = k / (s ((J s + d)(L s + R) + k^2)), C = kp + ki/s,
    Dd = kd s / (Td s + 1)."""
    s = 1j * w
    P = K / (s * ((J * s + D) * (L * s + R) + K**2))
    C = KP + KI / s
    Dd = KD * s / (TD * s + 1)
    return (1 + P * Dd) / (1 + P * (C + Dd))


@pytest.fixture(scope="module")
def step_loop():
    return compile_model(PositionLoop(STEP, kp=KP, ki=KI, kd=KD, Td=TD, y_max=1.0))  # +-1 V: tight


def _overshoot(res):
    return np.max(res["J.phi"]) - 1.0


def test_step_saturates_and_anti_windup_bounds_overshoot(step_loop):
    runs = {k_aw: step_loop.simulate(1.5, params={"pid.k_aw": k_aw}, rtol=1e-8, atol=1e-10, n_points=3001)
            for k_aw in (0.0, KI / KP, 50.0)}
    for res in runs.values():
        y = res["pid.y.value"]
        assert np.all(y <= 1.0 + 1e-12) and np.all(y >= -1.0 - 1e-12)  # output within the limits
        assert np.allclose(res["src.v"], y)  # and it is what drives the motor
        assert np.mean(np.abs(y) >= 1.0 - 1e-12) > 0.03  # the limit is really active for a while
        assert res["J.phi"][-1] == pytest.approx(1.0, abs=1e-3)  # reaches the setpoint
    assert step_loop.simulate(1.5, rtol=1e-8, atol=1e-10, n_points=3)["pid.k_aw"][0] == KI / KP  # default rule
    without, default, strong = (_overshoot(runs[k]) for k in (0.0, KI / KP, 50.0))
    assert without > 0.4  # integrator wound up during the saturated travel: ~56 % overshoot
    assert default < 0.2
    assert strong < 0.1
    assert without > 3 * default
    # windup itself: without anti-windup the integral grows far beyond what the 1 V limit can use
    assert np.max(runs[0.0]["pid.I"]) > 3 * np.max(runs[50.0]["pid.I"])
    # after the proportional kick of the step has decayed (t > 50 ms), back-calculation keeps y_unsat close to
    # the limit; without it y_unsat runs ~18 V past the 1 V limit
    excess = {k: np.max(np.abs(r["pid.y_unsat"] - r["pid.y.value"])[r.t > 0.05]) for k, r in runs.items()}
    assert excess[0.0] > 10.0 and excess[50.0] < 0.1 * excess[0.0]


def test_no_derivative_kick_on_setpoint_step(step_loop):
    res = step_loop.simulate(0.02, params={"pid.k_aw": 50.0}, rtol=1e-10, atol=1e-12, n_points=2001)
    k = np.searchsorted(res.t, 0.01, side="right")  # just after the step
    assert res["pid.e"][k] == pytest.approx(1.0, abs=1e-3)
    assert abs(res["pid.D"][k]) < 1e-3  # derivative acts on the measurement, which has not moved yet
    assert res["pid.y_unsat"][k] == pytest.approx(KP, rel=1e-3)  # the proportional kick only


def test_derivative_filter_starts_at_the_measurement():
    sim = compile_model(PositionLoop(0.3, phi0=0.3, kp=KP, ki=KI, kd=KD, Td=TD, y_max=1.0))
    res = sim.simulate(0.1, rtol=1e-10, atol=1e-12, n_points=11)
    assert res["pid.x_d"][0] == pytest.approx(0.3, rel=1e-9)
    assert np.allclose(res["pid.y.value"], 0.0, atol=1e-9)  # at rest on the setpoint: nothing happens
    assert np.allclose(res["J.phi"], 0.3, atol=1e-9)


def test_sine_tracking_matches_closed_loop_analysis():
    A, f = 0.5, 0.5  # rad, Hz: peak speed 1.6 rad/s, well inside the 3 V capability (60 rad/s no-load)
    sim = compile_model(PositionLoop(A * sp.sin(2 * sp.pi * f * time), kp=KP, ki=KI, kd=KD, Td=TD, y_max=3.0))
    res = sim.simulate(6.0, rtol=1e-10, atol=1e-12, n_points=6001)
    late = res.t >= 4.0  # transients (slowest closed-loop pole ~ 0.1 s) are gone
    e = res["pid.e"]
    assert np.max(np.abs(e[late])) < 0.02 * A
    assert np.max(np.abs(res["pid.y.value"])) < 3.0  # never saturates: the linear analysis applies
    w = 2 * np.pi * f
    G = error_response(w)
    exact = A * np.abs(G) * np.sin(w * res.t + np.angle(G))
    assert np.max(np.abs(e[late] - exact[late])) < 1e-6 * A * np.abs(G)


class FeedForwardLoop(PositionLoop):
    """:class:`PositionLoop` whose PID also gets the reference's rate and acceleration, weighted with the unloaded
    motor's own inverse (``v = (k + R d / k) w + (R J / k) a``, the inductance's small terms left out) plus the
    PID's own derivative gain (its derivative acts on the measurement, so it brakes a moving reference by kd w)."""

    def build(self):
        super().build()
        self.ff = VelocityAccelerationFeedForward(k_v=K + R * D / K + KD, k_a=R * J / K)
        connect(self.ref.y, self.ff.u)
        connect(self.ff.y, self.pid.u_ff)


def test_feed_forward_makes_the_loop_follow_a_fast_sine():
    A, f = 0.5, 4.0  # rad, Hz: fast against the PID's bandwidth; the feed-forward alone nearly makes the motion
    ref = A * sp.sin(2 * sp.pi * f * time)
    gains = dict(kp=KP, ki=KI, kd=KD, Td=TD, y_max=50.0)
    plain = compile_model(PositionLoop(ref, **gains)).simulate(2.0, rtol=1e-9, atol=1e-11, n_points=2001)
    ff = compile_model(FeedForwardLoop(ref, with_feed_forward=True, **gains)).simulate(2.0, rtol=1e-9, atol=1e-11,
                                                                                       n_points=2001)
    late = plain.t >= 1.0
    e_plain, e_ff = np.max(np.abs(plain["pid.e"][late])), np.max(np.abs(ff["pid.e"][late]))
    assert e_plain > 0.05 * A  # the PID alone lags
    assert e_ff < e_plain / 20
    w = 2 * np.pi * f  # the block's output is the weighted rate and acceleration of the reference
    expected = (K + R * D / K + KD) * A * w * np.cos(w * ff.t) - (R * J / K) * A * w**2 * np.sin(w * ff.t)
    assert np.allclose(ff["ff.y.value"], expected, atol=1e-9 * np.max(np.abs(expected)))
    assert np.allclose(ff["pid.y_unsat"] - ff["pid.kp"] * ff["pid.e"] - ff["pid.I"] - ff["pid.D"],
                       ff["ff.y.value"], atol=1e-9)  # y_unsat = kp e + I + D + k_ff u_ff with k_ff = 1


def test_feed_forward_is_an_option_that_adds_a_port():
    assert not hasattr(PID(y_max=1.0), "u_ff")
    with pytest.raises(ModelError, match="with_feed_forward"):
        PID(y_max=1.0, with_feed_forward="yes")


def test_pid_law_by_hand_at_given_states(step_loop):
    """Evaluate the compiled loop at chosen states (t = 0.5 s, setpoint 1) and check the law term by term."""
    cm = step_loop
    k_aw = 50.0
    p = cm.param_vector({"pid.k_aw": k_aw})
    names = cm.state_names
    points = [  # phi, I, x_d, J.w, L.i
        dict(phi=0.99, I=0.2, x_d=0.99 - 1e-4, w=0.3, i=0.1),  # unsaturated: y_unsat = 0.2 + 0.2 - 0.05 = 0.35
        dict(phi=0.5, I=0.3, x_d=0.5, w=5.0, i=0.5),  # saturated high: y_unsat = 10.3
        dict(phi=1.2, I=-0.5, x_d=1.2 + 2e-4, w=-1.0, i=-0.2),  # saturated low: y_unsat = -4.4 + 0.1 = -4.3
    ]
    t = np.full(len(points), 0.5)
    values = {"J.w": "w", "L.i": "i", "damper.phi_rel": "phi", "pid.I": "I", "pid.x_d": "x_d"}
    assert sorted(names) == sorted(values)
    X = np.array([[pt[values[n]] for pt in points] for n in names])
    res = Result(cm, t, X, p, cm.input_tuple(), cm.time_modes(t, p, cm.discrete_start()), events=[])
    for k, pt in enumerate(points):
        e = 1.0 - pt["phi"]
        Dd = -KD * (pt["phi"] - pt["x_d"]) / TD
        y_unsat = KP * e + pt["I"] + Dd
        y = min(max(y_unsat, -1.0), 1.0)
        assert res["pid.e"][k] == pytest.approx(e, rel=1e-12)
        assert res["pid.D"][k] == pytest.approx(Dd, rel=1e-9)
        assert res["pid.y_unsat"][k] == pytest.approx(y_unsat, rel=1e-9)
        assert res["pid.y.value"][k] == pytest.approx(y, rel=1e-12)
        assert res["der(pid.I)"][k] == pytest.approx(KI * e + k_aw * (y - y_unsat), rel=1e-9)
        assert res["der(pid.x_d)"][k] == pytest.approx((pt["phi"] - pt["x_d"]) / TD, rel=1e-9)
        assert res["src.v"][k] == pytest.approx(y, rel=1e-12)
    assert [res["pid.y.value"][k] for k in (1, 2)] == [1.0, -1.0]
    assert res["pid.y_unsat"][0] == pytest.approx(0.35, rel=1e-9)


def test_pid_parameter_checks():
    with pytest.raises(ModelError, match="Td must be > 0"):
        PID(y_max=1.0, Td=0.0)
    with pytest.raises(ModelError, match="y_max"):
        compile_model(PositionLoop(STEP, kp=KP))  # a limit must be chosen
    assert PID(y_max=2.0).parameter_value("y_min") == -2.0
    assert PID(y_max=2.0, y_min=0.0).parameter_value("y_min") == 0.0
    assert PID(y_max=1.0, kp=4.0, ki=2.0).parameter_value("k_aw") == 0.5
    assert PID(y_max=1.0, kp=0.0, ki=2.0).parameter_value("k_aw") == 0.0


class Blocks(Model):
    """u = sin(2 pi t) through FirstOrder, Limiter, Feedback and Add."""

    def build(self):
        self.u = SignalSource(signal=2 * sp.sin(2 * sp.pi * time))
        self.c = SignalSource(signal=0.5)
        self.lag = FirstOrder(k=3.0, T=0.2)
        self.lim = Limiter(u_max=1.5)
        self.fb = Feedback()
        self.add = Add(k1=2.0, k2=-4.0)
        connect(self.u.y, self.lag.u, self.lim.u, self.fb.u1, self.add.u1)
        connect(self.c.y, self.fb.u2, self.add.u2)


def test_small_blocks():
    res = compile_model(Blocks()).simulate(2.0, rtol=1e-11, atol=1e-12, n_points=401)
    t = res.t
    u = 2 * np.sin(2 * np.pi * t)
    assert np.allclose(res["lim.y.value"], np.clip(u, -1.5, 1.5), atol=1e-12)
    assert np.allclose(res["fb.y.value"], u - 0.5, atol=1e-12)
    assert np.allclose(res["add.y.value"], 2 * u - 4 * 0.5, atol=1e-12)
    # FirstOrder, x(0) = 0: T x' + x = k A sin(w t)  ->  x = k A / (1 + (wT)^2) (sin - wT cos + wT e^(-t/T))
    w, T, kA = 2 * np.pi, 0.2, 3.0 * 2
    exact = kA / (1 + (w * T) ** 2) * (np.sin(w * t) - w * T * np.cos(w * t) + w * T * np.exp(-t / T))
    assert np.allclose(res["lag.y.value"], exact, rtol=0, atol=1e-8)


# ------------------------------------------------------------------------------------------- cascade servo
# maxon EC-4pole 30, 48 V winding (docs/parameters.md) with a small load of 1 g cm2
M_R, M_L, M_K, M_J, M_D = 0.386, 6.53e-5, 0.0274, 3.33e-6 + 1e-6, 5.7e-6


class ServoDrive(Model):
    """CascadeServo commanding a SignalVoltage across the motor; current, speed and angle fed back."""

    def __init__(self, target, v_limit=None, **servo):
        super().__init__()
        self.target, self.v_limit, self.servo_kw = target, v_limit, servo

    def build(self):
        self.ref = SignalSource(signal=self.target)
        self.ctrl = CascadeServo(use_voltage_limit_input=self.v_limit is not None, **self.servo_kw)
        if self.v_limit is not None:
            self.supply = SignalSource(signal=self.v_limit)
            connect(self.supply.y, self.ctrl.v_limit)
        self.src = SignalVoltage()
        self.ammeter = CurrentSensor()
        self.R = Resistor(R=M_R)
        self.L = Inductor(L=M_L, i=Start(0.0))
        self.emf = EMF(k=M_K)
        self.J = Inertia(J=M_J, phi=Start(0.0), w=Start(0.0))
        self.damper = Damper(d=M_D)
        self.fixed = Fixed()
        self.gnd = Ground()
        self.angle = AngleSensor()
        self.speed = SpeedSensor()
        connect(self.src.p, self.ammeter.p)
        connect(self.ammeter.n, self.R.p)
        connect(self.R.n, self.L.p)
        connect(self.L.n, self.emf.p)
        connect(self.emf.n, self.src.n, self.gnd.p)
        connect(self.emf.flange, self.J.flange_a)
        connect(self.J.flange_b, self.damper.flange_b, self.angle.flange, self.speed.flange)
        connect(self.damper.flange_a, self.fixed.flange)
        connect(self.ref.y, self.ctrl.position_ref)
        connect(self.angle.phi, self.ctrl.position)
        connect(self.speed.w, self.ctrl.velocity)
        connect(self.ammeter.i_out, self.ctrl.current)
        connect(self.ctrl.voltage, self.src.u)


TARGET = 20 * (1 - sp.exp(-time / 1e-3))  # 20 rad (~3.2 turns), a fast but smooth command


def test_cascade_servo_reaches_position_within_limits():
    sim = compile_model(ServoDrive(TARGET, w_max=500.0))
    res = sim.simulate(0.3, rtol=1e-8, atol=1e-10, n_points=3001)
    assert res["J.phi"][-1] == pytest.approx(20.0, abs=1e-4)
    assert np.max(res["J.phi"]) < 20.0 * 1.01  # no significant overshoot
    w_ref, i_ref, v = res["ctrl.pos.y.value"], res["ctrl.vel.y.value"], res["src.v"]
    assert np.max(np.abs(w_ref)) == pytest.approx(500.0)  # the speed limit is active ...
    assert np.max(res["J.w"]) < 1.2 * 500.0  # ... and the speed loop follows it
    assert np.max(np.abs(i_ref)) == pytest.approx(10.0)  # current limit (EPOS2 10 A) active while accelerating
    assert np.max(np.abs(res["L.i"])) <= 10.0
    assert np.max(np.abs(v)) <= 43.2 + 1e-9
    assert np.allclose(v, res["ctrl.voltage.value"])


def test_cascade_servo_with_voltage_limit_input():
    supply = 6.0 + 2.0 * sp.sin(2 * sp.pi * 20 * time)  # available voltage varying between 4 and 8 V
    sim = compile_model(ServoDrive(TARGET, v_limit=supply, w_max=500.0))
    assert "ctrl.cur.k_aw" in sim.param_names  # the limited current loop keeps its anti-windup
    res = sim.simulate(0.4, rtol=1e-8, atol=1e-10, n_points=4001)
    limit = 6.0 + 2.0 * np.sin(2 * np.pi * 20 * res.t)
    assert np.all(np.abs(res["src.v"]) <= limit + 1e-9)
    assert np.any(np.abs(res["src.v"]) >= limit - 1e-9)  # the voltage limit binds (no-load speed < 300 rad/s)
    assert np.max(res["J.w"]) < 8.0 / M_K  # slower than with the full 43.2 V
    assert res["J.phi"][-1] == pytest.approx(20.0, abs=1e-3)


def test_pid_variable_limit_block():
    class Clamped(Model):
        def build(self):
            self.r = SignalSource(signal=5 * sp.sin(2 * sp.pi * time))
            self.m = SignalSource(signal=0.0)
            self.lim = SignalSource(signal=1.0 + 0.5 * time)
            self.pid = PIDVariableLimit(kp=2.0)
            connect(self.r.y, self.pid.setpoint)
            connect(self.m.y, self.pid.measurement)
            connect(self.lim.y, self.pid.limit)

    res = compile_model(Clamped()).simulate(1.0, rtol=1e-10, atol=1e-12, n_points=101)
    lim = 1.0 + 0.5 * res.t
    assert np.allclose(res["pid.y.value"], np.clip(10 * np.sin(2 * np.pi * res.t), -lim, lim), atol=1e-9)


# ------------------------------------------------------------------------------------ ServoDriver, cascade_gains
def test_cascade_gains_reproduce_the_documented_loop_shaping():
    g = cascade_gains(M_R, M_L, M_K, 3.33e-6)
    wc = 2 * np.pi * 1000.0
    assert g["kp_cur"] == pytest.approx(M_L * wc) and g["ki_cur"] == pytest.approx(M_R * wc)
    assert g["kp_vel"] == pytest.approx(3.33e-6 * wc / 10 / M_K)
    assert g["ki_vel"] == pytest.approx(g["kp_vel"] * wc / 40) and g["kp_pos"] == pytest.approx(wc / 100)
    for name in ("kp_pos", "kp_vel", "ki_vel", "i_max", "kp_cur", "ki_cur"):  # the library defaults are these
        assert name == "i_max" or getattr(CascadeServo, name).default == pytest.approx(g[name], rel=2e-3)
    with pytest.raises(ModelError, match="cascade_gains: J must be a number > 0"):
        cascade_gains(M_R, M_L, M_K, 0.0)


class _Amplified(Model):
    """ServoDriver on a 24 V supply with internal resistance, driving the motor with a small load."""

    def __init__(self, target, **drive):
        super().__init__()
        self.target, self.drive_kw = target, drive

    def build(self):
        from acausal.library.drives import ServoDriver
        from acausal.library.electrical import Supply
        self.supply, self.gnd = Supply(V=24.0, R_int=0.2), Ground()
        self.drive = ServoDriver(**self.drive_kw)
        self.R, self.L, self.emf = Resistor(R=M_R), Inductor(L=M_L, i=Start(0.0)), EMF(k=M_K)
        self.J, self.damper, self.fixed = Inertia(J=M_J, phi=Start(0.0), w=Start(0.0)), Damper(d=M_D), Fixed()
        self.angle, self.speed, self.ref = AngleSensor(), SpeedSensor(), SignalSource(signal=self.target)
        connect(self.supply.p, self.drive.bus_p); connect(self.supply.n, self.drive.bus_n, self.gnd.p)
        connect(self.drive.mot_p, self.R.p); connect(self.R.n, self.L.p); connect(self.L.n, self.emf.p)
        connect(self.emf.n, self.drive.mot_n)
        connect(self.emf.flange, self.J.flange_a)
        connect(self.J.flange_b, self.damper.flange_b, self.angle.flange, self.speed.flange)
        connect(self.damper.flange_a, self.fixed.flange)
        connect(self.ref.y, self.drive.position_ref); connect(self.angle.phi, self.drive.position)
        connect(self.speed.w, self.drive.velocity)


def test_servo_driver_limits_current_and_voltage_to_its_bus():
    gains = cascade_gains(M_R, M_L, M_K, M_J)
    sim = compile_model(_Amplified(TARGET, **gains, i_max=2.0, w_max=600.0, d_max=0.95))
    res = sim.simulate(0.4, rtol=1e-8, atol=1e-10, n_points=4001)
    assert res["J.phi"][-1] == pytest.approx(20.0, abs=1e-3)
    i, i_ref = res["drive.ammeter.i"], res["drive.ctrl.vel.y.value"]
    assert np.max(np.abs(i_ref)) == pytest.approx(2.0)  # the current limit is reached ...
    assert np.max(np.abs(i)) < 2.0 * 1.02  # ... and holds (up to the current loop's overshoot)
    assert np.allclose(i, res["L.i"])  # the ammeter sits in the motor circuit
    v_avail = 0.95 * res["drive.bridge.v_bus"]
    assert np.all(np.abs(res["drive.bridge.u.value"]) <= v_avail + 1e-9)  # the bus limits the command
    v_bus = res["drive.bridge.v_bus"]
    assert v_bus.min() < 23.9 and v_bus.max() > 24.1  # sags while driving, rises while braking into the supply
    b = res.energy_balance()
    assert abs(b.residual) < 1e-6 and b.losses["drive.bridge.loss_power"] == 0.0  # a neutral bridge is lossless
    assert sim.device_defaults() == {}  # the cascade inside takes the driver's values, none of the EPOS2's


def test_servo_driver_needs_its_gains_and_limits():
    with pytest.raises(ModelError, match="ServoDriver 'drive': parameter 'i_max' has no value"):
        compile_model(_Amplified(TARGET, **cascade_gains(M_R, M_L, M_K, M_J), w_max=600.0))
