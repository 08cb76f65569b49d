"""The Rust module of one system: the kernels wrapped in the runtime's traits.

Given a :class:`~symbolic.codegen.definition.SystemDefinition`, this writes (for a
system ``planar_robot``, runtime path ``rt``):

* ``DOC``, ``NX``, ``NU``, ``mod state`` / ``mod input`` / ``mod family`` (named indices);
* ``struct PlanarRobot`` implementing ``rt::system::ControlAffine<NX, NU>``;
* the kernels: ``drift``, ``input_matrix`` and one row kernel per family with its
  ``<FAMILY>_RELATIVE_DEGREE`` / ``_INPUT_COLUMNS`` / ``_ROW_NAMES`` constants;
* per family with parameters ``struct <Family>Params`` (named nalgebra fields);
* ``FAMILIES``, ``struct Capacity``, ``struct Params``, ``struct Barriers`` implementing
  ``rt::system::BarrierSet<NU>``;
* ``default_settings()`` and ``type Filter`` for the generic ECBF filter;
* ``KERNELS``, the uniform kernel table.

The text must work under ``include!`` inside a ``mod`` block, so it has no inner
attributes or inner doc comments: lint allows sit on the items that need them and the
module's documentation is the ``DOC`` constant (and the system struct's doc).
"""

from __future__ import annotations

import json

from ...definition import FamilyDefinition, SystemDefinition
from .emitter import emit_kernel, float_literal, rustdoc_text
from .kernel_table import emit_kernel_table

KERNEL_ALLOWS = ("#[allow(clippy::all, clippy::pedantic, clippy::nursery, unused_parens, unused_variables, "
                 "non_snake_case)]")


def camel(name: str) -> str:
    return "".join(part.capitalize() for part in name.split("_"))


def _doc(text: str, indent: str = "") -> list[str]:
    out = []
    for line in text.strip().splitlines() or [""]:
        out.append(f"{indent}/// {rustdoc_text(line)}".rstrip())
    return out


def _str(text: str) -> str:
    """A Rust string literal (JSON escapes are valid Rust escapes for these texts)."""
    return json.dumps(text, ensure_ascii=False)


def _param_type(shape: tuple[int, ...], rt: str) -> str:
    """Through the runtime's re-export of nalgebra, so a user crate needs no nalgebra
    dependency of its own (and cannot pick a mismatched version)."""
    if shape == ():
        return "f64"
    if len(shape) == 1:
        return f"{rt}::nalgebra::SVector<f64, {shape[0]}>"
    return f"{rt}::nalgebra::SMatrix<f64, {shape[0]}, {shape[1]}>"


def _param_arg(var: str, name: str, shape: tuple[int, ...]) -> str:
    """The kernel argument for field ``name`` of ``var``: a scalar, or the flattened
    (row-major) array built element by element: no allocation, no copies beyond it."""
    if shape == ():
        return f"{var}.{name}"
    if len(shape) == 1:
        return "&[" + ", ".join(f"{var}.{name}[{i}]" for i in range(shape[0])) + "]"
    rows, cols = shape
    return "&[" + ", ".join(f"{var}.{name}[({i}, {j})]" for i in range(rows) for j in range(cols)) + "]"


def _poles(f: FamilyDefinition, rt: str) -> str:
    if len(set(f.poles)) == 1:
        return f"{rt}::system::Poles::repeated({float_literal(f.poles[0])}, {f.degree})"
    return f"{rt}::system::Poles::from_array([{', '.join(float_literal(p) for p in f.poles)}])"


def _activation(value: float) -> str:
    return "f64::INFINITY" if value == float("inf") else float_literal(value)


class _Names:
    """Every item name the module defines, so a clash is an error here, not in rustc."""

    def __init__(self, system: str):
        self.system = system
        self.seen: dict[str, str] = {}

    def add(self, name: str, what: str) -> str:
        if name in self.seen:
            from ....spec import SpecError
            raise SpecError(f"system {self.system!r}: {what} would be named `{name}`, as is "
                            f"{self.seen[name]}; rename one of them")
        self.seen[name] = what
        return name


def emit_system(d: SystemDefinition, rt: str) -> str:
    """The module text (before rustfmt), ``rt`` being the path to the runtime crate."""
    sys_type = camel(d.name)
    names = _Names(d.name)
    for item, what in [("DOC", "the module doc"), ("NX", "the state count"), ("NU", "the input count"),
                       ("state", "the state indices"), ("input", "the input indices"),
                       ("family", "the family indices"), (sys_type, "the system type"),
                       ("FAMILIES", "the family table"), ("Capacity", "the capacity type"),
                       ("Params", "the parameter type"), ("Barriers", "the barrier set"),
                       ("default_settings", "the default settings"), ("Filter", "the filter type"),
                       ("KERNELS", "the kernel table"), ("kernel_table", "the kernel wrappers"),
                       ("STATE_NAMES", "the state names"), ("INPUT_NAMES", "the input names")]:
        names.add(item, what)
    for k in d.kernels():
        names.add(k.name, f"kernel `{k.name}`")
        for c in k.constants:
            names.add(c.name, f"constant of kernel `{k.name}`")
    for f in d.families:
        if f.params:
            names.add(f"{camel(f.name)}Params", f"the parameters of family `{f.name}`")

    nx, nu = len(d.state_names), len(d.input_names)
    out: list[str] = []
    w = out.append

    # ------------------------------------------------------------ description
    doc = d.doc.strip() or f"The {d.name} system."
    w(f"/// What the `{d.name}` module is: the spec's description.")
    w(f"pub const DOC: &str = {_str(doc)};")
    w("")
    w("/// Number of states.")
    w(f"pub const NX: usize = {nx};")
    w("/// Number of inputs.")
    w(f"pub const NU: usize = {nu};")
    w("")
    for mod, what, entries, docs in [("state", "states in `x`", d.state_names, d.state_docs),
                                     ("input", "inputs in `u`", d.input_names, d.input_docs)]:
        w(f"/// Indices of the {what}.")
        w(f"pub mod {mod} {{")
        for i, (n, nd) in enumerate(zip(entries, docs, strict=True)):
            out.extend(_doc(f"`{n}`" + (f": {nd}" if nd else "."), "    "))
            w(f"    pub const {n.upper()}: usize = {i};")
        w("}")
        w("")
    w("/// Indices of the families in [`FAMILIES`] (and `RowLayout::family`).")
    w("pub mod family {")
    for i, f in enumerate(d.families):
        w(f"    /// `{f.name}`.")
        w(f"    pub const {f.name.upper()}: usize = {i};")
    w("}")
    w("")

    # ----------------------------------------------------------------- system
    out.extend(_doc(doc))
    w("///")
    w(f"/// The control-affine model x' = f(x) + g(x) u, with {nx} state{'s' * (nx != 1)} (see [`state`]) "
      f"and {nu} input{'s' * (nu != 1)} (see [`input`]).")
    w("#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]")
    w(f"pub struct {sys_type};")
    w("")
    lower = ", ".join(float_literal(lim.lower) for lim in d.input_limits)
    upper = ", ".join(float_literal(lim.upper) for lim in d.input_limits)
    w(f"impl {rt}::system::ControlAffine<NX, NU> for {sys_type} {{")
    w(f"    const NAME: &'static str = {_str(d.name)};")
    w(f"    const STATE_NAMES: [&'static str; NX] = [{', '.join(_str(n) for n in d.state_names)}];")
    w(f"    const INPUT_NAMES: [&'static str; NU] = [{', '.join(_str(n) for n in d.input_names)}];")
    w(f"    const INPUT_MIN: [f64; NU] = [{lower}];")
    w(f"    const INPUT_MAX: [f64; NU] = [{upper}];")
    w("")
    w("    fn drift(x: &[f64; NX]) -> [f64; NX] {")
    w("        self::drift(x)")
    w("    }")
    w("")
    w("    fn input_matrix(x: &[f64; NX]) -> [[f64; NU]; NX] {")
    w("        self::input_matrix(x)")
    w("    }")
    w("}")
    w("")
    w("/// State layout, as `ControlAffine::STATE_NAMES`.")
    w(f"pub const STATE_NAMES: [&str; NX] = [{', '.join(_str(n) for n in d.state_names)}];")
    w("/// Input layout, as `ControlAffine::INPUT_NAMES`.")
    w(f"pub const INPUT_NAMES: [&str; NU] = [{', '.join(_str(n) for n in d.input_names)}];")
    w("")

    # ---------------------------------------------------------------- kernels
    for k in d.kernels():
        w(emit_kernel(k, attributes=[KERNEL_ALLOWS]))

    # ------------------------------------------------------------- parameters
    for f in d.families:
        if not f.params:
            continue
        ty = f"{camel(f.name)}Params"
        out.extend(_doc(f"Parameters of one `{f.name}` instance." + (f" {f.doc.strip()}" if f.doc.strip() else "")))
        w("#[derive(Debug, Clone, Copy, PartialEq, Default)]")
        w(f"pub struct {ty} {{")
        for p in f.params:
            pdoc = p.doc or f"`{p.name}`"
            if len(p.shape) == 2:
                pdoc += f" ({p.shape[0]} x {p.shape[1]})"
            out.extend(_doc(pdoc, "    "))
            w(f"    pub {p.name}: {_param_type(p.shape, rt)},")
        w("}")
        w("")
        w(f"impl {ty} {{")
        w(f"    /// `Ok(())` when every number is finite and within `±{rt}::system::PARAM_LIMIT`.")
        w("    ///")
        w("    /// # Errors")
        w(f"    /// [`{rt}::error::CbfError::NonFinite`] or [`{rt}::error::CbfError::OutOfRange`], "
          "naming the parameter.")
        w(f"    pub fn validate(&self) -> Result<(), {rt}::error::CbfError> {{")
        for p in f.params:
            values = f"core::slice::from_ref(&self.{p.name})" if p.shape == () else f"self.{p.name}.as_slice()"
            w(f'        {rt}::system::validate_params("{f.name}.{p.name}", {values})?;')
        w("        Ok(())")
        w("    }")
        w("}")
        w("")

    # --------------------------------------------------------------- families
    w("/// The barrier families, in spec order (indexed by `RowLayout::family`, see [`family`]).")
    w(f"pub const FAMILIES: [{rt}::system::FamilyInfo; {len(d.families)}] = [")
    for f in d.families:
        u = f.name.upper()
        w(f"    {rt}::system::FamilyInfo {{")
        w(f"        name: {_str(f.name)},")
        w(f"        relative_degree: {u}_RELATIVE_DEGREE,")
        w(f"        row_names: &{u}_ROW_NAMES,")
        w(f"        defaults: {rt}::system::FamilyParams {{")
        w(f"            poles: {_poles(f, rt)},")
        w(f"            slack_weight: {float_literal(f.slack_weight)},")
        w(f"            activation: {_activation(f.activation)},")
        w("        },")
        w("    },")
    w("];")
    w("")

    cap_families = [f for f in d.families if f.capacity]
    w("/// How many instances each capacity family has room for; fixed at construction, so the")
    w("/// row layout (and the QP's sparsity) is too.")
    w("#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]")
    w("pub struct Capacity {")
    for f in cap_families:
        w(f"    /// Slots for `{f.name}` instances (at most `{rt}::system::MAX_INSTANCES`).")
        w(f"    pub {f.name}: usize,")
    w("}")
    w("")

    w("/// Every family's runtime instances: what [`Barriers`] reads besides the state and time.")
    w("#[derive(Debug, Clone, PartialEq)]")
    w("pub struct Params {")
    for f in d.families:
        if f.capacity:
            w(f"    /// The `{f.name}` instances, filled at run time up to [`Capacity::{f.name}`].")
            w(f"    pub {f.name}: {rt}::system::Instances<{camel(f.name)}Params>,")
        elif f.params:
            w(f"    /// The {f.count} `{f.name}` instance(s), always active.")
            w(f"    pub {f.name}: [{camel(f.name)}Params; {f.count}],")
    w("}")
    w("")
    w("impl Params {")
    w("    /// Default (zero) fixed instances and empty capacity families sized for `capacity`.")
    w("    ///")
    w("    /// # Errors")
    w(f"    /// [`{rt}::error::CbfError::TooLarge`] for a capacity above `{rt}::system::MAX_INSTANCES`.")
    w(f"    pub fn new(capacity: Capacity) -> Result<Self, {rt}::error::CbfError> {{")
    if not cap_families:
        w("        let _ = capacity;")
    w("        Ok(Self {")
    for f in d.families:
        if f.capacity:
            w(f'            {f.name}: {rt}::system::Instances::with_capacity("{f.name}", capacity.{f.name})?,')
        elif f.params:
            w(f"            {f.name}: [{camel(f.name)}Params::default(); {f.count}],")
    w("        })")
    w("    }")
    w("")
    w("    /// The capacities these parameters were sized for.")
    w("    pub fn capacity(&self) -> Capacity {")
    w("        Capacity {" + ", ".join(f"{f.name}: self.{f.name}.capacity()" for f in cap_families) + "}")
    w("    }")
    w("}")
    w("")

    # --------------------------------------------------------------- barriers
    w("/// The rows of every family, laid out once for a [`Capacity`] and evaluated each cycle")
    w("/// into preallocated storage. Row order: families in spec order; within a family,")
    w("/// instance by instance, the rows of one instance consecutive.")
    w("#[derive(Debug, Clone, PartialEq)]")
    w("pub struct Barriers {")
    w("    capacity: Capacity,")
    w(f"    layout: Vec<{rt}::system::RowLayout>,")
    w(f"    rows: Vec<{rt}::system::Row<NU>>,")
    w("}")
    w("")
    w("impl Barriers {")
    w("    /// Lay out the rows for `capacity`; every row starts inactive.")
    w("    ///")
    w("    /// # Errors")
    w(f"    /// [`{rt}::error::CbfError::TooLarge`] for a capacity above `{rt}::system::MAX_INSTANCES`.")
    w(f"    pub fn new(capacity: Capacity) -> Result<Self, {rt}::error::CbfError> {{")
    for f in cap_families:
        w(f"        if capacity.{f.name} > {rt}::system::MAX_INSTANCES {{")
        w(f"            return Err({rt}::error::CbfError::TooLarge {{ what: {_str(f.name)}, "
          f"value: capacity.{f.name}, max: {rt}::system::MAX_INSTANCES }});")
        w("        }")
    fixed_rows = sum(f.count * len(f.row_names) for f in d.families if not f.capacity)
    cap_rows = " + ".join(f"capacity.{f.name}" + (f" * {len(f.row_names)}" if len(f.row_names) > 1 else "")
                          for f in cap_families)
    total = " + ".join(([str(fixed_rows)] if fixed_rows else []) + ([cap_rows] if cap_rows else [])) or "0"
    w(f"        let mut layout = Vec::with_capacity({total});")
    for f in d.families:
        u = f.name.upper()
        count = f"capacity.{f.name}" if f.capacity else str(f.count)
        w(f"        for instance in 0..{count} {{")
        w(f"            for row in 0..{u}_ROW_NAMES.len() {{")
        w(f"                layout.push({rt}::system::RowLayout {{ family: family::{u}, instance, row, "
          f"columns: &{u}_INPUT_COLUMNS }});")
        w("            }")
        w("        }")
    w(f"        let rows = vec![{rt}::system::Row::ZERO; layout.len()];")
    w("        Ok(Self { capacity, layout, rows })")
    w("    }")
    w("")
    w("    /// The capacity the rows were laid out for.")
    w("    pub fn capacity(&self) -> Capacity {")
    w("        self.capacity")
    w("    }")
    w("}")
    w("")

    w(f"impl {rt}::system::BarrierSet<NU> for Barriers {{")
    w("    type State = [f64; NX];")
    w("    type Params = Params;")
    w("")
    w(f"    fn families(&self) -> &[{rt}::system::FamilyInfo] {{")
    w("        &FAMILIES")
    w("    }")
    w("")
    w(f"    fn layout(&self) -> &[{rt}::system::RowLayout] {{")
    w("        &self.layout")
    w("    }")
    w("")
    w(f"    fn rows(&self) -> &[{rt}::system::Row<NU>] {{")
    w("        &self.rows")
    w("    }")
    w("")
    w(f"    fn evaluate(&mut self, t: f64, x: &[f64; NX], params: &Params) -> Result<(), {rt}::error::CbfError> {{")
    w("        if params.capacity() != self.capacity {")
    w(f"            return Err({rt}::error::CbfError::CapacityMismatch);")
    w("        }")
    w(f"        {rt}::system::validate_state(x)?;")
    if d.time_varying:
        w(f"        {rt}::system::validate_time(t)?;")
    else:
        w("        let _ = t; // no family is time-varying")
    for f in d.families:
        if f.capacity:
            w(f"        for p in params.{f.name}.as_slice() {{")
            w("            p.validate()?;")
            w("        }")
        elif f.params:
            w(f"        for p in &params.{f.name} {{")
            w("            p.validate()?;")
            w("        }")
    w("        let mut i = 0;")
    for f in d.families:
        u = f.name.upper()
        args = ["x"] + (["t"] if f.time else []) + [_param_arg("p", p.name, p.shape) for p in f.params]
        call = f"self::{f.name}({', '.join(args)})"
        store = (f"for ((row, lie), lg) in self.rows[i..i + n].iter_mut().zip(&lie).zip(&lg) {{ "
                 f"row.store(lie, lg, &{u}_INPUT_COLUMNS); }}")
        w(f"        // {f.name}: relative degree {f.degree}, {len(f.row_names)} row(s) per instance, "
          f"{'capacity' if f.capacity else f'{f.count} fixed instance(s)'}")
        w(f"        let n = {u}_ROW_NAMES.len();")
        if f.capacity:
            w(f"        let filled = params.{f.name}.as_slice();")
            w(f"        for slot in 0..self.capacity.{f.name} {{")
            w("            if let Some(p) = filled.get(slot) {")
            w(f"                let (lie, lg) = {call};")
            w(f"                {store}")
            w("            } else {")
            w("                for row in &mut self.rows[i..i + n] { row.active = false; }")
            w("            }")
            w("            i += n;")
            w("        }")
        elif f.params:
            w(f"        for p in &params.{f.name} {{")
            w(f"            let (lie, lg) = {call};")
            w(f"            {store}")
            w("            i += n;")
            w("        }")
        else:
            w(f"        let (lie, lg) = {call};")
            w(f"        {store}")
            w("        i += n;")
    w("        debug_assert_eq!(i, self.rows.len());")
    w("        Ok(())")
    w("    }")
    w("}")
    w("")

    # ----------------------------------------------------------------- filter
    w("/// The spec's defaults: every family's poles, slack weight and activation, and the")
    w("/// input limits.")
    w(f"pub fn default_settings() -> {rt}::filter::FilterSettings<NU> {{")
    w(f"    {rt}::filter::FilterSettings::defaults(")
    w("        &FAMILIES,")
    w(f"        <{sys_type} as {rt}::system::ControlAffine<NX, NU>>::INPUT_MIN,")
    w(f"        <{sys_type} as {rt}::system::ControlAffine<NX, NU>>::INPUT_MAX,")
    w("    )")
    w("}")
    w("")
    w("/// The ECBF-QP safety filter over this system's [`Barriers`].")
    w(f"pub type Filter = {rt}::filter::EcbfFilter<Barriers, NU>;")
    w("")

    # ------------------------------------------------------------ kernel table
    w(emit_kernel_table(d.kernels(), rt, f"`{d.name}`", attributes=[KERNEL_ALLOWS]))
    return "\n".join(out) + "\n"
