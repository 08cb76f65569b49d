"""Parameter domains on the spec side: declared as ``(shape, doc, domain)``, refused with a
SpecError naming system, family and parameter where they cannot hold (wrong shape, bad
bounds), and emitted for the generated checks."""

from __future__ import annotations

import pytest

from symbolic.codegen.backends.rust.system_module import emit_system
from symbolic.codegen.definition import define
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
)


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
