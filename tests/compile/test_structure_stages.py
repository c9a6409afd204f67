"""Alias elimination, the balance check, Pantelides' index reduction with dummy derivatives and the BLT ordering,
each on a small system whose answer is known by hand, stage by stage (flatten -> aliases -> balance -> index
reduction -> BLT), without compiling code."""
import numpy as np
import pytest
import sympy as sp

from acausal import Component, Eq, Model, Parameter, StructureError, Variable, compile_model, der, time
from acausal.compile.alias import eliminate_aliases
from acausal.compile.flatten import flatten
from acausal.compile.structure import EquationSystem, blt_blocks, check_balance, reduce_index
from acausal.compile.structure.balance import max_matching


def flat_of(model):
    flat = flatten(model)
    eliminate_aliases(flat)
    return flat


def stages(model):
    """``(balanced, reduced, sorted)`` systems of a model."""
    balanced = check_balance(EquationSystem.from_flat(flat_of(model)))
    reduced = reduce_index(balanced)
    return balanced, reduced, blt_blocks(reduced)


# ------------------------------------------------------------------------------------------- alias elimination
class Aliased(Component):
    """a = b, c = -a, k = 3 and y = x are aliases; x has a fixed start, so x stays and y goes."""
    a, b, c, k = Variable(), Variable(), Variable(), Variable()
    x = Variable(start=1.0, fixed=True)
    y = Variable()

    def equations(self):
        return [Eq(self.a, self.b), Eq(self.c, -self.a), Eq(self.k, 3.0), Eq(der(self.x), -self.x + self.a),
                Eq(self.b, sp.sin(time)), Eq(self.y, self.x)]


def test_aliases_are_removed_with_their_sign_and_constant():
    flat = flat_of(Aliased())
    assert {n: str(e) for n, e in flat.aliases.items()} == {"b": "a", "c": "-a", "k": "3.00000000000000", "y": "x"}
    assert sorted(flat.variables) == ["a", "x"]
    residuals = {str(eq.residual) for eq in flat.equations}
    assert residuals == {"-a + der(x) + x", "a - sin(time)"}


def test_the_variable_with_a_fixed_start_is_the_one_kept():
    class Swapped(Component):
        y = Variable()
        x = Variable(start=1.0, fixed=True)

        def equations(self):
            return [Eq(self.y, self.x), Eq(der(self.x), -self.y)]
    flat = flat_of(Swapped())
    assert {n: str(e) for n, e in flat.aliases.items()} == {"y": "x"} and sorted(flat.variables) == ["x"]


def test_aliases_reach_the_results_by_name():
    res = compile_model(Aliased()).simulate(1.0, n_points=11)
    np.testing.assert_allclose(res["c"], -np.sin(res.t), atol=1e-12)
    np.testing.assert_allclose(res["y"], res["x"], atol=0)
    assert np.all(res["k"] == 3.0)


# ------------------------------------------------------------------------------------------- balance
def test_maximum_matching_assigns_every_equation_an_unknown():
    assert max_matching([{"a", "b"}, {"a"}], ["a", "b"]) == {0: "b", 1: "a"}
    assert len(max_matching([{"a"}, {"a"}], ["a", "b"])) == 1  # the second equation finds nothing left


class Under(Component):
    a, b, c = Variable(), Variable(), Variable()

    def equations(self):
        return [Eq(self.a + self.b, sp.sin(time)), Eq(self.c, sp.cos(time))]


class Wrapped(Model):
    def build(self):
        self.part = Under()


class Conflict(Component):
    a, b, c = Variable(), Variable(), Variable()

    def equations(self):
        return [Eq(self.a + self.b, sp.sin(time)), Eq(2 * self.a + 3 * self.b, sp.cos(time)),
                Eq(self.a * self.b, 1 + time), Eq(self.c, time * self.c + 1)]


def test_an_under_determined_system_names_the_component_and_its_unknowns():
    with pytest.raises(StructureError, match=r"2 equations for 3 unknowns; under-determined.*'part\.a', 'part\.b' "
                                             r"of 'part' lack 1 equation"):
        check_balance(EquationSystem.from_flat(flat_of(Wrapped())))


def test_an_over_determined_system_names_the_unknowns_its_surplus_constrains():
    with pytest.raises(StructureError, match=r"4 equations for 3 unknowns; over-determined: 1 equation\(s\) too "
                                             r"many .*constrain 'a', 'b'"):
        check_balance(EquationSystem.from_flat(flat_of(Conflict())))


# ------------------------------------------------------------------------------------------- Pantelides
class Pendulum(Component):
    """The planar pendulum in Cartesian coordinates: index 3 (the rod's length constrains the positions, so the
    tension F is found only after differentiating the constraint twice)."""
    L, m, g = Parameter(1.0), Parameter(1.0), Parameter(9.81)
    x, y = Variable(start=1.0), Variable(start=0.0)
    vx, vy = Variable(start=0.0), Variable(start=0.0)
    F = Variable()

    def equations(self):
        return [Eq(der(self.x), self.vx), Eq(der(self.y), self.vy),
                Eq(self.m * der(self.vx), -self.F * self.x / self.L),
                Eq(self.m * der(self.vy), -self.F * self.y / self.L - self.m * self.g),
                Eq(self.x**2 + self.y**2, self.L**2)]


def test_the_cartesian_pendulum_is_index_three_with_two_states():
    balanced, reduced, _ = stages(Pendulum())
    assert balanced.index == 1 and reduced.differentiations == 2 and reduced.index == 3
    # the constraint twice, each velocity equation once: 5 + 4 equations
    assert len(reduced.residuals) == 9 and sum(p is not None for p in reduced.eq_pred) == 4
    assert len(reduced.states) == 2 and len(reduced.dummies) == 4
    # one position and its velocity are states; the other pair is dummy (algebraic) through the constraint
    pos = {"x", "y"} & set(reduced.states)
    assert len(pos) == 1 and {"v" + p for p in pos} <= set(reduced.states)


class SwingingPendulum(Pendulum):
    """The same pendulum swinging 30 degrees either side of the bottom, its horizontal position and speed chosen as
    states (they are a good coordinate system wherever the rod is not horizontal)."""
    x, vx = Variable(start=0.5, state_select="always"), Variable(start=0.0, state_select="always")
    y = Variable(start=-np.sqrt(0.75))


def test_the_index_reduced_pendulum_keeps_its_length_and_its_energy():
    sim = compile_model(SwingingPendulum())
    assert sorted(sim.state_names) == ["vx", "x"]
    res = sim.simulate(3.0, n_points=301, rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(res["x"] ** 2 + res["y"] ** 2, 1.0, atol=1e-8)
    energy = 0.5 * (res["vx"] ** 2 + res["vy"] ** 2) + 9.81 * res["y"]
    np.testing.assert_allclose(energy, energy[0], atol=1e-6)
    assert res["x"].min() == pytest.approx(-0.5, abs=1e-3)  # it swings through the bottom to the other side


@pytest.mark.xfail(strict=True, reason="static state selection: the default states (y, vy) are no coordinate system "
                   "at the bottom, and the run is not refused there (it stops the pendulum, losing m g L of energy)")
def test_a_run_through_a_singular_state_choice_is_refused_or_right():
    from acausal import UntrustedResult
    try:
        res = compile_model(Pendulum()).simulate(2.0, n_points=201, rtol=1e-9, atol=1e-11)
    except UntrustedResult:
        return
    energy = 0.5 * (res["vx"] ** 2 + res["vy"] ** 2) + 9.81 * res["y"]
    np.testing.assert_allclose(energy, energy[0], atol=1e-3)


class RigidPair(Component):
    """Two inertias whose angles are equal (a rigid shaft): their four states are two."""
    J1, J2 = Parameter(1.0), Parameter(2.0)
    p1, w1 = Variable(start=0.0, fixed=True), Variable(start=1.0)
    p2, w2, tau = Variable(), Variable(), Variable()

    def equations(self):
        return [Eq(der(self.p1), self.w1), Eq(der(self.p2), self.w2), Eq(self.J1 * der(self.w1), self.tau),
                Eq(self.J2 * der(self.w2), -self.tau + sp.sin(time)), Eq(self.p1, self.p2)]


def test_rigidly_joined_inertias_have_one_angle_and_one_speed():
    _, reduced, _ = stages(RigidPair())
    assert reduced.differentiations == 1 and reduced.index == 2
    assert len(reduced.states) == 2 and sum(s.startswith("p") for s in reduced.states) == 1


# ------------------------------------------------------------------------------------------- BLT
class Chain(Component):
    """Written in the wrong order: c from b and a, b from a, a from time; then a linear loop of u and v."""
    a, b, c, u, v = Variable(), Variable(), Variable(), Variable(), Variable()

    def equations(self):
        return [Eq(self.c, self.b + self.a), Eq(self.b, 2 * self.a), Eq(self.a, sp.sin(time)),
                Eq(self.u + self.v, self.c), Eq(self.u - self.v, 1)]


def test_blt_orders_explicit_equations_and_groups_a_loop():
    _, _, ordered = stages(Chain())
    blocks = [(eqs, sorted(unknowns)) for eqs, unknowns in ordered.blocks]
    assert blocks == [([2], ["a"]), ([1], ["b"]), ([0], ["c"]), ([3, 4], ["u", "v"])]


def test_every_block_needs_only_the_states_and_earlier_blocks():
    for model in (Chain(), Pendulum(), RigidPair()):
        _, reduced, ordered = stages(model)
        known = set(reduced.states)
        for eqs, unknowns in ordered.blocks:
            needed = set().union(*(reduced.eq_vars[k] for k in eqs)) - set(unknowns)
            assert needed <= known, (type(model).__name__, eqs, needed - known)
            known |= set(unknowns)
        assert known == set(reduced.variables)
