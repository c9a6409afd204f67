"""Result.plot: labels, one y axis per unit, clear errors."""
import warnings

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from acausal import ModelError, compile_model  # noqa: E402
from acausal.errors import UnknownNameError  # noqa: E402

from ..drive_models import MotorGearLoad  # noqa: E402


@pytest.fixture(scope="module")
def res():
    return compile_model(MotorGearLoad()).simulate(0.05, n_points=51)


def _legend(ax):
    return [t.get_text() for t in ax.get_legend().get_texts()]


def test_default_labels_carry_name_and_unit_and_units_get_their_own_axis(res):
    ax = res.plot("L.i", "rotor.w")
    assert _legend(ax) == ["L.i [A]", "rotor.w [rad/s]"]
    assert ax.get_ylabel() == "[A]" and ax.twin.get_ylabel() == "[rad/s]"
    assert np.array_equal(ax.get_lines()[0].get_ydata(), res["L.i"])
    assert np.array_equal(ax.twin.get_lines()[0].get_ydata(), res["rotor.w"])
    c1, c2 = ax.get_lines()[0].get_color(), ax.twin.get_lines()[0].get_color()
    assert c1 != c2  # one color cycle over both axes
    plt.close("all")


def test_label_as_string_list_or_dict(res):
    assert _legend(res.plot("L.i", label="motor current")) == ["motor current"]
    assert _legend(res.plot("L.i", "R.i", label=["coil", "resistor"])) == ["coil", "resistor"]
    ax = res.plot("L.i", "R.i", label={"R.i": "resistor"})
    assert _legend(ax) == ["L.i [A]", "resistor"] and not hasattr(ax, "twin")  # one unit (A): one axis
    plt.close("all")


def test_bad_labels_and_names_are_named(res):
    with pytest.raises(ModelError, match="one string for 2 variables"):
        res.plot("L.i", "R.i", label="both")
    with pytest.raises(ModelError, match="3 labels for 2 variables"):
        res.plot("L.i", "R.i", label=["a", "b", "c"])
    with pytest.raises(ModelError, match="not plotted"):
        res.plot("L.i", label={"rotor.w": "speed"})
    with pytest.raises(UnknownNameError, match="nope"):
        res.plot("nope")
    with pytest.raises(ModelError, match="at least one"):
        res.plot()
    plt.close("all")


def test_a_third_unit_shares_the_right_axis_with_a_warning(res):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ax = res.plot("L.i", "rotor.w", "R.loss_power")
    assert any("3 units (A, rad/s, W)" in str(w.message) for w in caught)
    assert len(ax.twin.get_lines()) == 2 and ax.twin.get_ylabel() == "[rad/s], [W]"
    plt.close("all")


def test_plots_onto_a_given_axis(res):
    fig, (top, bottom) = plt.subplots(2, 1)
    assert res.plot("L.i", ax=top) is top and len(bottom.get_lines()) == 0
    assert len(top.get_lines()) == 1
    plt.close(fig)
