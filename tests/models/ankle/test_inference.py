"""Inference of the paper's unpublished parameters (models/ankle/inference.py): it recovers known parameters from
numbers the model itself computed, says which unknowns the numbers cannot identify, and the shipped ``paper_fit``
record stays inside the documented ranges and applies to every registered model."""
import json

import numpy as np
import pytest

from acausal import ModelError
from acausal.models.ankle import fit_record, inference, presets
from acausal.models.ankle.protocol import compiled
from acausal.models.ankle.registry import MODELS

TRUTH = {"body_mass": 66.0, "link.r_f": 2.0e-3, "planetary.tau_c": 0.5}


@pytest.mark.slow
def test_recovers_known_parameters_from_the_models_own_numbers():
    unknowns = [u for u in inference.UNKNOWNS if u.name in TRUTH]
    targets = [t for t in inference.TARGETS if t.claim == "C1"]  # Table 1: one condition
    problem = inference.Problem(unknowns, targets, executor="serial")
    made = problem.simulated(problem.simulate(TRUTH))
    fit = inference.fit(unknowns, targets, executor="serial", targets_paper=made, max_nfev=30)
    for u in unknowns:
        assert fit.values[u.name] == pytest.approx(TRUTH[u.name], abs=0.02 * (u.hi - u.lo)), u.name
        assert fit.identified[u.name], u.name
    assert fit.cost < 1e-3
    assert {r["target"] for r in fit.target_rows()} == {t.id for t in targets}


def test_a_one_sided_target_has_no_residual_once_met():
    worst = next(t for t in inference.TARGETS if t.id == "C7.worst")  # "over 50 %"
    assert worst.bound == "lower" and worst.z(0.60) == 0.0 and worst.z(0.50) == 0.0
    assert worst.z(0.46) == pytest.approx((0.46 - 0.50) / worst.sigma)
    mean = next(t for t in inference.TARGETS if t.id == "C7.mean")  # "around 20 %": two-sided
    assert mean.z(0.25) > 0 > mean.z(0.15)


def test_an_unknown_the_numbers_cannot_separate_is_not_identified():
    problem = inference.Problem(inference.UNKNOWNS[:3], inference.TARGETS[:5])
    column = np.array([1.0, 2.0, 0.5, 0.0, 1.0])
    jac = np.column_stack([column, column, [0.0, 0.0, 0.0, 30.0, 10.0]])  # the first two act alike
    sd, identified, sv = inference._uncertainty(problem, jac, np.array([0.5, 0.5, 0.5]))
    assert not identified["body_mass"] and not identified["link.r_f"] and identified["planetary.tau_c"]
    assert min(sv) < 1e-9 * max(sv)
    _, on_bound, _ = inference._uncertainty(problem, np.eye(5)[:, :3] * 100, np.array([0.0, 0.5, 1.0]))
    assert on_bound == {"body_mass": False, "link.r_f": True, "planetary.tau_c": False}


def test_an_unknown_held_on_its_bound_does_not_blur_the_others():
    """The fit's active constraint: an unknown on its bound is held there, so an unknown the targets pin is
    identified even when the held one acts almost alike (it could not be told apart only were the held one free)."""
    problem = inference.Problem(inference.UNKNOWNS[:3], inference.TARGETS[:5])
    pinned = np.array([1.0, 2.0, 0.5, 0.0, 1.0]) * 20
    jac = np.column_stack([pinned, pinned * 1.0001, [0.0, 0.0, 0.0, 30.0, 10.0]])
    sd_free, identified_free, _ = inference._uncertainty(problem, jac, np.array([0.5, 0.5, 0.5]))
    assert not identified_free["body_mass"]  # both free: the first two trade against each other
    sd, identified, _ = inference._uncertainty(problem, jac, np.array([0.5, 0.0, 0.5]))
    assert identified["body_mass"] and not identified["link.r_f"] and identified["planetary.tau_c"]
    assert sd["body_mass"] < 0.01 * sd_free["body_mass"]
    assert sd["link.r_f"] == sd_free["link.r_f"]  # the held one's: as if it were free


def test_shipped_record_lies_in_the_ranges_and_names_what_it_fitted():
    record = presets.paper_fit_record()
    for u in record["unknowns"]:
        assert u["lo"] <= u["value"] <= u["hi"], u["parameter"]
        assert record["preset"][u["parameter"]] == u["value"]
    assert {u.name for u in inference.UNKNOWNS} <= set(record["preset"])
    assert fit_record.fitted_claims(record) == {"C1", "C2", "C3", "C7", "C8", "C10"}
    assert presets.preset("paper_fit")["link.r_f"] == record["preset"]["link.r_f"] > 0
    assert presets.preset("library")["link.r_f"] == 0.0
    assert "paper_fit" in fit_record.markdown(record) or "body_mass" in fit_record.markdown(record)


def test_every_preset_key_is_a_parameter_of_the_paper_actuator():
    replay, bench = compiled("replay").sim, compiled("closed_loop").sim  # the controller's only on the bench
    for name in [*presets.PRESETS, *presets.FITTED]:
        for key in presets.preset(name):
            assert replay.has_parameter(key) or (key.startswith("controller.") and bench.has_parameter(key)), \
                (name, key)
    assert all(m.options.get("linkage") == "frictional" for m in MODELS.values()
               if m.model.endswith("AnkleActuator") or m.model.endswith("SelfLockingMaccepa"))


def test_a_broken_record_is_named(tmp_path):
    path = tmp_path / "paper_fit.json"
    with pytest.raises(ModelError, match="not found"):
        presets.paper_fit_record(path)
    path.write_text("{not json")
    with pytest.raises(ModelError, match="paper_fit.json is not an inference record"):
        presets.paper_fit_record(path)
    path.write_text(json.dumps({"preset": {"body_mass": "heavy"}}))
    with pytest.raises(ModelError, match="body_mass"):
        presets.paper_fit_record(path)


def test_the_record_ships_with_the_package():
    import tomllib
    from pathlib import Path
    cfg = tomllib.loads((Path(__file__).parents[3] / "pyproject.toml").read_text())
    data = cfg["tool"]["setuptools"]["package-data"]
    assert presets.PAPER_FIT_RECORD.name in data["acausal.models.ankle"]


def test_the_infer_verb_is_wired(capsys, tmp_path):
    from acausal.cli import main
    with pytest.raises(SystemExit) as e:
        main(["infer", "--help"])
    assert e.value.code == 0 and "--install" in capsys.readouterr().out
    # a record to start from that is not there is named before any run
    assert main(["infer", "--out", str(tmp_path / "o"), "--start-from", str(tmp_path / "earlier.json")]) == 2
    said = capsys.readouterr().err
    assert "--start-from" in said and "earlier.json" in said and "no such file" in said


def test_the_reports_words_on_the_inference_are_written_from_its_record():
    """What the report says the inference fitted (the claims it fitted, the driver's and the motor's values and
    where they ended) follows ``paper_fit.json``, so it cannot go stale when the record changes."""
    import copy
    from acausal.models.ankle import paper
    from acausal.models.ankle.fit_record import fitted_claims
    from acausal.models.ankle.presets import paper_fit_record
    record = paper_fit_record()
    import re
    assert re.findall(r"\bC\d+\b", paper.inferred_from(record)) == sorted(fitted_claims(record),
                                                                      key=lambda c: int(c[1:]))
    said = paper.assumptions(record)
    fitted = {u["parameter"]: u for u in record["unknowns"]}
    for name in ("driver.P_q", "driver.R_on", "driver.k_sw"):
        assert (name in said["driver"]) == (name in fitted)
    assert ("inertia is inferred" in said["motor"]) == ("motor.J" in fitted)
    other = copy.deepcopy(record)  # the inference without the motor's inertia, the bridge resistance identified
    other["unknowns"] = [u for u in other["unknowns"] if u["parameter"] != "motor.J"]
    for u in other["unknowns"]:
        u["identified"] = u["identified"] or u["parameter"] == "driver.R_on"
    again = paper.assumptions(other)
    assert "inertia" in again["motor"].split(" are datasheet values")[0] and "J = 3.33e-6 kg m2" in again["motor"]
    assert "identified: driver.R_on" in again["driver"]


def test_a_claim_left_out_of_the_fit_takes_its_targets_only():
    kept = inference.targets_without(("C3",))
    assert {t.claim for t in kept} == {t.claim for t in inference.TARGETS} - {"C3"}
    assert [t for t in inference.TARGETS if t.claim != "C3"] == list(kept)
    assert inference.targets_without() == inference.TARGETS
    for claim in ("C8", "C6", "C99"):  # C8 is the planner's tolerance; C6 is no target
        with pytest.raises(ModelError, match=rf"{claim} is no target of the fit; its targets are those of C1, C2"):
            inference.targets_without((claim,))


def test_infer_refuses_an_unknown_claim_before_any_run(tmp_path, capsys):
    from acausal.cli import main
    assert main(["infer", "--out", str(tmp_path), "--without", "C6", "--jobs", "1"]) == 2
    assert "C6 is no target of the fit" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())
