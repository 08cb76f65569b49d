"""Relative-degree detection, model-file validation, and model edits reaching the output."""

import importlib.util
import sys

import pytest
import symengine as se

from symbolic.codegen.backends.rust.emitter import emit_kernel
from symbolic.codegen.definition import define
from symbolic.codegen.generate import render
from symbolic.generate import REPO_ROOT
from symbolic.kernel import Kernel
from symbolic.lie import LieEngine, RelativeDegreeError

SPEC_DIR = REPO_ROOT / "systems" / "tachyon3" / "spec"
MODEL = SPEC_DIR / "tachyon3.toml"


def _load(name: str, path):
    """A module of the Tachyon 3 crate's spec folder, loaded by path (the spec imports its
    model module by plain name, as it is when cbfgen-build loads it). What it imports is
    taken out of ``sys.modules`` again, as the spec loader does, so a spec loaded later
    from another folder finds its own model module."""
    before = set(sys.modules)
    sys.path.insert(0, str(SPEC_DIR))
    try:
        loader = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(loader)
        sys.modules[name] = module  # dataclasses look their module up by name
        loader.loader.exec_module(module)
    finally:
        sys.path.remove(str(SPEC_DIR))
        for added in set(sys.modules) - before:
            del sys.modules[added]
    return module


_model = _load("tachyon3_model", SPEC_DIR / "tachyon3_model.py")
ModelError, Tachyon3, load_model = _model.ModelError, _model.Tachyon3, _model.load_model


def _tachyon3_spec():
    """The Tachyon 3 spec module (its crate's spec/tachyon3.py)."""
    return _load("tachyon3_spec", SPEC_DIR / "tachyon3.py")


@pytest.fixture(scope="module")
def system():
    return Tachyon3(load_model(MODEL))


def engine(system):
    k = Kernel("probe", "probe")
    k.array_input("x", system.state_names, "state")
    return LieEngine(k, system.x, system.f, system.g)


def test_velocity_constraint_has_degree_one(system):
    row = engine(system).row(1 - system.s["v"] ** 2, "speed")
    assert row.degree == 1 and set(row.lg) == {system.input_names.index("a")}


def test_position_constraints_have_degree_two(system):
    s = system.s
    eng = engine(system)
    assert eng.row(s["bz"] - 0.1, "body height").degree == 2
    world_x = eng.row(s["px"], "origin x")  # p_x' = v cos(yaw): the input reaches it via v
    assert world_x.degree == 2 and set(world_x.lg) == {system.input_names.index("a")}
    # Through a named intermediate, as the families use them.
    z = eng.let_("probe_z", s["bz"] + 0.3 * se.sin(s["pitch"]))
    row = eng.row(z * z - 0.04, "through a let")
    assert row.degree == 2
    assert set(row.lg) == {system.input_names.index("baz"), system.input_names.index("pitch_acc")}


def test_constraint_without_input_dependence_is_rejected(system):
    with pytest.raises(RelativeDegreeError, match="does not depend on the input"):
        engine(system).row(system.s["pz"] - 0.5, "origin height")  # p_z' = 0 for ever


def _definition(model=MODEL):
    return define(_tachyon3_spec().build(model))


def test_moving_a_hip_regenerates_exactly_the_kernels_that_depend_on_it(tmp_path):
    text = MODEL.read_text()
    edited = text.replace("hip = [0.40, 0.40, 0.12]", "hip = [0.42, 0.40, 0.12]", 1)  # LF hip 2 cm forward
    assert edited != text
    (tmp_path / "tachyon3.toml").write_text(edited)
    before, after = _definition(), _definition(tmp_path / "tachyon3.toml")
    texts = [{k.name: emit_kernel(k, "cbfgen") for k in d.kernels()} for d in (before, after)]
    changed = {name for name in texts[0] if texts[0][name] != texts[1][name]}
    assert "joint_limits_lf" in changed
    # The toes move in the hips' lateral planes: only the hip's y reaches the toe rows.
    assert not changed & {"joint_limits_rf", "body_edge", "toe_edge", "foothold_lf", "drift"}
    hips = [{c.name: c.value for c in d.constants}["hip_positions"] for d in (before, after)]
    assert hips[0][0][0] == 0.40 and hips[1][0][0] == 0.42


def test_editing_the_model_changes_the_inputs_hash(tmp_path):
    """The model file is a dependency of the spec: its header lists it and an edit changes
    the inputs hash (what cbfgen-build compares), so the crate regenerates."""
    copy = tmp_path / "spec"
    copy.mkdir()
    for name in ("tachyon3.py", "tachyon3_model.py", "tachyon3.toml"):
        (copy / name).write_text((SPEC_DIR / name).read_text())
    _, before = render(copy / "tachyon3.py")
    assert "// depends: tachyon3.toml\n// depends: tachyon3_model.py\n" in before
    model = copy / "tachyon3.toml"
    model.write_text(model.read_text().replace("radius = 0.10", "radius = 0.11"))
    _, after = render(copy / "tachyon3.py")
    assert before.splitlines()[1] != after.splitlines()[1]


@pytest.mark.parametrize("edit, message", [
    (("stroke = 0.50", "stroke = -0.50"), "knee.stroke: must be > 0"),
    (('outward = "forward"', 'outward = "sideways"'), "outward"),
    (("hip_range_deg = [-45.0, 45.0]", "hip_range_deg = [45.0, -45.0]"), "hip_range_deg"),
    (("toe_alpha = 1500.0", "toe_alpha = -1.0"), r"smoothing.toe_alpha: must lie in \[1e-06, 1e\+09\]"),
    (("toe_alpha = 1500.0", 'toe_alpha = "sharp"'), "smoothing.toe_alpha: expected a finite number"),
    (("toe_accel = [10.0, 10.0]", "toe_accel = [10.0]"), "inputs.toe_accel"),
    (("origin_accel = 3.0", "origin_accel = 0.0"), "inputs.origin_accel: must be > 0"),
    # The runtime's domains: numbers the safe API would refuse are refused here too.
    (("ssat_alpha = 200.0", "ssat_alpha = 1e300"), r"smoothing.ssat_alpha: must lie in \[1e-06, 1e\+09\]"),
    (("ssat_alpha_rot = 200.0", "ssat_alpha_rot = 5e-324"), "smoothing.ssat_alpha_rot: must lie in"),
    (("half_extents = [0.50, 0.30, 0.125]", "half_extents = [0.50, 0.30, 1e-17]"), "body.half_extents: must lie in"),
    (("poles = [20.0, 20.0]", "poles = [20.0, 1e300]"), "ecbf.poles: must lie in"),
    (("origin_accel = 3.0", "origin_accel = 1e307"), "inputs.origin_accel: must lie in"),
])
def test_broken_model_files_are_rejected_with_the_key_named(tmp_path, edit, message):
    path = tmp_path / "broken.toml"
    path.write_text(MODEL.read_text().replace(*edit, 1))
    with pytest.raises(ModelError, match=message):
        load_model(path)


def test_input_limits_follow_the_input_layout(system):
    """One limit per input, read from the file's groups (toe limits repeated per leg)."""
    limits = dict(zip(system.input_names, system.model.input_limits, strict=True))
    assert limits["a"] == 3.0 and limits["pitch_acc"] == 4.0
    assert limits["baz"] == 4.0 and limits["rr_az"] == 10.0 and limits["lf_ax"] == 10.0


def test_body_edge_row_is_the_world_frame_ssat_minus_its_margin(system):
    """The row's h, evaluated by SymEngine, against the numpy SSAT reference with the
    body pose built from the state independently (p + Rz(yaw)(bx, 0, bz), Rz Ry)."""
    import numpy as np

    from symbolic.families import ssat
    from symbolic.smoothing import LSE, XTANH
    from symbolic.tests.test_ssat_reference import random_rotation, reference_axes, reference_h

    kernel = next(k for k in _definition().kernels() if k.name == "body_edge")
    margin = ssat.margin_kernel(LSE, XTANH)
    rng = np.random.default_rng(8)
    m = system.model
    for _ in range(20):
        x = rng.normal(size=36) * 0.3
        yaw, pitch = x[3], x[8]
        rz = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]])
        ry = np.array([[np.cos(pitch), 0, np.sin(pitch)], [0, 1, 0], [-np.sin(pitch), 0, np.cos(pitch)]])
        body_c = x[0:3] + rz @ np.array([x[6], 0.0, x[7]])
        body_r = rz @ ry
        ec, er, eh = rng.uniform(-1, 1, 3), random_rotation(), rng.uniform(0.02, 0.5, 3)
        got = kernel.evaluate({"x": x, "center": ec, "rotation": er.flatten(), "half": eh})
        hb = np.array(m.body_half_extents)
        ys = reference_axes(ec, er, eh, body_c, body_r, hb, "xtanh", m.ssat_alpha, m.ssat_alpha_rot)
        want = reference_h(ys, "lse", m.ssat_alpha) - margin.evaluate(
            {"half_a": eh, "half_b": hb, "alpha": m.ssat_alpha, "alpha_rot": m.ssat_alpha_rot})["margin"][0]
        assert got["lie"][0] == pytest.approx(want, rel=1e-10, abs=1e-12)
