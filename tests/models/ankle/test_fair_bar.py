"""The bar the report holds the paper's claims to (models/ankle/paper.py, fit_record.py): the headline over the
testable predictions only, the report's first table (every claim with its class and the paper's sentence, its margin
and "fragile"), and the fitted values near a bound of their range, each with the record's reason or flagged."""
import re

from acausal.models.ankle import claims as C
from acausal.models.ankle.fit_record import bounds_markdown, near_bounds
from acausal.models.ankle.paper import fair_bar, headline
from acausal.models.ankle.presets import paper_fit_record


def _claim_rows(holding: dict):
    """Rows as evaluate gives them: every claim with its declared class; ``holding``: id -> (holds, fragile)."""
    return [dict(id=c.id, role=c.role, quote=c.quote, why=c.why, simulated="x", margin="m",
                 holds=holding.get(c.id, ("no", ""))[0], fragile=holding.get(c.id, ("no", ""))[1])
            for c in C.CLAIMS]


def test_the_headline_counts_the_testable_predictions_only():
    testable = [c.id for c in C.CLAIMS if c.role == C.TESTABLE]
    others = {c.id: ("yes", "no") for c in C.CLAIMS if c.role != C.TESTABLE}  # targets etc. holding count nothing
    none = headline(_claim_rows(others))
    assert f"0 of {len(testable)} testable predictions hold" in none and "fewer than half" in none
    every = headline(_claim_rows({**others, **{i: ("yes", "no") for i in testable}}))
    assert f"{len(testable)} of {len(testable)} testable predictions hold" in every and "at least half" in every
    one = headline(_claim_rows({testable[0]: ("yes", "yes")}))
    assert f"1 of {len(testable)}" in one and f"fragile: {testable[0]}" in one


def _record(values: dict, reasons: dict = {}):
    record = paper_fit_record()
    unknowns = [dict(parameter=k, value=v, lo=0.0, hi=1.0, sd=0.1, identified=True, unit="1", start=0.5, source="s",
                     **({"bound_reason": reasons[k]} if k in reasons else {})) for k, v in values.items()]
    return {**record, "unknowns": unknowns}


def test_values_near_a_bound_are_named_with_their_reason_or_flagged():
    record = _record({"a": 0.03, "b": 0.5, "c": 0.97, "d": 0.051}, {"c": "the paper's own estimate"})
    near = {b["parameter"]: b for b in near_bounds(record)}
    assert set(near) == {"a", "c"} and near["a"]["bound"] == "lower" and near["c"]["bound"] == "upper"
    table = bounds_markdown(record)
    assert "lower: **on a bound, no reason**" in table and "upper: the paper's own estimate" in table


def test_the_shipped_records_reasons_belong_to_values_near_a_bound():
    record = paper_fit_record()
    near = {b["parameter"] for b in near_bounds(record)}
    assert {u["parameter"] for u in record["unknowns"] if u.get("bound_reason")} <= near


def test_the_reports_first_section_lists_every_claim_with_its_class_and_sentence():
    rows = _claim_rows({"C10": ("yes", "yes")})
    text = "\n".join(fair_bar(rows, paper_fit_record()))
    table = [line for line in text.splitlines() if re.match(r"\| C\d+ \|", line)]
    assert [line.split("|")[1].strip() for line in table] == [c.id for c in C.CLAIMS]
    c10 = next(line for line in table if line.startswith("| C10 |"))
    assert C.CALIBRATION["C10"][1] in c10 and "**fragile**" in c10
    assert "testable predictions hold" in text and "are the declared ones" in text


def test_a_bound_reason_has_one_home_the_unknowns_declaration_which_the_inference_writes_into_its_record():
    """The reasons a fitted value may sit at a bound are declared with the unknowns (``inference.UNKNOWNS``); the
    record carries what the inference wrote from them, so a rerun of ``acausal infer`` keeps them."""
    from acausal.models.ankle.inference import CALIBRATION_SET, UNKNOWNS
    from acausal.models.ankle.presets import paper_fit_record
    record = paper_fit_record()
    declared = {u.name: u.bound_reason for u in UNKNOWNS}
    assert {u["parameter"]: u.get("bound_reason", "") for u in record["unknowns"]} == declared
    assert record["calibration_set"].startswith(CALIBRATION_SET)
