"""Parameter domains on the spec side: declared as ``(shape, doc, domain)``, required by
the primitives they are used in, refused with a SpecError naming system, family and
parameter where they cannot hold (wrong shape, bad bounds, a declaration that conflicts
with a primitive's, constants outside them), and emitted for the generated checks."""

from __future__ import annotations

from pathlib import Path

import pytest
import symengine as se

from symbolic import primitives as prim
from symbolic.codegen.backends.rust.system_module import emit_system
from symbolic.codegen.definition import define
from symbolic.codegen.generate import render
from symbolic.spec import (
    DEFAULT_TOLERANCE,
    Interval,
    NonNegative,
    Positive,
    Real,
    Rotation,
    SpecError,
    System,
    UnitVector,
    load,
)

REPO = Path(__file__).resolve().parents[2]
BOXED = Path(__file__).resolve().parent / "specs" / "boxed_robot.py"


def _planar(name: str, h, params: dict, **family) -> System:
    """A planar double integrator with one family ``name``."""
    s = System("demo")
    px, py, vx, vy = s.states(["px", "py", "vx", "vy"])
    s.inputs(["ax", "ay"], limits=[(-1, 1), (-1, 1)])
    s.dynamics(f=[vx, vy, 0, 0], g=[[0, 0], [0, 0], [1, 0], [0, 1]])
    s.family(name, lambda p: h(p, px, py), params=params, **({"capacity": True} | family))
    return s


def _domains(s: System) -> dict[str, dict[str, object]]:
    return {f.name: {p.name: p.domain for p in f.params} for f in define(s).families}


def _robot(px, py) -> prim.Box:
    return prim.Box([px, py, 0], prim.identity(), [0.1, 0.1, 0.1])


# ----------------------------------------------------------------- declaration
def test_declared_domains_in_every_form_reach_the_definition():
    params = {
        "a": ((), "doc", Positive()),
        "b": ((), NonNegative),  # a class without arguments is its default
        "c": ((), "doc", Interval(-1.0, 2.0)),
        "n": ((2,), UnitVector(1e-6)),
        "r": ((2, 2), "a 2x2 rotation", Rotation()),
        "free": ((), "no domain"),
    }

    def h(p, px, py):
        return p.a * px + p.b * py + p.c + p.free + p.n[0] * px + p.r[0][1] * py

    got = _domains(_planar("f", h, params))["f"]
    assert got == {"a": Positive(), "b": NonNegative(), "c": Interval(-1.0, 2.0), "n": UnitVector(1e-6),
                   "r": Rotation(DEFAULT_TOLERANCE), "free": Real()}


@pytest.mark.parametrize("spec, message", [
    (((3,), "doc", Rotation()),
     "parameter 'q' is declared Rotation, but a rotation is a 2x2 or 3x3 matrix, not shape (3,)"),
    (((4, 4), Rotation()), "a rotation is a 2x2 or 3x3 matrix, not shape (4, 4)"),
    (((2, 3), Rotation()), "not shape (2, 3)"),
    (((3, 3), UnitVector()),
     "parameter 'q' is declared UnitVector, but a unit vector is a vector, shape (n,), not (3, 3)"),
    (((), UnitVector()), "a unit vector is a vector, shape (n,), not ()"),
    (((), Interval(2.0, 1.0)), "Interval(2.0, 1.0) needs finite lo < hi within +-1e6"),
    (((), Interval(0.0, float("inf"))), "needs finite lo < hi"),
    (((), Interval(0.0, 2e6)), "needs finite lo < hi within +-1e6"),
    (((), Interval), "Interval needs its bounds"),
    (((3, 3), Rotation(0.0)), "Rotation(tol=0.0): the tolerance must be a number in [1e-12, 0.01]"),
    (((3, 3), Rotation(0.5)), "the tolerance must be a number in [1e-12, 0.01]"),
    (((2,), UnitVector(-1.0)), "UnitVector(tol=-1.0)"),
    (((), "doc", "positive"), "'positive' is not a domain"),
    (((), "doc", Positive(), "extra"), "parameter 'q' has shape"),
])
def test_a_domain_that_cannot_hold_is_a_spec_error_naming_system_family_and_parameter(spec, message):
    with pytest.raises(SpecError) as err:
        _planar("walls", lambda p, px, py: px - p.q[0][0] if isinstance(p.q, list) else px, {"q": spec})
    text = str(err.value)
    assert "system 'demo', family 'walls'" in text and "'q'" in text and message in text, text


def test_declared_domains_are_emitted_for_the_generated_checks():
    params = {"half": ((2,), Interval(1e-3, 2.0)), "n": ((2,), UnitVector()), "r": ((2, 2), Rotation(1e-6))}
    text = emit_system(define(_planar("walls", lambda p, px, py: p.half[0] * px + p.n[0] * py + p.r[0][0],
                                      params)), "rt")
    for line in ['("half", rt::param_domain::Domain::Interval { lo: 0.001, hi: 2.0 }),',
                 '("n", rt::param_domain::Domain::UnitVector { tolerance: 1e-09 }),',
                 '("r", rt::param_domain::Domain::Rotation { tolerance: 1e-06 }),',
                 'rt::param_domain::check("walls", "r", Self::DOMAINS[2].1, &[2, 2], self.r.as_slice())?;']:
        assert line in text, line
    # Every instance is checked where the rows are evaluated, naming member and instance.
    assert "p.validate().map_err(|e| e.in_instance(instance).in_member(member))?;" in text


# ---------------------------------------------------------------- primitives
def test_primitives_give_their_parameters_domains():
    def h(p, px, py):
        box = prim.Box(p.center, p.rotation, p.half)
        post = prim.Box(p.center, prim.rot_z(p.yaw), [p.hx, p.hy, p.hz])
        return [("ssat", prim.ssat(p, box, _robot(px, py))),
                ("sphere", prim.sphere_box(p, [px, py, 0], p.radius, post)),
                ("blob", prim.superellipsoid(p, [px, py, 0], box, inflate=p.margin)),
                ("fence", prim.half_space([px, py], p.normal, p.offset))]

    params = {"center": (3,), "rotation": (3, 3), "half": (3,), "yaw": (), "hx": (), "hy": (), "hz": (),
              "radius": (), "margin": (), "normal": (2,), "offset": ()}
    got = _domains(_planar("f", h, params))["f"]
    rotation = Rotation(DEFAULT_TOLERANCE)
    assert got == {"center": Real(), "rotation": rotation, "half": Positive(), "yaw": Real(), "hx": Positive(),
                   "hy": Positive(), "hz": Positive(), "radius": Positive(), "margin": NonNegative(),
                   "normal": UnitVector(DEFAULT_TOLERANCE), "offset": Real()}
    assert prim.BOX_ROTATION == rotation and prim.NORMAL == UnitVector(DEFAULT_TOLERANCE)


def test_a_transposed_rotation_parameter_still_gets_its_domain():
    got = _domains(_planar("f", lambda p, px, py: prim.ssat(p, prim.Box(p.c, prim.transpose(p.r), [1, 1, 1]),
                                                               _robot(px, py)),
                           {"c": (3,), "r": (3, 3)}))["f"]
    assert got == {"c": Real(), "r": Rotation(DEFAULT_TOLERANCE)}


def test_a_declared_domain_within_the_primitives_is_kept_and_one_outside_is_an_error():
    def h(p, px, py):
        return prim.ssat(p, prim.Box(p.c, prim.identity(), p.half), _robot(px, py))

    narrow = {"c": (3,), "half": ((3,), "half extents", Interval(0.01, 1.0))}
    assert _domains(_planar("walls", h, narrow))["walls"]["half"] == Interval(0.01, 1.0)
    for declared in (NonNegative(), Real(), Interval(-1.0, 1.0), Interval(0.0, 1.0)):
        with pytest.raises(SpecError) as err:
            define(_planar("walls", h, {"c": (3,), "half": ((3,), declared)}))
        text = str(err.value)
        assert "system 'demo', family 'walls'" in text and "parameter 'half' is declared" in text, text
        assert "prim.Box's box half extents needs > 0" in text, text
    tight = {"c": (3,), "r": ((3, 3), Rotation(1e-12))}
    loose = {"c": (3,), "r": ((3, 3), Rotation(1e-6))}

    def with_r(p, px, py):
        return prim.ssat(p, prim.Box(p.c, p.r, [1, 1, 1]), _robot(px, py))

    assert _domains(_planar("walls", with_r, tight))["walls"]["r"] == Rotation(1e-12)
    with pytest.raises(SpecError, match="parameter 'r' is declared Rotation .* needs a proper rotation"):
        define(_planar("walls", with_r, loose))


def test_one_parameter_asked_two_incompatible_domains_is_an_error():
    def h(p, px, py):
        return prim.ssat(p, prim.Box([0, 0, 0], prim.identity(), p.v), _robot(px, py)) + prim.half_space(
            [px, py, 0], p.v, 0)

    with pytest.raises(SpecError) as err:
        define(_planar("walls", h, {"v": (3,)}))
    assert "family 'walls'" in str(err.value) and "parameter 'v'" in str(err.value)
    assert "no one domain satisfies both" in str(err.value)


def test_a_primitive_given_part_of_a_parameter_asks_for_a_declaration():
    def h(p, px, py):
        return prim.ssat(p, prim.Box([0, 0, 0], prim.identity(), [p.v[0], p.v[1], 0.2]), _robot(px, py))

    with pytest.raises(SpecError) as err:
        define(_planar("walls", h, {"v": (3,)}))
    text = str(err.value)
    assert "system 'demo', family 'walls'" in text and "uses some entries of parameter 'v'" in text, text
    assert _domains(_planar("walls", h, {"v": ((3,), Positive())}))["walls"]["v"] == Positive()

    def rows(p, px, py):  # a rotation from some entries of a matrix parameter is no rotation
        return prim.ssat(p, prim.Box([0, 0, 0], [p.m[0], p.m[1], [0, 0, 1]], [1, 1, 1]), _robot(px, py))

    with pytest.raises(SpecError, match="uses entries of parameter 'm' but not the parameter as a whole"):
        define(_planar("walls", rows, {"m": (3, 3)}))


def test_expressions_of_parameters_are_left_to_the_spec():
    # A rotation built from an angle and half extents grown by a constant are not the
    # parameters themselves: nothing is attached, nothing refused.
    def h(p, px, py):
        return prim.ssat(p, prim.Box([0, 0, 0], prim.rot_z(p.yaw), [p.a + 0.1, 1, 1]), _robot(px, py))

    assert _domains(_planar("walls", h, {"yaw": (), "a": ()}))["walls"] == {"yaw": Real(), "a": Real()}


@pytest.mark.parametrize("make, message", [
    (lambda: prim.Box([0, 0, 0], prim.identity(), [0.1, -0.2, 0.1]), "entry 1 is -0.2, not > 0"),
    (lambda: prim.Box([0, 0, 0], [[2, 0, 0], [0, 2, 0], [0, 0, 2]], [1, 1, 1]), "max |R^T R - I| is 3"),
    (lambda: prim.Box([0, 0, 0], [[1, 0, 0], [0, 1, 0], [0, 0, -1]], [1, 1, 1]), "det R is -1"),
    (lambda: prim.half_space([0, 0], [1, 1], 0), "its length is 1.41421"),
])
def test_constants_outside_a_primitive_domain_are_refused_where_they_are_written(make, message):
    with pytest.raises(SpecError, match=message.replace("|", r"\|").replace("^", r"\^")):
        make()


def test_a_constant_outside_a_domain_inside_a_family_names_system_and_family():
    def h(p, px, py):
        return prim.ssat(p, prim.Box(p.c, prim.identity(), [0.1, 0.0, 0.1]), _robot(px, py))

    with pytest.raises(SpecError, match=r"system 'demo', family 'walls': prim.Box's box half extents .* "
                                        r"entry 1 is 0, not > 0"):
        define(_planar("walls", h, {"c": (3,)}))


def test_every_member_of_an_indexed_family_asks_the_same_domain_once():
    s = System("demo")
    px, py, vx, vy = s.states(["px", "py", "vx", "vy"])
    s.inputs(["ax", "ay"], limits=[(-1, 1), (-1, 1)])
    s.dynamics(f=[vx, vy, 0, 0], g=[[0, 0], [0, 0], [1, 0], [0, 1]])
    sizes = {"small": 0.1, "large": 0.3}
    s.family("walls", lambda p: prim.ssat(p, prim.Box(p.c, p.r, p.half),
                                          prim.Box([px, py, 0], prim.identity(), [sizes[p.label]] * 3)),
             params={"c": (3,), "r": (3, 3), "half": (3,)}, over=list(sizes), capacity=True)
    fam = define(s).families[0]
    assert [(p.name, p.domain) for p in fam.params] == [("c", Real()), ("r", Rotation(DEFAULT_TOLERANCE)),
                                                        ("half", Positive())]


# ------------------------------------------------------------------- built-ins
def _spec_domains(path: str) -> dict[str, dict[str, object]]:
    return {f.name: {p.name: p.domain for p in f.params} for f in define(load(REPO / path)).families}


def test_the_built_in_families_declare_or_inherit_their_domains():
    t3 = _spec_domains("systems/tachyon3/spec/tachyon3.py")
    edge = {"center": Real(), "rotation": Rotation(1e-9), "half": Interval(1e-6, 1e4)}
    assert t3["body_edge"] == edge and t3["toe_edge"] == edge
    assert t3["foothold"] == {"normal": UnitVector(1e-9), "offset": Real()}
    assert t3["foot_height"] == {"floor_z": Real()} and t3["stability"] == {"a": Real(), "b": Real()}
    panda = _spec_domains("systems/panda/spec/panda.py")
    assert panda["obstacle"] == {"center": Real(), "rotation": Rotation(1e-9), "half": Positive()}
    robot = _spec_domains("examples/your_robot/spec/your_robot.py")
    assert robot["obstacle"]["radius"] == Positive() and robot["corridor"]["normal"] == UnitVector(1e-9)


def test_the_generated_checks_carry_each_domain():
    _, text = render(BOXED)
    for line in ['("rotation", cbfgen::param_domain::Domain::Rotation { tolerance: 1e-09 }),',
                 '("half_extents", cbfgen::param_domain::Domain::Positive),',
                 '("margin", cbfgen::param_domain::Domain::NonNegative),',
                 '("normal", cbfgen::param_domain::Domain::UnitVector { tolerance: 1e-09 }),',
                 '[("vmax", cbfgen::param_domain::Domain::Interval { lo: 0.1, hi: 5.0 })]']:
        assert line in text, line
    # An unset fixed instance is checked where it is evaluated, naming member and instance.
    assert "p.validate().map_err(|e| e.in_instance(instance).in_member(member))?;" in text


def test_half_extents_as_symengine_numbers_are_checked_too():
    with pytest.raises(SpecError, match="entry 0 is -1"):
        prim.Box([0, 0, 0], prim.identity(), [se.RealDouble(-1.0), se.Integer(1), se.Rational(1, 2)])
    prim.Box([0, 0, 0], prim.identity(), [se.RealDouble(1.0), se.Integer(1), se.Rational(1, 2)])
