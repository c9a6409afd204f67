"""Tests of acausal.library.gait: the packaged Winter (1991) natural-cadence ankle data and its smooth signals.

Reference numbers are those of the gait data set's README (reproduced from the packaged data by a data check):
peak plantarflexor moment 1.628 N m/kg at 48 %; ankle angle +9.62 deg dorsiflexion at 44 % and -19.77 deg
plantarflexion at 66 % (dorsiflexion positive; in this library's plantarflexion-positive convention: minimum -9.62 deg,
maximum +19.77 deg); work per stride +0.345 / -0.124 / net +0.221 J/kg from a periodic central difference.
"""
import importlib.resources
import math

import numpy as np
import pytest

from acausal.errors import AcausalError, DataError, ModelError
from acausal.library.gait import (DEFAULT_PATH, GaitCycle, GaitParameterError, GaitWork, load_gait_table)
from acausal.model.signals import Signal

DEG = math.pi / 180


@pytest.fixture(scope="module")
def table():
    return load_gait_table()


@pytest.fixture(scope="module")
def cycle():
    return GaitCycle()


def fine_grid(cycle, n=200_001):
    return np.linspace(0.0, cycle.stride_time, n)


# -- packaged file --------------------------------------------------------------------------------------------------
def test_packaged_file_is_package_data():
    res = importlib.resources.files("acausal.library").joinpath("data/ankle_gait_winter.csv")
    assert res.is_file()
    assert DEFAULT_PATH.is_file()
    text = DEFAULT_PATH.read_text(encoding="utf-8")
    comments = [line for line in text.splitlines() if line.startswith("#")]
    body = [line for line in text.splitlines() if line and not line.startswith("#")]
    joined = "\n".join(comments)
    for needle in ("Winter", "1991", "NATURAL", "1.1396", "mechmotum/gait-closed-loop-id", "NickKok/libnmm",
                   "46 %: 1.688 -> 1.608", "74 %", "94 %", "PLANTARFLEXION POSITIVE", "100 %", "DROPPED", "[rad]"):
        assert needle in joined, needle
    assert body[0] == "gait_fraction,ankle_angle_rad,ankle_moment_Nm_per_kg"  # no power column
    assert len(body) == 51  # header + 50 samples


def test_table_contents(table):
    assert table.fraction.size == table.angle.size == table.moment_per_kg.size == 50
    np.testing.assert_allclose(table.fraction, np.arange(50) * 0.02, atol=1e-15)
    # plantarflexion positive: the source's +9.62 deg dorsiflexion at 44 % is -9.62 deg here, -19.77 at 66 % is +19.77
    i, j = np.argmin(table.angle), np.argmax(table.angle)
    assert table.angle[i] / DEG == pytest.approx(-9.62, abs=1e-9) and table.fraction[i] == pytest.approx(0.44)
    assert table.angle[j] / DEG == pytest.approx(19.77, abs=1e-9) and table.fraction[j] == pytest.approx(0.66)
    # the corrected samples (second transcription)
    for frac, value in ((0.46, 1.608), (0.74, -0.010), (0.94, 0.007)):
        assert table.moment_per_kg[round(frac / 0.02)] == value


def test_peak_moment(table, cycle):
    assert table.peak_moment() == (1.628, 0.48)
    assert cycle.peak_moment() == (1.628, 0.48)
    # the smooth torque peaks close to the tabulated peak (between samples: within one sample spacing)
    t = fine_grid(cycle)
    tq = cycle.torque(t) / cycle.body_mass
    assert tq.max() == pytest.approx(1.628, abs=0.01)
    assert abs(t[np.argmax(tq)] / cycle.stride_time - 0.48) < 0.02


def test_angle_extremes_value_and_timing(cycle):
    """Smoothed extremes: within 0.25 deg (< 1 % of the 29.4 deg range) and half a sample spacing (1 % stride)."""
    t = fine_grid(cycle)
    th = cycle.angle(t) / DEG
    i, j = np.argmin(th), np.argmax(th)
    assert th[i] == pytest.approx(-9.62, abs=0.25)   # max dorsiflexion +9.62 deg in the source's convention
    assert abs(t[i] / cycle.stride_time - 0.44) <= 0.01
    assert th[j] == pytest.approx(19.77, abs=0.25)   # max plantarflexion -19.77 deg in the source's convention
    assert abs(t[j] / cycle.stride_time - 0.66) <= 0.01
    assert cycle.angle(0.44 * cycle.stride_time) / DEG == pytest.approx(-9.62, abs=1e-9)  # interpolating
    assert cycle.angle(0.66 * cycle.stride_time) / DEG == pytest.approx(19.77, abs=1e-9)


# -- power and work -------------------------------------------------------------------------------------------------
def central_difference_power(table, stride_time):
    """The source's derived power: P = M * (-d theta_dorsi/dt) = M * d theta_plantar/dt, periodic central difference."""
    h = (table.fraction[1] - table.fraction[0]) * stride_time
    dth = (np.roll(table.angle, -1) - np.roll(table.angle, 1)) / (2 * h)
    return table.moment_per_kg * dth, h


def test_central_difference_reproduces_source_power_column(table):
    # a few values of the source's ankle_power_W_per_kg column (derived there with P = M * (-d theta_dorsi/dt))
    p, h = central_difference_power(table, 1.1396)
    for frac, value in ((0.16, -0.506), (0.46, 0.566), (0.52, 3.215), (0.54, 3.241), (0.58, 1.263)):
        assert p[round(frac / 0.02)] == pytest.approx(value, abs=1.5e-3)
    assert p[p > 0].sum() * h == pytest.approx(0.345, abs=1e-3)
    assert p[p < 0].sum() * h == pytest.approx(-0.124, abs=1e-3)
    assert p.sum() * h == pytest.approx(0.221, abs=1e-3)


def test_power_sign_convention(table, cycle):
    """torque * dtheta/dt with both plantarflexion positive is the source's generation-positive power."""
    p_cd, _ = central_difference_power(table, cycle.stride_time)
    p = cycle.power(table.fraction * cycle.stride_time) / cycle.body_mass
    assert np.corrcoef(p, p_cd)[0, 1] > 0.99
    assert cycle.power(0.53 * cycle.stride_time) > 0        # push-off: generation
    assert cycle.power(0.16 * cycle.stride_time) < 0        # controlled dorsiflexion: absorption
    t = fine_grid(cycle)
    pk = cycle.power(t) / cycle.body_mass
    assert 0.52 <= t[np.argmax(pk)] / cycle.stride_time <= 0.54
    assert pk.max() == pytest.approx(3.24, rel=0.06)         # the central difference flattens the sharp peak


def test_work_per_stride(cycle):
    """Spline work vs the README's central-difference numbers, tolerance 3 %.

    The reference numbers come from a 2 %-step central difference, whose error on the steep push-off (angle changes
    by up to 5 deg per sample) is O(h^2 theta''') and which also places the power's sign changes only to the sample
    grid; the spline integral is exact for the spline. Measured differences: positive 0.05 %, net 0.9 %, negative
    1.5 % (small absorbed work, most sensitive to where the zero crossings fall); 3 % leaves room without hiding a
    wrong sign or a wrong factor.
    """
    w = cycle.work_per_stride()
    assert isinstance(w, GaitWork)
    m = cycle.body_mass
    assert w.positive / m == pytest.approx(0.345, rel=0.03)
    assert w.negative / m == pytest.approx(-0.124, rel=0.03)
    assert w.net / m == pytest.approx(0.221, rel=0.03)
    assert w.net == pytest.approx(w.positive + w.negative, rel=1e-12)
    # independent check: the net work is the closed integral of torque dtheta; fine periodic trapezoid of the power
    t = np.linspace(0.0, cycle.stride_time, 400_001)[:-1]
    assert np.sum(cycle.power(t)) * (t[1] - t[0]) == pytest.approx(w.net, rel=1e-8)
    p = cycle.power(t)
    assert np.sum(np.clip(p, 0, None)) * (t[1] - t[0]) == pytest.approx(w.positive, rel=1e-6)


def test_work_scales_with_mass_not_with_stride_time(cycle):
    w = cycle.work_per_stride()
    for stride_time in (1.2, 2.0, 3.0):
        ws = cycle.scaled(stride_time=stride_time).work_per_stride()
        np.testing.assert_allclose(ws, w, rtol=1e-9)
    heavy = cycle.scaled(body_mass=80.0)
    assert heavy.stride_time == cycle.stride_time and heavy.body_mass == 80.0
    np.testing.assert_allclose(heavy.work_per_stride(), np.asarray(w) * 80.0 / cycle.body_mass, rtol=1e-9)
    # the profiles are stretched in time: same angle and torque at the same gait fraction
    slow = cycle.scaled(stride_time=3.0)
    f = np.linspace(0, 1, 37)
    np.testing.assert_allclose(slow.angle(f * 3.0), cycle.angle(f * cycle.stride_time), atol=1e-12)
    np.testing.assert_allclose(slow.torque(f * 3.0), cycle.torque(f * cycle.stride_time), atol=1e-10)
    # peak joint torque about 98 N m at 60 kg (parameters.md)
    assert cycle.torque(fine_grid(cycle)).max() == pytest.approx(97.8, abs=1.0)


# -- signals --------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("smoothing", ["spline", "fourier"])
def test_signals_are_named_signals(smoothing):
    c = GaitCycle(smoothing=smoothing)
    a, tq = c.angle_signal(), c.torque_signal()
    assert isinstance(a, Signal) and isinstance(tq, Signal)
    assert a.name == "gait ankle angle" and tq.name == "gait ankle torque"
    assert a.max_order is None or a.max_order >= 3
    assert isinstance(c.angle(0.1), float) and c.angle(np.zeros(3)).shape == (3,)
    assert c.torque(0.5) == pytest.approx(float(tq(0.5)))


@pytest.mark.parametrize("smoothing", ["spline", "fourier"])
@pytest.mark.parametrize("which", ["angle_signal", "torque_signal"])
def test_derivatives_match_finite_differences(smoothing, which):
    c = GaitCycle(smoothing=smoothing)
    sig = getattr(c, which)()
    t = np.linspace(0.013, c.stride_time - 0.013, 997)
    h = 1e-5  # central difference error O(h^2): measured ~1e-7 relative, rounding ~1e-10
    for k in (1, 2, 3):
        fd = (sig(t + h, k - 1) - sig(t - h, k - 1)) / (2 * h)
        exact = sig(t, k)
        assert np.abs(fd - exact).max() <= 1e-6 * np.abs(exact).max(), k


@pytest.mark.parametrize("smoothing", ["spline", "fourier"])
@pytest.mark.parametrize("which", ["angle_signal", "torque_signal"])
def test_periodic_and_continuous_across_stride_boundary(smoothing, which):
    c = GaitCycle(smoothing=smoothing)
    sig, T = getattr(c, which)(), c.stride_time
    grid = np.linspace(0, T, 2001)
    for k in range(4):
        scale = np.abs(sig(grid, k)).max()
        for boundary in (0.0, T, 2 * T):
            jump = abs(sig(boundary + 1e-9, k) - sig(boundary - 1e-9, k))
            assert jump <= 1e-6 * scale, (k, boundary)  # a kink or jump would be O(scale)
        np.testing.assert_allclose(sig(grid + 3 * T, k), sig(grid, k), atol=1e-12 * scale)


def test_fourier_agrees_with_spline(cycle):
    f = GaitCycle(smoothing="fourier", harmonics=12)
    t = fine_grid(cycle, 20_001)
    for name in ("angle", "torque"):
        s_val, f_val = getattr(cycle, name)(t), getattr(f, name)(t)
        assert np.abs(s_val - f_val).max() <= 0.02 * np.ptp(s_val), name
    np.testing.assert_allclose(f.work_per_stride(), cycle.work_per_stride(), rtol=0.02)
    assert "fourier" in repr(f) and f.scaled(body_mass=70).smoothing == "fourier"


# -- validation -----------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs,name", [({"stride_time": 0.0}, "stride_time"), ({"stride_time": -1.0}, "stride_time"),
                                         ({"stride_time": float("nan")}, "stride_time"),
                                         ({"body_mass": 0}, "body_mass"), ({"body_mass": "heavy"}, "body_mass"),
                                         ({"smoothing": "cubic"}, "smoothing"), ({"smoothing": "fourier",
                                                                                 "harmonics": 0}, "harmonics"),
                                         ({"smoothing": "fourier", "harmonics": 25}, "harmonics")])
def test_bad_parameters(table, kwargs, name):
    with pytest.raises(ModelError, match=name) as info:
        GaitCycle(table, **kwargs)
    assert isinstance(info.value, ValueError) and isinstance(info.value, GaitParameterError)
    if set(kwargs) <= {"stride_time", "body_mass"}:
        with pytest.raises(ValueError, match=name):
            GaitCycle(table).scaled(**kwargs)


GOOD_HEADER = "gait_fraction,ankle_angle_rad,ankle_moment_Nm_per_kg"


def write_table(tmp_path, rows, header=GOOD_HEADER, name="bad.csv"):
    path = tmp_path / name
    path.write_text("# comment\n# another comment\n" + header + "\n" + "\n".join(rows) + "\n", encoding="utf-8")
    return path


def good_rows(n=10):
    return [f"{i / n:.3f},{0.1 * math.sin(2 * math.pi * i / n):.6f},{math.cos(2 * math.pi * i / n):.6f}"
            for i in range(n)]


def test_loader_reads_a_written_table_in_any_column_order(tmp_path):
    rows = [",".join(reversed(r.split(","))) + ",extra" for r in good_rows()]
    path = write_table(tmp_path, rows, header="ankle_moment_Nm_per_kg,ankle_angle_rad,gait_fraction,note")
    tab = load_gait_table(path)
    np.testing.assert_allclose(tab.fraction, np.arange(10) / 10)
    assert tab.source == str(path)
    c = GaitCycle(tab, stride_time=2.0, body_mass=1.0)
    assert c.torque(0.0) == pytest.approx(1.0)


@pytest.mark.parametrize("mutate,line,column,what", [
    (lambda r: r.__setitem__(3, "0.300,abc,0.5"), 7, "ankle_angle_rad", "not a number"),
    (lambda r: r.__setitem__(4, "0.400,0.1,nan"), 8, "ankle_moment_Nm_per_kg", "non-finite"),
    (lambda r: r.__setitem__(2, "0.200,inf,0.5"), 6, "ankle_angle_rad", "non-finite"),
    (lambda r: r.__setitem__(5, "0.400,0.1,0.5"), 9, "gait_fraction", "does not increase"),
    (lambda r: r.__setitem__(6, "0.600,0.1"), 10, "ankle_moment_Nm_per_kg", "missing"),
    (lambda r: r.append("1.000,0.0,1.0"), 14, "gait_fraction", ">= 1"),
])
def test_loader_errors_name_file_row_and_column(tmp_path, mutate, line, column, what):
    rows = good_rows()
    mutate(rows)
    path = write_table(tmp_path, rows)
    with pytest.raises(DataError) as info:
        load_gait_table(path)
    msg = str(info.value)
    assert str(path) in msg and f"line {line}" in msg and "data row" in msg and repr(column) in msg and what in msg


def test_loader_missing_column(tmp_path):
    path = write_table(tmp_path, [r.rsplit(",", 1)[0] for r in good_rows()], header="gait_fraction,ankle_angle_rad")
    with pytest.raises(DataError, match="missing column 'ankle_moment_Nm_per_kg'") as info:
        load_gait_table(path)
    assert str(path) in str(info.value) and "line 3" in str(info.value)


def test_loader_other_file_errors(tmp_path):
    with pytest.raises(DataError, match="cannot read"):
        load_gait_table(tmp_path / "nope.csv")
    empty = tmp_path / "empty.csv"
    empty.write_text("# only comments\n", encoding="utf-8")
    with pytest.raises(DataError, match="no header"):
        load_gait_table(empty)
    with pytest.raises(DataError, match="at least"):
        load_gait_table(write_table(tmp_path, good_rows()[:3]))
    assert issubclass(DataError, AcausalError)
