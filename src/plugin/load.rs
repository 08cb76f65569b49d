//! The loader's side: a plugin opened, checked, and wrapped in the type-erased traits.

use std::any::Any;
use std::path::Path;
use std::time::Duration;

use super::convert::{cause, domain, family_params, family_params_c, read_error, safety, solver, solver_c, static_str};
use super::{
    decode, dynamics_op, store_op, CauseC, ErrorC, FamilyParamsC, Handle, PluginV1, ReportC, RowC, RowLayoutC,
    SettingsC, SlotC, WorstCaseC, ABI_VERSION, BACKENDS, ENTRY_POINT, INPUT_SOURCES, QP_STATUSES,
};
use crate::dynamic::{
    CapacityCount, DynBarriers, DynFilter, DynParams, DynRows, DynSettings, DynSystem, FamilyStore, RowView,
};
use crate::error::CbfError;
use crate::filter::{Calibration, Cause, FamilyRelaxation, InputSource, Output, Verdict, WorstCase};
use crate::param_domain::Domain;
use crate::system::{
    find_kernel, ClassK, FamilyInfo, FamilyKind, FamilyParams, InstanceKind, KernelSignature, RowLayout,
};

fn plugin_error(message: String) -> CbfError {
    CbfError::Plugin { message }
}

/// Open the plugin at `path` (a shared library built with [`crate::export_plugin!`]), check
/// its ABI and core versions, and return its system. The library stays loaded for the rest
/// of the process; loading the same file again returns a second, equal system.
///
/// # Errors
/// [`CbfError::Plugin`]: the file cannot be opened (the loader's message), has no
/// `cbfgen_plugin_v1`, or was built for another ABI or core version (rebuild it).
pub fn load(path: &Path) -> Result<&'static dyn DynSystem, CbfError> {
    let table = open(path)?;
    if table.abi_version != ABI_VERSION {
        return Err(plugin_error(format!(
            "{}: plugin ABI version {}, this cbfgen reads version {ABI_VERSION}: rebuild the plugin",
            path.display(),
            table.abi_version
        )));
    }
    // SAFETY: the table's strings are the plugin's statics.
    let core = unsafe { static_str(table.core_version) };
    if core != env!("CARGO_PKG_VERSION") {
        return Err(plugin_error(format!(
            "{}: built against cbfgen {core}, this is cbfgen {}: rebuild the plugin",
            path.display(),
            env!("CARGO_PKG_VERSION")
        )));
    }
    // SAFETY: a table of this ABI_VERSION, checked; its description is static in the plugin.
    Ok(Box::leak(Box::new(unsafe { PluginSystem::new(table) })))
}

#[cfg(unix)]
fn open(path: &Path) -> Result<&'static PluginV1, CbfError> {
    use std::ffi::{CStr, CString};
    use std::os::unix::ffi::OsStrExt;

    let last_error = || {
        // SAFETY: dlerror returns null or a C string valid until the next dl call.
        let e = unsafe { libc::dlerror() };
        if e.is_null() {
            "unknown error".to_string()
        } else {
            unsafe { CStr::from_ptr(e) }.to_string_lossy().into_owned()
        }
    };
    let name = CString::new(path.as_os_str().as_bytes())
        .map_err(|_| plugin_error(format!("{}: a path with a NUL byte", path.display())))?;
    // SAFETY: a valid C string; the handle is never closed (the system is 'static).
    let lib = unsafe { libc::dlopen(name.as_ptr(), libc::RTLD_NOW | libc::RTLD_LOCAL) };
    if lib.is_null() {
        return Err(plugin_error(format!("cannot load plugin {}: {}", path.display(), last_error())));
    }
    let symbol = CString::new(ENTRY_POINT).expect("no NUL in the entry point's name");
    // SAFETY: an open library and a valid name.
    let entry = unsafe { libc::dlsym(lib, symbol.as_ptr()) };
    if entry.is_null() {
        return Err(plugin_error(format!("{} is not a cbfgen plugin: no {ENTRY_POINT}", path.display())));
    }
    // SAFETY: the symbol is the plugin's `extern "C" fn() -> *const PluginV1` (the name is
    // reserved for it); the table is a static of the library, which stays loaded.
    let entry: extern "C" fn() -> *const PluginV1 = unsafe { std::mem::transmute(entry) };
    unsafe { entry().as_ref() }.ok_or_else(|| plugin_error(format!("{}: no entry table", path.display())))
}

#[cfg(not(unix))]
fn open(path: &Path) -> Result<&'static PluginV1, CbfError> {
    Err(plugin_error(format!("{}: plugins load on Unix-like systems only", path.display())))
}

/// # Safety
/// `p` points to `n` values that live as long as the process (or `n` is 0).
unsafe fn statics<T>(p: *const T, n: usize) -> &'static [T] {
    if n == 0 {
        return &[];
    }
    // SAFETY: as the caller promises.
    unsafe { std::slice::from_raw_parts(p, n) }
}

/// What a host-side [`ClassK`] of a plugin's family evaluates: never called (the plugin's
/// filter evaluates its own α); NaN if it ever were, so nothing could pass for safe.
fn evaluated_in_the_plugin(_: f64) -> f64 {
    f64::NAN
}

/// A plugin's system, described on this side, run on the plugin's.
struct PluginSystem {
    table: &'static PluginV1,
    name: &'static str,
    doc: &'static str,
    nx: usize,
    nu: usize,
    state_names: &'static [&'static str],
    input_names: &'static [&'static str],
    input_min: &'static [f64],
    input_max: &'static [f64],
    families: &'static [FamilyInfo],
    /// Per family: each parameter's name and domain.
    domains: Vec<&'static [(&'static str, Domain)]>,
    /// The plugin's kernels, in its order (the index [`PluginV1::kernel_call`] takes).
    kernels: Vec<KernelSignature>,
}

impl PluginSystem {
    /// # Safety
    /// `table` is a checked table of a loaded plugin, of this [`ABI_VERSION`].
    unsafe fn new(table: &'static PluginV1) -> Self {
        // SAFETY: everything the description points at is static in the plugin.
        unsafe {
            let d = &*(table.describe)();
            let strs =
                |p, n| -> &'static [&'static str] { Vec::leak(statics(p, n).iter().map(|s| static_str(*s)).collect()) };
            let mut domains = Vec::new();
            let mut families = Vec::new();
            for f in statics(d.families, d.n_families) {
                let params = statics(f.params, f.n_params);
                let shapes: Vec<(&'static str, &'static [usize])> =
                    params.iter().map(|p| (static_str(p.name), statics(p.shape, p.rank))).collect();
                domains.push(&*Vec::leak(params.iter().map(|p| (static_str(p.name), domain(p.domain))).collect()));
                let class_k = static_str(f.defaults.class_k);
                let class_k = if class_k == ClassK::LINEAR.name() {
                    ClassK::LINEAR
                } else {
                    ClassK::extended(class_k, evaluated_in_the_plugin)
                };
                let defaults = family_params(&f.defaults, std::iter::once(class_k)).unwrap_or(FamilyParams {
                    poles: crate::system::Poles::repeated(10.0, f.relative_degree),
                    priority: f.defaults.priority,
                    activation: f.defaults.activation,
                    class_k,
                });
                families.push(FamilyInfo {
                    name: static_str(f.name),
                    kind: if f.kind == 1 { FamilyKind::Lyapunov } else { FamilyKind::Barrier },
                    relative_degree: f.relative_degree,
                    row_names: strs(f.row_names, f.n_row_names),
                    members: strs(f.members, f.n_members),
                    instances: match f.instances {
                        0 => InstanceKind::Fixed,
                        1 => InstanceKind::Optional,
                        _ => InstanceKind::Capacity,
                    },
                    count: f.count,
                    params: Vec::leak(shapes),
                    defaults,
                });
            }
            let slots = |p: *const SlotC, n| -> &'static [(&'static str, usize)] {
                Vec::leak(statics(p, n).iter().map(|s| (static_str(s.name), s.len)).collect())
            };
            let kernels = statics(d.kernels, d.n_kernels)
                .iter()
                .map(|k| KernelSignature {
                    name: static_str(k.name),
                    inputs: slots(k.inputs, k.n_inputs),
                    outputs: slots(k.outputs, k.n_outputs),
                })
                .collect();
            Self {
                table,
                name: static_str(d.name),
                doc: static_str(d.doc),
                nx: d.nx,
                nu: d.nu,
                state_names: strs(d.state_names, d.nx),
                input_names: strs(d.input_names, d.nu),
                input_min: statics(d.input_min, d.nu),
                input_max: statics(d.input_max, d.nu),
                families: Vec::leak(families),
                domains,
                kernels,
            }
        }
    }

    fn check_len(what: &'static str, expected: usize, got: usize) -> Result<(), CbfError> {
        if expected == got {
            Ok(())
        } else {
            Err(CbfError::LengthMismatch { what, expected, got })
        }
    }

    /// The plugin's dynamics `op` at `x` (and `u`, for `XDOT`) into `out`.
    fn dynamics(&self, op: u32, x: &[f64], u: &[f64], out: &mut [f64]) -> Result<(), CbfError> {
        let mut err = ErrorC::new();
        // SAFETY: the slices' own pointers and lengths (the plugin checks them).
        let status = unsafe {
            (self.table.dynamics)(op, x.as_ptr(), x.len(), u.as_ptr(), u.len(), out.as_mut_ptr(), out.len(), &mut err)
        };
        self.call(status.into(), &err).map(drop)
    }

    /// `params` as this system's own.
    fn own<'a>(&self, params: &'a dyn DynParams) -> Result<&'a PluginParams, CbfError> {
        params
            .as_any()
            .downcast_ref::<PluginParams>()
            .filter(|p| std::ptr::eq(p.system, self))
            .ok_or(CbfError::SystemMismatch { expected: self.name, got: params.system() })
    }

    fn call(&self, status: i64, err: &ErrorC) -> Result<i64, CbfError> {
        if status < 0 {
            Err(read_error(err))
        } else {
            Ok(status)
        }
    }

    fn handle(&self, h: Handle, err: &ErrorC) -> Result<Handle, CbfError> {
        if h.is_null() {
            Err(read_error(err))
        } else {
            Ok(h)
        }
    }

    /// The rows' layout of a barrier set or filter handle (columns static in the plugin).
    fn layout(&self, rows: Handle, filter: bool) -> Vec<RowLayout> {
        // SAFETY: a live handle of that kind.
        let n = unsafe { (self.table.rows_len)(rows, filter) };
        (0..n)
            .map(|i| {
                let mut l =
                    RowLayoutC { family: 0, member: 0, instance: 0, row: 0, columns: std::ptr::null(), n_columns: 0 };
                // SAFETY: i < n; the columns are the plugin's statics.
                unsafe { (self.table.layout)(rows, filter, i, &mut l) };
                let columns = unsafe { statics(l.columns, l.n_columns) };
                RowLayout { family: l.family, member: l.member, instance: l.instance, row: l.row, columns }
            })
            .collect()
    }

    fn row(&self, rows: Handle, filter: bool, i: usize) -> Option<RowView<'_>> {
        let mut r = RowC { lie: std::ptr::null(), lg: std::ptr::null(), active: false, culled: false };
        // SAFETY: a live handle; the row's data stay put until the object is next evaluated,
        // which needs `&mut` of its owner, so not while this borrow lives.
        if !unsafe { (self.table.row)(rows, filter, i, &mut r) } {
            return None;
        }
        Some(RowView {
            lie: unsafe { &*r.lie.cast::<[f64; crate::system::MAX_RELATIVE_DEGREE + 1]>() },
            lg: unsafe { statics(r.lg, self.nu) },
            active: r.active,
            culled: r.culled,
        })
    }

    /// Buffers for one settings exchange, and their C view.
    fn settings_buffers(&self) -> (Vec<FamilyParamsC>, [Vec<f64>; 3]) {
        let family = family_params_c(&self.families.first().map_or(
            FamilyParams {
                poles: crate::system::Poles::repeated(1.0, 1),
                priority: 0,
                activation: f64::INFINITY,
                class_k: ClassK::LINEAR,
            },
            |f| f.defaults,
        ));
        (vec![family; self.families.len()], [vec![0.0; self.nu], vec![0.0; self.nu], vec![0.0; self.nu]])
    }

    fn read_settings(&self, families: &[FamilyParamsC], inputs: &[Vec<f64>; 3], c: &SettingsC) -> DynSettings {
        let known = |_: usize| self.families.iter().map(|f| f.defaults.class_k);
        DynSettings {
            families: families
                .iter()
                .enumerate()
                // SAFETY: the names point into the plugin's statics.
                .map(|(i, p)| unsafe { family_params(p, known(i)) }.unwrap_or(self.families[i].defaults))
                .collect(),
            input_weights: inputs[0].clone(),
            input_min: inputs[1].clone(),
            input_max: inputs[2].clone(),
            solver: solver(&c.solver),
            measure_cpu_time: c.measure_cpu_time,
            cull_far_rows: c.cull_far_rows,
            sampled_data: None,
        }
    }

    /// The plugin's settings read by `fill` (its defaults, or a filter's) into buffers sized
    /// from the description (which the plugin checks: `fill` cannot fail on them).
    fn settings_from(&self, fill: impl FnOnce(*mut SettingsC, *mut ErrorC) -> i32) -> DynSettings {
        let (mut families, mut inputs) = self.settings_buffers();
        let mut c = SettingsC {
            n_families: families.len(),
            n_inputs: self.nu,
            families: families.as_mut_ptr(),
            input_weights: inputs[0].as_mut_ptr(),
            input_min: inputs[1].as_mut_ptr(),
            input_max: inputs[2].as_mut_ptr(),
            solver: solver_c(&crate::qp::SolverSettings::default()),
            measure_cpu_time: false,
            cull_far_rows: true,
        };
        let mut err = ErrorC::new();
        let status = fill(&mut c, &mut err);
        debug_assert_eq!(status, 0, "settings buffers sized from the description");
        self.read_settings(&families, &inputs, &c)
    }
}

// SAFETY: the table is thread-safe (see PluginV1); the rest is immutable plain data.
unsafe impl Sync for PluginSystem {}
unsafe impl Send for PluginSystem {}

impl DynSystem for PluginSystem {
    fn name(&self) -> &'static str {
        self.name
    }
    fn doc(&self) -> &'static str {
        self.doc
    }
    fn nx(&self) -> usize {
        self.nx
    }
    fn nu(&self) -> usize {
        self.nu
    }
    fn state_names(&self) -> &'static [&'static str] {
        self.state_names
    }
    fn input_names(&self) -> &'static [&'static str] {
        self.input_names
    }
    fn input_min(&self) -> &'static [f64] {
        self.input_min
    }
    fn input_max(&self) -> &'static [f64] {
        self.input_max
    }
    fn families(&self) -> &'static [FamilyInfo] {
        self.families
    }
    fn drift(&self, x: &[f64], f: &mut [f64]) -> Result<(), CbfError> {
        Self::check_len("state", self.nx, x.len())?;
        Self::check_len("drift output", self.nx, f.len())?;
        self.dynamics(dynamics_op::DRIFT, x, &[], f)
    }
    fn input_matrix(&self, x: &[f64], g: &mut [f64]) -> Result<(), CbfError> {
        Self::check_len("state", self.nx, x.len())?;
        Self::check_len("input matrix output", self.nx * self.nu, g.len())?;
        self.dynamics(dynamics_op::INPUT_MATRIX, x, &[], g)
    }
    fn xdot(&self, x: &[f64], u: &[f64], xdot: &mut [f64]) -> Result<(), CbfError> {
        Self::check_len("state", self.nx, x.len())?;
        Self::check_len("input", self.nu, u.len())?;
        Self::check_len("xdot output", self.nx, xdot.len())?;
        self.dynamics(dynamics_op::XDOT, x, u, xdot)
    }
    fn params(&self, capacity: &[CapacityCount]) -> Result<Box<dyn DynParams>, CbfError> {
        let mut err = ErrorC::new();
        // SAFETY: `capacity.len()` counts.
        let h = unsafe { (self.table.params_new)(capacity.as_ptr(), capacity.len(), &mut err) };
        Ok(Box::new(PluginParams::new(self.leaked(), self.handle(h, &err)?)))
    }
    fn barriers_for(&self, params: &dyn DynParams) -> Result<Box<dyn DynBarriers>, CbfError> {
        let p = self.own(params)?;
        let mut err = ErrorC::new();
        // SAFETY: a live parameters handle of this plugin.
        let h = self.handle(unsafe { (self.table.barriers_new)(p.handle, &mut err) }, &err)?;
        Ok(Box::new(PluginBarriers { system: self.leaked(), handle: h, layout: self.layout(h, false) }))
    }
    fn kernels(&self) -> Vec<KernelSignature> {
        self.kernels.clone()
    }
    fn call_kernel(&self, name: &str, inputs: &[f64], outputs: &mut [f64]) -> Result<(), CbfError> {
        let (index, signature) = find_kernel(self.name, &self.kernels, name)?;
        signature.check_lengths(inputs, outputs)?;
        let mut err = ErrorC::new();
        // SAFETY: the slices' own pointers and lengths.
        let status = unsafe {
            (self.table.kernel_call)(
                index,
                inputs.as_ptr(),
                inputs.len(),
                outputs.as_mut_ptr(),
                outputs.len(),
                &mut err,
            )
        };
        self.call(status.into(), &err).map(drop)
    }
    fn default_settings(&self) -> DynSettings {
        // SAFETY: buffers sized from the description.
        self.settings_from(|c, err| unsafe { (self.table.default_settings)(c, err) })
    }
    fn filter(&self, capacity: &[CapacityCount], settings: &DynSettings) -> Result<Box<dyn DynFilter>, CbfError> {
        Self::check_len("family settings", self.families.len(), settings.families.len())?;
        Self::check_len("input_weights", self.nu, settings.input_weights.len())?;
        Self::check_len("input_min", self.nu, settings.input_min.len())?;
        Self::check_len("input_max", self.nu, settings.input_max.len())?;
        if settings.sampled_data.is_some() {
            // Refused, not dropped: a filter built without the certificate it was asked for
            // would report safety between the samples it never checked.
            return Err(CbfError::Unsupported {
                operation: "sampled-data certificate (not in the plugin ABI)",
                kind: "plugin",
            });
        }
        let mut families: Vec<FamilyParamsC> = settings.families.iter().map(family_params_c).collect();
        let mut inputs = [settings.input_weights.clone(), settings.input_min.clone(), settings.input_max.clone()];
        let c = SettingsC {
            n_families: families.len(),
            n_inputs: self.nu,
            families: families.as_mut_ptr(),
            input_weights: inputs[0].as_mut_ptr(),
            input_min: inputs[1].as_mut_ptr(),
            input_max: inputs[2].as_mut_ptr(),
            solver: solver_c(&settings.solver),
            measure_cpu_time: settings.measure_cpu_time,
            cull_far_rows: settings.cull_far_rows,
        };
        let mut err = ErrorC::new();
        // SAFETY: buffers sized as checked above; `capacity.len()` counts.
        let h = unsafe { (self.table.filter_new)(capacity.as_ptr(), capacity.len(), &c, &mut err) };
        let h = self.handle(h, &err)?;
        let layout = self.layout(h, true);
        let rows = layout.len();
        let mut filter = PluginFilter {
            system: self.leaked(),
            handle: h,
            layout,
            u: vec![0.0; self.nu],
            active: vec![false; rows],
            delta: vec![0.0; rows],
            margins: vec![0.0; rows],
            relative: vec![0.0; rows],
            causes: vec![CauseC::default(); rows],
            relaxed: vec![None; rows],
            relaxation: vec![FamilyRelaxation::default(); self.families.len()],
            output: Output::before_any_update(()),
        };
        filter.refresh();
        Ok(Box::new(filter))
    }
}

impl PluginSystem {
    /// This system as the `'static` it is ([`load`] leaks it).
    fn leaked(&self) -> &'static PluginSystem {
        // SAFETY: every PluginSystem is created by `load` and leaked, never dropped.
        unsafe { &*(self as *const PluginSystem) }
    }
}

/// A plugin's parameters: its handle, and one proxy per family (member) that has any.
struct PluginParams {
    system: &'static PluginSystem,
    handle: Handle,
    stores: Vec<PluginStore>,
}

// SAFETY: the plugin's parameters are `Send + Sync` (DynParams); the handle only moves them.
unsafe impl Send for PluginParams {}
unsafe impl Sync for PluginParams {}

impl PluginParams {
    fn new(system: &'static PluginSystem, handle: Handle) -> Self {
        let mut stores = Vec::new();
        for (family, f) in system.families.iter().enumerate() {
            if f.params.is_empty() {
                continue;
            }
            let width = f.params.iter().map(|(_, shape)| shape.iter().product::<usize>()).sum();
            for member in 0..f.members.len().max(1) {
                stores.push(PluginStore {
                    system,
                    params: handle,
                    family,
                    member,
                    kind: f.instances,
                    width,
                    domains: system.domains[family],
                });
            }
        }
        Self { system, handle, stores }
    }

    fn missing(&self, family: usize, member: usize) -> CbfError {
        let mut err = ErrorC::new();
        // SAFETY: a live handle; EXISTS reads nothing.
        let status = unsafe {
            (self.system.table.store)(
                self.handle,
                store_op::EXISTS,
                family,
                member,
                0,
                std::ptr::null_mut(),
                0,
                false,
                &mut err,
            )
        };
        if status < 0 {
            read_error(&err)
        } else {
            CbfError::NoSuchIndex { what: "family", index: family, len: self.system.families.len() }
        }
    }
}

impl Drop for PluginParams {
    fn drop(&mut self) {
        // SAFETY: our handle, freed once.
        unsafe { (self.system.table.params_free)(self.handle) }
    }
}

impl DynParams for PluginParams {
    fn system(&self) -> &'static str {
        self.system.name
    }
    fn families(&self) -> &'static [FamilyInfo] {
        self.system.families
    }
    fn store(&self, family: usize, member: usize) -> Result<&dyn FamilyStore, CbfError> {
        match self.stores.iter().find(|s| (s.family, s.member) == (family, member)) {
            Some(s) => Ok(s),
            None => Err(self.missing(family, member)),
        }
    }
    fn store_mut(&mut self, family: usize, member: usize) -> Result<&mut dyn FamilyStore, CbfError> {
        match self.stores.iter().position(|s| (s.family, s.member) == (family, member)) {
            Some(i) => Ok(&mut self.stores[i]),
            None => Err(self.missing(family, member)),
        }
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
    fn clone_box(&self) -> Box<dyn DynParams> {
        // SAFETY: a live handle (so the clone fails only if the plugin panics; a null
        // handle then makes every later call an error, not undefined behaviour).
        let mut err = ErrorC::new();
        let h = unsafe { (self.system.table.params_clone)(self.handle, &mut err) };
        Box::new(PluginParams::new(self.system, h))
    }
}

/// One family's (member's) instances in a plugin's parameters.
struct PluginStore {
    system: &'static PluginSystem,
    params: Handle,
    family: usize,
    member: usize,
    kind: InstanceKind,
    width: usize,
    domains: &'static [(&'static str, Domain)],
}

// SAFETY: as PluginParams, which owns the handle.
unsafe impl Send for PluginStore {}
unsafe impl Sync for PluginStore {}

impl PluginStore {
    fn op(&self, op: u32, instance: usize, values: *mut f64, len: usize, flag: bool) -> Result<i64, CbfError> {
        let mut err = ErrorC::new();
        // SAFETY: a live handle; `values` holds `len` numbers.
        let status = unsafe {
            (self.system.table.store)(self.params, op, self.family, self.member, instance, values, len, flag, &mut err)
        };
        self.system.call(status, &err)
    }
}

impl FamilyStore for PluginStore {
    fn kind(&self) -> InstanceKind {
        self.kind
    }
    fn width(&self) -> usize {
        self.width
    }
    fn domains(&self) -> &'static [(&'static str, Domain)] {
        self.domains
    }
    fn slots(&self) -> usize {
        self.op(store_op::SLOTS, 0, std::ptr::null_mut(), 0, false).unwrap_or(0) as usize
    }
    fn len(&self) -> usize {
        self.op(store_op::LEN, 0, std::ptr::null_mut(), 0, false).unwrap_or(0) as usize
    }
    fn get(&self, instance: usize, out: &mut [f64]) -> Result<bool, CbfError> {
        Ok(self.op(store_op::GET, instance, out.as_mut_ptr(), out.len(), false)? == 1)
    }
    fn set(&mut self, instance: usize, values: &[f64]) -> Result<(), CbfError> {
        // The plugin only reads `values` for SET and PUSH.
        self.op(store_op::SET, instance, values.as_ptr().cast_mut(), values.len(), false).map(drop)
    }
    fn push(&mut self, values: &[f64]) -> Result<(), CbfError> {
        self.op(store_op::PUSH, 0, values.as_ptr().cast_mut(), values.len(), false).map(drop)
    }
    fn remove(&mut self, instance: usize) -> Result<(), CbfError> {
        self.op(store_op::REMOVE, instance, std::ptr::null_mut(), 0, false).map(drop)
    }
    fn clear(&mut self) -> Result<(), CbfError> {
        self.op(store_op::CLEAR, 0, std::ptr::null_mut(), 0, false).map(drop)
    }
    fn set_enabled(&mut self, enabled: bool) -> Result<(), CbfError> {
        self.op(store_op::SET_ENABLED, 0, std::ptr::null_mut(), 0, enabled).map(drop)
    }
    fn is_enabled(&self) -> bool {
        self.op(store_op::IS_ENABLED, 0, std::ptr::null_mut(), 0, false).unwrap_or(0) == 1
    }
}

/// A plugin's barrier set.
struct PluginBarriers {
    system: &'static PluginSystem,
    handle: Handle,
    layout: Vec<RowLayout>,
}

// SAFETY: the plugin's barrier set is `Send` (DynBarriers).
unsafe impl Send for PluginBarriers {}

impl Drop for PluginBarriers {
    fn drop(&mut self) {
        // SAFETY: our handle, freed once.
        unsafe { (self.system.table.barriers_free)(self.handle) }
    }
}

impl DynRows for PluginBarriers {
    fn families(&self) -> &'static [FamilyInfo] {
        self.system.families
    }
    fn layout(&self) -> &[RowLayout] {
        &self.layout
    }
    fn row(&self, i: usize) -> Option<RowView<'_>> {
        self.system.row(self.handle, false, i)
    }
}

impl DynBarriers for PluginBarriers {
    fn evaluate(&mut self, t: f64, x: &[f64], params: &dyn DynParams) -> Result<(), CbfError> {
        PluginSystem::check_len("state", self.system.nx, x.len())?;
        let p = self.system.own(params)?;
        let mut err = ErrorC::new();
        // SAFETY: live handles of this plugin; `x` checked.
        let status =
            unsafe { (self.system.table.barriers_evaluate)(self.handle, t, x.as_ptr(), x.len(), p.handle, &mut err) };
        self.system.call(status.into(), &err).map(drop)
    }
}

/// A plugin's filter, with this side's copy of its last report.
struct PluginFilter {
    system: &'static PluginSystem,
    handle: Handle,
    layout: Vec<RowLayout>,
    u: Vec<f64>,
    active: Vec<bool>,
    delta: Vec<f64>,
    relative: Vec<f64>,
    causes: Vec<CauseC>,
    relaxed: Vec<Option<Cause>>,
    relaxation: Vec<FamilyRelaxation>,
    /// All 0: a plugin's filter never certifies between the samples (not in the ABI).
    margins: Vec<f64>,
    output: Output<()>,
}

// SAFETY: the plugin's filter is `Send` (DynFilter).
unsafe impl Send for PluginFilter {}

impl Drop for PluginFilter {
    fn drop(&mut self) {
        // SAFETY: our handle, freed once.
        unsafe { (self.system.table.filter_free)(self.handle) }
    }
}

impl PluginFilter {
    /// Copy the plugin's last report into this side's buffers (no allocation).
    fn refresh(&mut self) {
        let mut r = ReportC {
            n_u: self.u.len(),
            n_rows: self.active.len(),
            n_families: self.relaxation.len(),
            u: self.u.as_mut_ptr(),
            active: self.active.as_mut_ptr(),
            delta: self.delta.as_mut_ptr(),
            relative: self.relative.as_mut_ptr(),
            causes: self.causes.as_mut_ptr(),
            relaxation: self.relaxation.as_mut_ptr(),
            source: 0,
            status: -1,
            backend: -1,
            dense_steps: 0,
            dense_fallback: false,
            elastic_stages: 0,
            nonfinite_row: -1,
            iterations: 0,
            polished: false,
            active_rows: 0,
            safety: Default::default(),
            convergence: Default::default(),
            consecutive_fallbacks: 0,
            work: Default::default(),
            eval_time_ns: 0,
            solve_time_ns: 0,
            cpu_time_ns: -1,
        };
        // SAFETY: a live filter handle; every buffer sized for its rows, families, inputs.
        let mut err = ErrorC::new();
        let status = unsafe { (self.system.table.filter_report)(self.handle, &mut r, &mut err) };
        debug_assert_eq!(status, 0, "report buffers sized from the filter's layout");
        for (out, c) in self.relaxed.iter_mut().zip(&self.causes) {
            *out = cause(*c);
        }
        let o = &mut self.output;
        o.source = decode(&INPUT_SOURCES, r.source.into()).unwrap_or(InputSource::NominalClipped);
        o.status = decode(&QP_STATUSES, r.status.into());
        o.backend = decode(&BACKENDS, r.backend.into());
        o.dense_steps = r.dense_steps;
        o.dense_fallback = r.dense_fallback;
        o.elastic_stages = r.elastic_stages;
        o.nonfinite_row = usize::try_from(r.nonfinite_row).ok();
        o.iterations = r.iterations;
        o.polished = r.polished;
        o.active_rows = r.active_rows;
        o.safety = safety(&r.safety);
        o.convergence = safety(&r.convergence);
        o.consecutive_fallbacks = r.consecutive_fallbacks;
        o.work = r.work;
        o.eval_time = Duration::from_nanos(r.eval_time_ns);
        o.solve_time = Duration::from_nanos(r.solve_time_ns);
        o.cpu_time = u64::try_from(r.cpu_time_ns).ok().map(Duration::from_nanos);
    }
}

impl DynRows for PluginFilter {
    fn families(&self) -> &'static [FamilyInfo] {
        self.system.families
    }
    fn layout(&self) -> &[RowLayout] {
        &self.layout
    }
    fn row(&self, i: usize) -> Option<RowView<'_>> {
        self.system.row(self.handle, true, i)
    }
}

impl DynFilter for PluginFilter {
    fn update(&mut self, t: f64, x: &[f64], u_ref: &[f64], params: &dyn DynParams) -> Result<(), CbfError> {
        PluginSystem::check_len("state", self.system.nx, x.len())?;
        PluginSystem::check_len("nominal input", self.system.nu, u_ref.len())?;
        let p = self.system.own(params)?;
        let mut err = ErrorC::new();
        // SAFETY: live handles of this plugin; lengths checked.
        let status = unsafe {
            (self.system.table.filter_update)(
                self.handle,
                t,
                x.as_ptr(),
                x.len(),
                u_ref.as_ptr(),
                u_ref.len(),
                p.handle,
                self.u.as_mut_ptr(),
                self.u.len(),
                &mut err,
            )
        };
        self.system.call(status.into(), &err)?;
        self.refresh();
        Ok(())
    }
    fn output(&self) -> Output<&[f64]> {
        self.output.map_input(|_| self.u.as_slice())
    }
    fn input(&self) -> &[f64] {
        &self.u
    }
    fn verdict(&self) -> Verdict {
        self.output.safety.verdict
    }
    fn fallback_input(&self, u_ref: &[f64], out: &mut [f64]) -> Result<(), CbfError> {
        PluginSystem::check_len("nominal input", self.system.nu, u_ref.len())?;
        PluginSystem::check_len("fallback output", self.system.nu, out.len())?;
        let mut err = ErrorC::new();
        // SAFETY: a live filter handle; lengths checked.
        let status = unsafe {
            (self.system.table.filter_fallback)(
                self.handle,
                u_ref.as_ptr(),
                u_ref.len(),
                out.as_mut_ptr(),
                out.len(),
                &mut err,
            )
        };
        self.system.call(status.into(), &err).map(drop)
    }
    fn active(&self) -> &[bool] {
        &self.active
    }
    fn delta(&self) -> &[f64] {
        &self.delta
    }
    fn relative_slack(&self) -> &[f64] {
        &self.relative
    }
    fn relaxed(&self) -> &[Option<Cause>] {
        &self.relaxed
    }
    fn relaxation(&self) -> &[FamilyRelaxation] {
        &self.relaxation
    }
    fn margins(&self) -> &[f64] {
        &self.margins
    }
    fn settings(&self) -> DynSettings {
        // SAFETY: a live filter handle; buffers sized from the description.
        self.system.settings_from(|c, err| unsafe { (self.system.table.filter_settings)(self.handle, c, err) })
    }
    fn worst_case(&self) -> WorstCase {
        let (mut out, mut err) = (WorstCaseC::default(), ErrorC::new());
        // SAFETY: a live filter handle; `out` one value (so the call cannot fail).
        unsafe { (self.system.table.filter_worst_case)(self.handle, &mut out, &mut err) };
        out.into()
    }
    fn calibrate(&mut self, t: f64, x: &[f64], params: &dyn DynParams) -> Result<Calibration, CbfError> {
        PluginSystem::check_len("state", self.system.nx, x.len())?;
        let p = self.system.own(params)?;
        let (mut out, mut err) = (Calibration::default(), ErrorC::new());
        // SAFETY: live handles of this plugin; the state's length checked; `out` one value.
        let status = unsafe {
            (self.system.table.filter_calibrate)(self.handle, t, x.as_ptr(), x.len(), p.handle, &mut out, &mut err)
        };
        self.system.call(status.into(), &err)?;
        Ok(out)
    }
}
