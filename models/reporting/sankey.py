"""Labels of the paper's five-point Sankey diagram (``examples/table1.py``, ``acausal compare``); the drawing is
:func:`acausal.results.sankey.sankey`."""
from __future__ import annotations

#: the note under the output stage of the paper's actuator, whose MACCEPA is modelled lossless
LOSSLESS_LINKAGE = "output loss 0 J\n(MACCEPA modelled\nlossless)"
LABELS = {"source": "source", "driver": "driver output", "motor": "motor (k i w)", "link": "moment arm (link)",
          "output": "joint (output)"}


def loss_names_from_groups(loss_groups: dict, link: str = "linkage") -> list:
    """``(point after the stage, label)`` of each stage's loss, from a model's loss groups (``{"driver": [...],
    "motor": [...], "gearing": [...], "output": [...]}`` of loss-power names such as ``"rect.loss_power"``, as
    :attr:`StrideResult.stages <acausal.models.ankle.protocol.StrideResult.stages>` holds them)."""
    def who(stage):
        names = [n.split(".")[0] for n in loss_groups.get(stage, [])]
        return f"\n({', '.join(names)})" if names and names != [stage] else ""
    return [("driver", "driver loss" + who("driver")), ("motor", "motor loss" + who("motor")),
            ("link", "rotor and gearing loss" + who("gearing")), ("output", f"output loss\n({link})")]
