"""The definitions cache: an entry is reused only for the same inputs, and what comes back
is what a fresh definition gives."""

from __future__ import annotations

import pickle

import pytest
import symengine as se

from symbolic.codegen.backends.rust.emitter import emit_kernel
from symbolic.codegen.definition import define
from symbolic.definition_cache import cached, inputs_key
from symbolic.generate import all_kernels, builtin_specs
from symbolic.spec import load


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("CBFGEN_SYMBOLIC_CACHE", str(folder))
    return folder


def test_an_entry_is_reused_for_its_key_only_and_replaced_by_a_new_one(cache):
    calls = []
    x = se.Symbol("x")

    def define_once():
        calls.append(1)
        return {"h": se.tanh(x) * se.RealDouble(0.25)}

    first = cached("toy", "a", define_once)
    again = cached("toy", "a", define_once)
    assert calls == [1] and again == first and again["h"] == se.tanh(x) * se.RealDouble(0.25)
    cached("toy", "b", define_once)
    assert len(calls) == 2
    assert sorted(p.name for p in cache.iterdir()) == ["toy-b.pickle"]  # the old key's entry is gone


def test_a_damaged_entry_is_defined_again(cache):
    cache.mkdir()
    (cache / "toy-a.pickle").write_bytes(b"not a pickle")
    assert cached("toy", "a", lambda: 42) == 42
    assert pickle.loads((cache / "toy-a.pickle").read_bytes()) == 42


def test_off_stores_nothing(tmp_path, monkeypatch):
    monkeypatch.setenv("CBFGEN_SYMBOLIC_CACHE", "off")
    calls = []
    for _ in range(2):
        cached("toy", "a", lambda: calls.append(1))
    assert calls == [1, 1] and not (tmp_path / "target").exists()


def test_the_key_follows_the_specs_folder_and_the_dependencies_its_header_names(tmp_path):
    root = tmp_path / "repo"
    spec = root / "systems/robot/spec/robot.py"
    spec.parent.mkdir(parents=True)
    spec.write_text("# a spec\n")
    helper = root / "shared/facts.toml"
    helper.parent.mkdir(parents=True)
    helper.write_text("alpha = 1\n")
    generated = root / "systems/robot/generated/robot.rs"
    generated.parent.mkdir(parents=True)
    generated.write_text("// @generated\n// depends: ../../../shared/facts.toml\n")
    key = inputs_key([spec], root)
    assert inputs_key([spec], root) == key
    (spec.parent / "kinematics.py").write_text("LINKS = 3\n")  # a module beside the spec
    with_module = inputs_key([spec], root)
    assert with_module != key
    helper.write_text("alpha = 2\n")  # a dependency outside the folder, named by the header
    assert inputs_key([spec], root) != with_module


def test_cached_kernels_are_what_a_fresh_definition_emits():
    spec = next(p for p in builtin_specs() if p.stem == "double_integrator")
    fresh = define(load(spec), unrolled=True).kernels()
    kept = all_kernels()["double_integrator"]
    assert [emit_kernel(k, "cbfgen") for k in kept] == [emit_kernel(k, "cbfgen") for k in fresh]
