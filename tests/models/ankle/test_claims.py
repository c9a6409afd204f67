"""The claims table (models/ankle/claims.py): each check is computed from the run's CSV files, so the same
check gives yes on numbers that satisfy the paper's statement and no on numbers that do not. What the paper
measured is read from the bench model's rows, where the motor can follow from the replay's required duty."""
from acausal.models.ankle.claims import CLAIMS, evaluate
from acausal.models.ankle.published import PAPER
from acausal.models.reporting.tables import write_csv

POINTS = ("source", "driver", "motor", "link", "output")


def _row(P, T, energy, model="closed_loop", **kw):
    r = {"model": model, "preset": "library", "P_mm": P, "stride_time_s": T}
    r.update({f"E_{k}_J": v for k, v in energy.items()})
    r.update({"max_duty": 0.5, "min_driver_W": -50.0, "min_source_W": 0.0})
    r.update(kw)
    return r


def _claims(tmp_path, rows, **files):
    if rows:
        write_csv(tmp_path / "protocol.csv", rows)
    for name, content in files.items():
        write_csv(tmp_path / f"{name}.csv", content)
    return {c["id"]: c for c in evaluate(tmp_path)}


def test_table1_claim_follows_the_numbers(tmp_path):
    paper = PAPER["table1_energy"]
    ok = _claims(tmp_path, [_row(8, 2.0, {k: 1.1 * v for k, v in paper.items()})])
    assert ok["C1"]["holds"] == "yes" and ok["C10"]["holds"] == "yes"
    off = _claims(tmp_path, [_row(8, 2.0, {**paper, "motor": 0.8 * paper["motor"]}, min_driver_W=-10.0)])
    assert off["C1"]["holds"] == "no" and "motor" in off["C1"]["note"] and off["C10"]["holds"] == "no"


def test_grid_claims_need_the_grid_and_read_the_losses(tmp_path):
    few = _claims(tmp_path, [_row(8, 2.0, PAPER["table1_energy"])])
    assert few["C2"]["holds"] == few["C8"]["holds"] == "not checked"
    Ps, Ts = (2, 5, 8, 11, 15, 18), (1.2, 1.3, 1.5, 2.0, 2.5, 3.0)
    rows = []
    for i, P in enumerate(Ps):
        for j, T in enumerate(Ts):
            driver = 0.30 + 0.02 * (j - 2) ** 2  # a bowl over stride time, lowest at 1.5 s: 30-48 %
            gearing = 0.55 + 0.02 * i + (0.1 if P >= 15 and T <= 1.3 else 0.0)
            e = {"source": 100.0}
            e["driver"] = e["source"] * (1 - driver)
            e["motor"] = e["driver"] * (1 - 0.2 - 0.01 * i - 0.01 * j)  # grows with P and T
            e["link"] = e["motor"] * (1 - gearing)
            e["output"] = e["link"] * (1 - (0.6 if (P, T) == (18, 1.2) else 0.18))
            rows.append(_row(P, T, e, max_duty=0.9))  # the bench's controller: within the driver's limit
            rows.append(_row(P, T, {k: 0.0 for k in POINTS}, "replay", max_duty=1.2 if (P, T) == (18, 1.2) else 0.6))
    got = _claims(tmp_path, rows)
    assert got["C2"]["holds"] == "yes"  # 30-48 %: both ends within 6 points of 28.6-49.3 %
    assert got["C3"]["holds"] == got["C5"]["holds"] == got["C6"]["holds"] == got["C8"]["holds"] == "yes"
    assert got["C4"]["holds"] == "no"  # the minimum sits at 1.5 s but at 2 mm
    assert got["C7"]["holds"] == "yes"


def _driver_grid(driver):
    """A closed-loop grid whose driver loss is ``driver(P_mm, T)``; the other stages fixed."""
    rows = []
    for P in (2, 5, 8, 11, 15, 18):
        for T in (1.2, 1.3, 1.5, 2.0, 2.5, 3.0):
            e = {"source": 100.0, "driver": 100.0 * (1 - driver(P, T))}
            e.update(motor=0.8 * e["driver"], link=0.4 * e["driver"], output=0.3 * e["driver"])
            rows.append(_row(P, T, e))
    return rows


def test_driver_loss_claim_is_the_papers_bowl(tmp_path):
    bowl = _claims(tmp_path, _driver_grid(lambda P, T: 0.3 + 0.1 * (T - 1.5) ** 2))
    assert bowl["C3"]["holds"] == "yes" and "lowest at 1.5 s" in bowl["C3"]["simulated"]
    rising = _claims(tmp_path, _driver_grid(lambda P, T: 0.3 + 0.05 * T))  # grows everywhere: no short branch
    assert rising["C3"]["holds"] == "no" and "no bowl at 8 mm" in rising["C3"]["note"]
    # a bowl at the tuned 8 mm, but the loss falls at long strides elsewhere
    mixed = _claims(tmp_path, _driver_grid(lambda P, T: 0.3 + 0.1 * (T - 1.5) ** 2 * (1 if P == 8 else -1)))
    assert mixed["C3"]["holds"] == "no" and "long-stride branch not at 2 mm" in mixed["C3"]["note"]


def test_the_fits_c3_targets_read_the_bowl_as_the_claim_does(tmp_path):
    """``paper_fit`` is inferred on C3 (targets ``C3.short``, ``C3.long``): their residuals vanish on a grid where the
    claim holds and not on one where it fails, read from the runs as the claim reads the CSV."""
    from types import SimpleNamespace
    from acausal.models.ankle.targets import BENCH, TARGETS

    def runs_of(rows):
        return {(BENCH, r["P_mm"] * 1e-3, r["stride_time_s"]): SimpleNamespace(
            energy={k: r[f"E_{k}_J"] for k in POINTS},
            loss_fraction={"driver": 1 - r["E_driver_J"] / r["E_source_J"]}) for r in rows}
    c3 = {t.id: t for t in TARGETS if t.claim == "C3"}
    assert set(c3) == {"C3.short", "C3.long"} and all(t.bound == "lower" for t in c3.values())
    for driver, holds in ((lambda P, T: 0.3 + 0.1 * (T - 1.5) ** 2, "yes"),
                          (lambda P, T: 0.3 + 0.05 * T, "no"),  # no short branch
                          (lambda P, T: 0.3 + 0.1 * (T - 1.5) ** 2 * (1 if P == 8 else -1), "no")):  # long one falls
        rows = _driver_grid(driver)
        assert _claims(tmp_path, rows)["C3"]["holds"] == holds
        runs = runs_of(rows)
        z = [t.z(t.value(runs)) for t in c3.values()]
        assert (max(map(abs, z)) == 0.0) == (holds == "yes"), (holds, z)


def test_measured_claims_read_the_bench_not_the_replay(tmp_path):
    paper = PAPER["table1_energy"]
    replay_only = _claims(tmp_path, [_row(8, 2.0, paper, "replay")])
    assert replay_only["C1"]["holds"] == replay_only["C10"]["holds"] == "not checked"
    both = _claims(tmp_path, [_row(8, 2.0, paper), _row(8, 2.0, {k: 0.5 * v for k, v in paper.items()}, "replay")])
    assert both["C1"]["holds"] == "yes"


def test_design_claims_read_their_own_preset(tmp_path):
    optima = [dict(preset="paper_fit", stride_time_s=1.2, refined_kNpm=100.0, paper_design_kNpm=130.0,
                   efficiency_at_paper_design=0.15, refined_efficiency=0.25, refined_P_mm=5.0)]
    write_csv(tmp_path / "design_optima.csv", optima)
    assert {c["id"]: c for c in evaluate(tmp_path, "paper_fit")}["C11"]["holds"] == "yes"
    other = {c["id"]: c for c in evaluate(tmp_path, "library")}["C11"]
    assert other["holds"] == "not checked" and "library" in other["note"]


def test_average_efficiency_claim_reads_the_papers_eq4_maps(tmp_path):
    from acausal.models.ankle.presets import PAPER_EQ4

    def maps(eff):  # eff(k, P, T) on a 3 x 3 grid of the paper's Eq. 4 model, and the chain's at 0.1 everywhere
        return [dict(preset=preset, stride_time_s=T, k_Npm=k, P_m=P, feasible=True,
                     efficiency=eff(k, P, T) if preset == PAPER_EQ4 else 0.1)
                for preset in (PAPER_EQ4, "paper_fit") for T in (1.2, 2.0) for k in (1e5, 2e5, 3e5)
                for P in (0.004, 0.008, 0.012)]
    # higher on average at 2 s, although not at every design; the best precompression moves up at 2 s for k = 1e5
    # (0.012 m gains a point) and for k = 2e5 (0.004 m loses 8 points)
    up = _claims(tmp_path, [], design_maps=maps(lambda k, P, T: 0.3 + (0.05 if T == 2.0 else 0.0)
                                                 - (0.08 if (T, k, P) == (2.0, 2e5, 0.004) else 0.0)
                                                 + (0.01 if (T, k, P) == (2.0, 1e5, 0.012) else 0.0)))
    assert up["C12"]["holds"] == "yes" and "2 of 3 stiffnesses on Eq. 4" in up["C12"]["note"]
    down = _claims(tmp_path, [], design_maps=maps(lambda k, P, T: 0.3 - (0.05 if T == 2.0 else 0.0)))
    assert down["C12"]["holds"] == "no"
    assert _claims(tmp_path, [], design_maps=[dict(preset="paper_fit", stride_time_s=1.2, k_Npm=1e5, P_m=0.004,
                                                   feasible=True, efficiency=0.2)])["C12"]["holds"] == "not checked"


def test_r_inflation_claim_reads_the_calibration_on_its_own_presets_chain(tmp_path):
    t2 = [{"preset": "library", "parameter": "actuator resistance", "unit": "ohm", "motor_datasheet": 0.386,
           "estimated_total": 0.7, "calibrated": 2.0, "std_error": 0.1}]
    assert _claims(tmp_path, [], table2_calibrated=t2)["C13"]["holds"] == "yes"
    t2[0]["calibrated"] = 3.6  # 5.1x: more than 25 % above the paper's 2.86x
    assert _claims(tmp_path, [], table2_calibrated=t2)["C13"]["holds"] == "no"
    t2[0]["preset"] = "paper_fit"  # recordings of another chain say nothing of this preset's
    other = _claims(tmp_path, [], table2_calibrated=t2)["C13"]
    assert other["holds"] == "not checked" and "library chain" in other["note"]


def test_every_claim_is_a_prediction_until_a_fit_uses_it(tmp_path):
    assert len(CLAIMS) == 13
    for c in CLAIMS:
        assert c.statement and c.paper and c.reading, c.id
    assert {c["used_in_fit"] for c in evaluate(tmp_path)} == {"no"}
    marked = {c["id"] for c in evaluate(tmp_path, fitted=frozenset({"C1", "C9"})) if c["used_in_fit"] == "yes"}
    assert marked == {"C1", "C9"}


def test_fig7_claim_reads_its_own_preset(tmp_path):
    rows = [dict(preset=p, drive=d, peak_source_power_W=peak, energy_per_stride_J=100.0)
            for p, d, peak in (("library", "MACCEPA actuator", 100.0), ("library", "bench output motor", 140.0),
                               ("paper_fit", "MACCEPA actuator", 100.0), ("paper_fit", "bench output motor", 250.0),
                               ("paper_fit", "forward direct drive", 140.0))]
    write_csv(tmp_path / "fig07_summary.csv", rows)
    assert {c["id"]: c for c in evaluate(tmp_path, "library")}["C9"]["holds"] == "yes"
    assert {c["id"]: c for c in evaluate(tmp_path, "paper_fit")}["C9"]["holds"] == "no"


def test_missing_files_are_not_checked(tmp_path):
    got = {c["id"]: c["holds"] for c in evaluate(tmp_path)}
    assert set(got.values()) == {"not checked"}


def test_a_trend_tie_is_said_as_a_tie_whatever_the_order():
    """Fig. 11's row said "mixed (3 of 6)" or "grows (3 of 6)" by the hash seed (a tie broken by set order), and
    "grows (3 of 6)" read as a majority."""
    from acausal.models.ankle.figures.fig09_12_losses import trend_verdict
    tie = ["grows", "mixed", "grows", "mixed", "mixed", "grows"]
    assert trend_verdict(tie) == trend_verdict(tie[::-1]) == "no majority (grows 3, mixed 3 of 6 rows/columns)"
    assert trend_verdict(["grows"] * 4 + ["falls", "mixed"]) == "grows (4 of 6 rows/columns)"
    assert trend_verdict(["grows", "grows", "falls", "mixed"]) == "no majority (grows 2, falls 1, mixed 1 of 4 " \
                                                                  "rows/columns)"
