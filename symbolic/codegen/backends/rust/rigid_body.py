"""A rigid-body dynamics output (``System.rigid_body_output``) as Rust: the tree in numbers
(``cbfgen::rigid_body::Body`` constants, checked when the module compiles) and the output
function reading the joint coordinates, velocities and base rotation from the state and
walking the tree with the run time's algorithms, instead of M and the bias unrolled."""

from __future__ import annotations

from collections.abc import Sequence

from ....dynamics import Tree
from ....kernel import Kernel
from .emitter import SCALAR, _doc_lines, float_literal, generic, kernel_signature


def _array(values: Sequence[float]) -> str:
    return "[" + ", ".join(float_literal(float(v)) for v in values) + "]"


def emit_rigid_body_output(kernel: Kernel, tree: Tree, order: Sequence[int], runtime_crate: str,
                           attributes: Sequence[str] = ()) -> str:
    rb = f"{runtime_crate}::rigid_body"
    upper = kernel.name.upper()
    n, nq = len(tree.velocity_states), len(tree.coordinate_states)
    bodies = []
    for b in tree.bodies:
        if b.joint == "fixed":
            joint = f"{rb}::Joint::Fixed"
        else:
            kind = "Revolute" if b.joint == "revolute" else "Prismatic"
            joint = (f"{rb}::Joint::{kind} {{ axis: {_array(b.axis)}, coordinate: {b.coordinate}, "
                     f"velocity: {b.velocity} }}")
        bodies.append(f"    {rb}::Body {{ parent: {b.parent}, rotation: {_array(b.rotation)}, "
                      f"origin: {_array(b.origin)}, joint: {joint}, mass: {float_literal(b.mass)}, "
                      f"com: {_array(b.com)}, inertia: {_array(b.inertia)} }},")
    root = "Floating" if tree.floating else "Fixed"
    out = [f"/// The rigid bodies [`{kernel.name}`] walks: one per moving joint after the root, every link "
           "rigidly attached to one merged into it (its inertial and placement).", *attributes,
           f"const {upper}_BODIES: [{rb}::Body; {len(tree.bodies)}] = [", *bodies, "];",
           f"/// The tree of [`{upper}_BODIES`], its root {'floating' if tree.floating else 'fixed'}.",
           f"const {upper}_TREE: {rb}::Tree<'static> = {rb}::Tree {{ bodies: &{upper}_BODIES, "
           f"root: {rb}::Root::{root}, gravity: {_array(tree.gravity)} }};",
           f"const _: () = assert!({upper}_TREE.defect({nq}, {n}).is_none(), "
           f"\"{kernel.name}: the generated tree cannot be walked\");", ""]
    # Generic like every kernel: on intervals it encloses M and b over a box of states
    # (what certifies a torque-controlled robot between the samples).
    args, ret = kernel_signature(kernel, runtime_crate, SCALAR)
    q = ", ".join(f"x[{i}]" for i in tree.coordinate_states)
    v = ", ".join(f"x[{i}]" for i in tree.velocity_states)
    rotation = "None"
    if tree.rotation_states is not None:
        rotation = "Some(&[" + ", ".join(f"x[{i}]" for i in tree.rotation_states) + "])"
    body = [f"    let q: [{SCALAR}; {nq}] = [{q}];", f"    let v: [{SCALAR}; {n}] = [{v}];",
            f"    let mass: [[{SCALAR}; {n}]; {n}] = {upper}_TREE.mass_matrix(&q);",
            f"    let bias: [{SCALAR}; {n}] = {upper}_TREE.bias(&q, {rotation}, &v);"]
    if tuple(order) == tuple(range(n)):
        body.append("    (mass, bias)")
    else:
        body += [f"    const ORDER: [usize; {n}] = [{', '.join(str(i) for i in order)}];",
                 "    (ORDER.map(|i| ORDER.map(|j| mass[i][j])), ORDER.map(|i| bias[i]))"]
    signature = f"pub fn {kernel.name}{generic(runtime_crate)}({args}) -> {ret} {{"
    out += [*_doc_lines(kernel), *attributes, "#[inline]", signature, *body, "}"]
    # Its cost, for a worst-case bound: counted, not printed, as the walk is not a straight
    # line here; it branches on the tree alone, so one call's count is every call's.
    counted = f"{runtime_crate}::ops::Counted"
    n_x = len(next(inp for inp in kernel.inputs if inp.name == "x").symbols)
    out += [f"/// What one call of [`{kernel.name}`] performs: it walks its tree with branches on the tree "
            "alone, never on the numbers, so one call on numbers that count "
            f"(`{counted}`) counts every call's. What `{runtime_crate}::torque::JointTorque::with_dynamics_ops` "
            "takes.",
            f"pub fn {kernel.name}_ops() -> {runtime_crate}::ops::OpCount {{",
            f"    {counted}::measure(|| {kernel.name}(&[{counted}(0.0); {n_x}])).1", "}"]
    return "\n".join(out) + "\n"
