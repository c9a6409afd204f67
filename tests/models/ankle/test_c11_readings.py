"""C11 under the readings the paper leaves open (models/ankle/paper.py: c11_readings): each reading's optimum is
taken among the designs the motor can follow, its gain against its own reference design, and C11 counts as
reproduced only where the optimum is softer than that reference and at least C11's gain above it."""
import math

import numpy as np

from acausal.models.ankle import paper
from acausal.models.ankle.claims import C11_GAIN
from acausal.models.bench.design import DesignMap


def _map(eff, duty=None):
    ks, Ps = np.array([60e3, 130e3, 200e3]), np.array([0.004, 0.007, 0.010])
    K, P = np.meshgrid(ks, Ps, indexing="ij")
    e = np.vectorize(eff)(K, P)
    d = np.full(K.shape, 0.5) if duty is None else np.vectorize(duty)(K, P)
    return DesignMap(1.2, ks, Ps, {"efficiency": e, "max_duty": d})


def test_a_softer_optimum_with_the_gain_reproduces_c11():
    row = paper.c11_row(_map(lambda k, P: 0.15 + (0.10 if (k, P) == (60e3, 0.007) else 0.0)), "efficiency", "r")
    assert (row["optimum_kNpm"], row["optimum_P_mm"]) == (60.0, 7.0) and row["as_c11"]
    assert math.isclose(row["gain_points"], 10.0) and row["on_grid_edge"] == "k"


def test_a_small_gain_or_a_stiffer_optimum_does_not():
    small = paper.c11_row(_map(lambda k, P: 0.15 + (0.5 * C11_GAIN if k == 60e3 else 0.0)), "efficiency", "r")
    assert small["lower_stiffness"] and not small["as_c11"]
    stiff = paper.c11_row(_map(lambda k, P: 0.15 + (0.10 if k == 200e3 else 0.0)), "efficiency", "r")
    assert not stiff["lower_stiffness"] and not stiff["as_c11"]


def test_the_optimum_is_among_the_designs_the_motor_can_follow_and_the_reference_is_the_rows_own():
    m = _map(lambda k, P: 0.15 + (0.2 if k == 60e3 else 0.1 if k == 130e3 and P == 0.004 else 0.0),
             duty=lambda k, P: 1.5 if k == 60e3 else 0.5)
    row = paper.c11_row(m, "efficiency", "r", reference=(200e3, 0.010))
    assert (row["optimum_kNpm"], row["optimum_P_mm"]) == (130.0, 4.0)
    assert row["as_c11"] and (row["reference_kNpm"], row["reference_P_mm"]) == (200.0, 10.0)


def test_the_regenerated_energy_is_part_of_the_chains_losses():
    """What the rectifier burns (a regenerating supply's saving) is energy the chain lost: between 0 and E_source -
    E_output in every feasible design; NaN where the linkage cannot serve the gait."""
    from acausal.models.bench import design
    ks, Ps = np.array([60e3, 130e3, 1e3]), np.array([0.004, 0.007, 0.001])
    e = design.evaluate_designs(ks, Ps, 1.2)
    burnt = e["E_rectifier_J"]
    assert np.isnan(burnt[2]) and not e["feasible"][2]
    lost = e["E_source_J"][:2] - e["E_output_J"][:2]
    assert np.all(burnt[:2] > 0) and np.all(burnt[:2] < lost), (burnt, lost)


def test_the_verdict_and_gain_are_the_refined_optimums_and_the_grids_is_kept_beside_it():
    m = _map(lambda k, P: 0.15 + (0.05 if (k, P) == (60e3, 0.007) else 0.0))
    grid_only = paper.c11_row(m, "efficiency", "r")
    refined = paper.c11_row(m, "efficiency", "r", refined=(55e3, 0.0065, 0.15 + 0.10))
    assert math.isclose(grid_only["gain_points"], 5.0) and grid_only["as_c11"] == (0.05 >= C11_GAIN)
    assert (refined["grid_optimum_kNpm"], refined["grid_optimum_P_mm"]) == (60.0, 7.0)
    assert math.isclose(refined["grid_efficiency"], 0.20) and math.isclose(refined["efficiency"], 0.25)
    assert (refined["optimum_kNpm"], refined["optimum_P_mm"]) == (55.0, 6.5)
    assert math.isclose(refined["gain_points"], 10.0) and refined["as_c11"]


def test_refine_optimises_a_reading_derived_from_the_energies():
    """The regenerating reading is no column of evaluate_designs: refine computes it from the energies at every
    step, starts from its own grid optimum and ends no worse, within the grid's neighbourhood."""
    from acausal.models.bench import design
    ks, Ps = np.array([100e3, 150e3, 200e3]), np.array([0.003, 0.005, 0.007])
    K, P = np.meshgrid(ks, Ps, indexing="ij")
    e = design.evaluate_designs(K.ravel(), P.ravel(), 1.2)
    values = {k: np.asarray(v).reshape(K.shape) for k, v in e.items() if np.ndim(v) == 1 and len(v) == K.size}
    label, value = paper.C11_EFFICIENCIES["regenerating"]
    values["regenerating"] = value(values)
    m = DesignMap(1.2, ks, Ps, values)
    k0, P0, best = m.optimum("regenerating")
    k, P, refined = design.refine(m, key="regenerating", value=value)
    assert refined >= best and abs(k - k0) <= 50e3 and abs(P - P0) <= 0.002, (k0, P0, best, k, P, refined)
    again = design.evaluate_designs(np.array([k]), np.array([P]), 1.2)
    assert math.isclose(value(again)[0], refined, rel_tol=1e-9)
    assert refined != m.optimum("efficiency")[2]
