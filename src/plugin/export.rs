//! The plugin's side: [`PluginV1`]'s entry points over the plugin's one `DynSystem`.
//!
//! Handles are `Box<Box<dyn …>>` turned into raw pointers: the outer box gives a thin
//! pointer to hand across, the inner one is the type-erased object.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::ptr;
use std::sync::OnceLock;

use super::convert::{cause_c, domain_c, family_params, family_params_c, safety_c, solver, solver_c, write_error};
use super::{
    code, dynamics_op, store_op, DescriptionC, ErrorC, FamilyC, Handle, KernelC, ParamC, PluginV1, ReportC, RowC,
    RowLayoutC, SettingsC, SlotC, StrC, WorstCaseC, ABI_VERSION, BACKENDS, INPUT_SOURCES, QP_STATUSES,
};
use crate::dynamic::{CapacityCount, DynBarriers, DynFilter, DynParams, DynRows, DynSettings, DynSystem};
use crate::error::CbfError;
use crate::system::{FamilyKind, InstanceKind};

/// The one system this plugin exports (set by [`export`]).
static SYSTEM: OnceLock<&'static dyn DynSystem> = OnceLock::new();

fn system() -> &'static dyn DynSystem {
    *SYSTEM.get().expect("export() sets the system before the table is handed out")
}

/// The entry table of a plugin exporting `system`: what [`crate::export_plugin!`]'s
/// `cbfgen_plugin_v1` returns. A plugin exports one system; later calls keep the first.
pub fn export(system: &'static dyn DynSystem) -> &'static PluginV1 {
    SYSTEM.get_or_init(|| system);
    &TABLE
}

/// Export a generated system as a plugin: `cbfgen::export_plugin!(SYSTEM);` in a
/// `cdylib` crate beside `cbfgen::include_system!` (see [`crate::plugin`]).
#[macro_export]
macro_rules! export_plugin {
    ($system:expr) => {
        /// The plugin's entry table (cbfgen's plugin ABI, of `cbfgen::plugin::ABI_VERSION`).
        #[unsafe(no_mangle)]
        pub extern "C" fn cbfgen_plugin_v1() -> *const $crate::plugin::PluginV1 {
            $crate::plugin::export($system)
        }
    };
}

static TABLE: PluginV1 = PluginV1 {
    abi_version: ABI_VERSION,
    core_version: StrC { ptr: env!("CARGO_PKG_VERSION").as_ptr(), len: env!("CARGO_PKG_VERSION").len() },
    describe,
    dynamics,
    params_new,
    params_clone,
    params_free,
    store,
    barriers_new,
    barriers_free,
    barriers_evaluate,
    rows_len,
    layout,
    row,
    default_settings,
    filter_new,
    filter_free,
    filter_update,
    filter_report,
    filter_fallback,
    filter_settings,
    filter_worst_case,
    filter_calibrate,
    kernel_call,
};

/// Run `f`, its error (or a panic) into `err`; `fail` is what the call returns then.
fn guarded<T>(err: *mut ErrorC, fail: T, f: impl FnOnce() -> Result<T, CbfError>) -> T {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(v)) => v,
        Ok(Err(e)) => {
            write_error(&e, err);
            fail
        }
        Err(_) => {
            write_error(&CbfError::Plugin { message: format!("{}: the plugin panicked", system().name()) }, err);
            fail
        }
    }
}

fn boxed<T: ?Sized>(object: Box<T>) -> Handle {
    Box::into_raw(Box::new(object)).cast()
}

/// # Safety
/// `h` came from [`boxed`] with this `T` and is alive.
unsafe fn object<'a, T: ?Sized>(h: Handle) -> &'a mut Box<T> {
    // SAFETY: as the caller promises.
    unsafe { &mut *h.cast::<Box<T>>() }
}

/// # Safety
/// `p` points to `n` values (or `n` is 0).
unsafe fn slice<'a, T>(p: *const T, n: usize) -> &'a [T] {
    if n == 0 {
        return &[];
    }
    // SAFETY: as the caller promises.
    unsafe { std::slice::from_raw_parts(p, n) }
}

/// # Safety
/// `p` points to `n` writable values (or `n` is 0).
unsafe fn slice_mut<'a, T>(p: *mut T, n: usize) -> &'a mut [T] {
    if n == 0 {
        return &mut [];
    }
    // SAFETY: as the caller promises.
    unsafe { std::slice::from_raw_parts_mut(p, n) }
}

struct Description(DescriptionC);
// SAFETY: built once, read-only, pointing at leaked data.
unsafe impl Send for Description {}
unsafe impl Sync for Description {}

fn leak<T>(items: Vec<T>) -> *const T {
    Vec::leak(items).as_ptr()
}

fn strs(items: &[&'static str]) -> *const StrC {
    leak(items.iter().map(|s| StrC::new(s)).collect())
}

unsafe extern "C" fn describe() -> *const DescriptionC {
    static DESCRIPTION: OnceLock<Description> = OnceLock::new();
    let d = DESCRIPTION.get_or_init(|| {
        let s = system();
        // The domains live with the parameter types: read them off empty parameters.
        let params = s.params(&[]).ok();
        let families: Vec<FamilyC> = s
            .families()
            .iter()
            .enumerate()
            .map(|(i, f)| {
                let domains = params.as_ref().and_then(|p| p.store(i, 0).ok()).map(|st| st.domains()).unwrap_or(&[]);
                let params: Vec<ParamC> = f
                    .params
                    .iter()
                    .enumerate()
                    .map(|(k, (name, shape))| ParamC {
                        name: StrC::new(name),
                        shape: shape.as_ptr(),
                        rank: shape.len(),
                        domain: domain_c(domains.get(k).map_or(crate::param_domain::Domain::Real, |d| d.1)),
                    })
                    .collect();
                FamilyC {
                    name: StrC::new(f.name),
                    kind: u8::from(f.kind == FamilyKind::Lyapunov),
                    relative_degree: f.relative_degree,
                    row_names: strs(f.row_names),
                    n_row_names: f.row_names.len(),
                    members: strs(f.members),
                    n_members: f.members.len(),
                    instances: match f.instances {
                        InstanceKind::Fixed => 0,
                        InstanceKind::Optional => 1,
                        InstanceKind::Capacity => 2,
                    },
                    count: f.count,
                    n_params: params.len(),
                    params: leak(params),
                    defaults: family_params_c(&f.defaults),
                }
            })
            .collect();
        let slots = |slots: &'static [(&'static str, usize)]| {
            leak(slots.iter().map(|(name, len)| SlotC { name: StrC::new(name), len: *len }).collect())
        };
        let kernels: Vec<KernelC> = s
            .kernels()
            .iter()
            .map(|k| KernelC {
                name: StrC::new(k.name),
                inputs: slots(k.inputs),
                n_inputs: k.inputs.len(),
                outputs: slots(k.outputs),
                n_outputs: k.outputs.len(),
            })
            .collect();
        Description(DescriptionC {
            name: StrC::new(s.name()),
            doc: StrC::new(s.doc()),
            nx: s.nx(),
            nu: s.nu(),
            state_names: strs(s.state_names()),
            input_names: strs(s.input_names()),
            input_min: s.input_min().as_ptr(),
            input_max: s.input_max().as_ptr(),
            n_families: families.len(),
            families: leak(families),
            n_kernels: kernels.len(),
            kernels: leak(kernels),
        })
    });
    &d.0
}

unsafe extern "C" fn dynamics(op: u32, x: *const f64, u: *const f64, out: *mut f64, err: *mut ErrorC) -> i32 {
    guarded(err, -1, || {
        let s = system();
        let (nx, nu) = (s.nx(), s.nu());
        // SAFETY: the loader passes nx states, nu inputs and room for what `op` writes.
        let x = unsafe { slice(x, nx) };
        match op {
            dynamics_op::DRIFT => s.drift(x, unsafe { slice_mut(out, nx) })?,
            dynamics_op::INPUT_MATRIX => s.input_matrix(x, unsafe { slice_mut(out, nx * nu) })?,
            _ => s.xdot(x, unsafe { slice(u, nu) }, unsafe { slice_mut(out, nx) })?,
        }
        Ok(0)
    })
}

unsafe extern "C" fn params_new(counts: *const CapacityCount, n: usize, err: *mut ErrorC) -> Handle {
    // SAFETY: `n` counts.
    guarded(err, ptr::null_mut(), || Ok(boxed(system().params(unsafe { slice(counts, n) })?)))
}

unsafe extern "C" fn params_clone(params: Handle) -> Handle {
    // SAFETY: a live parameters handle.
    boxed(unsafe { object::<dyn DynParams>(params) }.clone_box())
}

unsafe extern "C" fn params_free(params: Handle) {
    // SAFETY: a live parameters handle, freed once.
    drop(unsafe { Box::from_raw(params.cast::<Box<dyn DynParams>>()) });
}

unsafe extern "C" fn store(
    params: Handle,
    op: u32,
    family: usize,
    member: usize,
    instance: usize,
    values: *mut f64,
    len: usize,
    flag: bool,
    err: *mut ErrorC,
) -> i64 {
    guarded(err, -1, || {
        // SAFETY: a live parameters handle; `values` holds `len` numbers.
        let p = unsafe { object::<dyn DynParams>(params) };
        let values = unsafe { slice_mut(values, len) };
        Ok(match op {
            store_op::SET => p.set(family, member, instance, values).map(|()| 0)?,
            store_op::PUSH => p.push(family, member, values).map(|()| 0)?,
            _ => {
                let store = p.store_mut(family, member)?;
                match op {
                    store_op::EXISTS => 0,
                    store_op::LEN => store.len() as i64,
                    store_op::SLOTS => store.slots() as i64,
                    store_op::IS_ENABLED => i64::from(store.is_enabled()),
                    store_op::GET => i64::from(store.get(instance, values)?),
                    store_op::REMOVE => store.remove(instance).map(|()| 0)?,
                    store_op::CLEAR => store.clear().map(|()| 0)?,
                    _ => store.set_enabled(flag).map(|()| 0)?,
                }
            }
        })
    })
}

unsafe extern "C" fn barriers_new(params: Handle, err: *mut ErrorC) -> Handle {
    // SAFETY: a live parameters handle.
    guarded(err, ptr::null_mut(), || {
        Ok(boxed(system().barriers_for(unsafe { object::<dyn DynParams>(params) }.as_ref())?))
    })
}

unsafe extern "C" fn barriers_free(barriers: Handle) {
    // SAFETY: a live barrier handle, freed once.
    drop(unsafe { Box::from_raw(barriers.cast::<Box<dyn DynBarriers>>()) });
}

unsafe extern "C" fn barriers_evaluate(
    barriers: Handle,
    t: f64,
    x: *const f64,
    params: Handle,
    err: *mut ErrorC,
) -> i32 {
    guarded(err, -1, || {
        // SAFETY: live handles; nx states.
        let b = unsafe { object::<dyn DynBarriers>(barriers) };
        let p = unsafe { object::<dyn DynParams>(params) };
        b.evaluate(t, unsafe { slice(x, system().nx()) }, p.as_ref()).map(|()| 0)
    })
}

/// # Safety
/// A live barrier (`filter` false) or filter handle.
unsafe fn rows_of<'a>(rows: Handle, filter: bool) -> &'a dyn DynRows {
    // SAFETY: as the caller promises.
    unsafe {
        if filter {
            &**object::<'a, dyn DynFilter>(rows)
        } else {
            &**object::<'a, dyn DynBarriers>(rows)
        }
    }
}

unsafe extern "C" fn rows_len(rows: Handle, filter: bool) -> usize {
    // SAFETY: a live handle of that kind.
    unsafe { rows_of(rows, filter) }.layout().len()
}

unsafe extern "C" fn layout(rows: Handle, filter: bool, i: usize, out: *mut RowLayoutC) -> bool {
    // SAFETY: a live handle of that kind; `out` writable.
    let Some(l) = unsafe { rows_of(rows, filter) }.layout().get(i) else { return false };
    let (family, member, instance, row) = (l.family, l.member, l.instance, l.row);
    unsafe {
        *out = RowLayoutC { family, member, instance, row, columns: l.columns.as_ptr(), n_columns: l.columns.len() }
    };
    true
}

unsafe extern "C" fn row(rows: Handle, filter: bool, i: usize, out: *mut RowC) -> bool {
    // SAFETY: a live handle of that kind; `out` writable.
    let Some(r) = unsafe { rows_of(rows, filter) }.row(i) else { return false };
    unsafe { *out = RowC { lie: r.lie, lg: r.lg.as_ptr(), active: r.active, culled: r.culled } };
    true
}

/// `s` into the caller's buffers.
///
/// # Safety
/// `out`'s buffers hold one entry per family and per input.
unsafe fn write_settings(s: &DynSettings, out: *mut SettingsC) {
    // SAFETY: as the caller promises.
    let out = unsafe { &mut *out };
    for (o, p) in unsafe { slice_mut(out.families, s.families.len()) }.iter_mut().zip(&s.families) {
        *o = family_params_c(p);
    }
    let nu = s.input_weights.len();
    unsafe { slice_mut(out.input_weights, nu) }.copy_from_slice(&s.input_weights);
    unsafe { slice_mut(out.input_min, nu) }.copy_from_slice(&s.input_min);
    unsafe { slice_mut(out.input_max, nu) }.copy_from_slice(&s.input_max);
    out.solver = solver_c(&s.solver);
    out.measure_cpu_time = s.measure_cpu_time;
    out.cull_far_rows = s.cull_far_rows;
}

unsafe extern "C" fn default_settings(out: *mut SettingsC) {
    // SAFETY: the loader sized the buffers from the description.
    unsafe { write_settings(&system().default_settings(), out) }
}

unsafe extern "C" fn filter_new(
    counts: *const CapacityCount,
    n: usize,
    settings: *const SettingsC,
    err: *mut ErrorC,
) -> Handle {
    guarded(err, ptr::null_mut(), || {
        let s = system();
        // SAFETY: the loader's buffers, sized from the description.
        let c = unsafe { &*settings };
        let known = || s.families().iter().map(|f| f.defaults.class_k);
        let families = unsafe { slice(c.families, s.families().len()) }
            .iter()
            .map(|p| unsafe { family_params(p, known()) })
            .collect::<Result<Vec<_>, _>>()?;
        let nu = s.nu();
        let settings = DynSettings {
            families,
            input_weights: unsafe { slice(c.input_weights, nu) }.to_vec(),
            input_min: unsafe { slice(c.input_min, nu) }.to_vec(),
            input_max: unsafe { slice(c.input_max, nu) }.to_vec(),
            solver: solver(&c.solver),
            measure_cpu_time: c.measure_cpu_time,
            cull_far_rows: c.cull_far_rows,
            // The ABI does not carry the certificate's settings; the loader refuses them.
            sampled_data: None,
        };
        Ok(boxed(s.filter(unsafe { slice(counts, n) }, &settings)?))
    })
}

unsafe extern "C" fn filter_free(filter: Handle) {
    // SAFETY: a live filter handle, freed once.
    drop(unsafe { Box::from_raw(filter.cast::<Box<dyn DynFilter>>()) });
}

unsafe extern "C" fn filter_update(
    filter: Handle,
    t: f64,
    x: *const f64,
    u_ref: *const f64,
    params: Handle,
    err: *mut ErrorC,
) -> i32 {
    guarded(err, -1, || {
        let s = system();
        // SAFETY: live handles; nx states and nu inputs.
        let f = unsafe { object::<dyn DynFilter>(filter) };
        let p = unsafe { object::<dyn DynParams>(params) };
        f.update(t, unsafe { slice(x, s.nx()) }, unsafe { slice(u_ref, s.nu()) }, p.as_ref()).map(|()| 0)
    })
}

unsafe extern "C" fn filter_report(filter: Handle, out: *mut ReportC) {
    // SAFETY: a live filter handle; the report's buffers sized for its rows, families, inputs.
    let f = unsafe { object::<dyn DynFilter>(filter) };
    let r = unsafe { &mut *out };
    let o = f.output();
    let rows = f.layout().len();
    unsafe { slice_mut(r.u, o.u.len()) }.copy_from_slice(o.u);
    unsafe { slice_mut(r.active, rows) }.copy_from_slice(f.active());
    unsafe { slice_mut(r.delta, rows) }.copy_from_slice(f.delta());
    unsafe { slice_mut(r.relative, rows) }.copy_from_slice(f.relative_slack());
    for (c, cause) in unsafe { slice_mut(r.causes, rows) }.iter_mut().zip(f.relaxed()) {
        *c = cause_c(*cause);
    }
    let relaxation = f.relaxation();
    unsafe { slice_mut(r.relaxation, relaxation.len()) }.copy_from_slice(relaxation);
    r.source = code(&INPUT_SOURCES, &o.source);
    r.status = o.status.map_or(-1, |s| code(&QP_STATUSES, &s) as i8);
    r.backend = o.backend.map_or(-1, |b| code(&BACKENDS, &b) as i8);
    r.dense_steps = o.dense_steps;
    r.dense_fallback = o.dense_fallback;
    r.elastic_stages = o.elastic_stages;
    r.nonfinite_row = o.nonfinite_row.map_or(-1, |i| i as i64);
    r.iterations = o.iterations;
    r.polished = o.polished;
    r.active_rows = o.active_rows;
    r.safety = safety_c(&o.safety);
    r.convergence = safety_c(&o.convergence);
    r.consecutive_fallbacks = o.consecutive_fallbacks;
    r.work = o.work;
    r.eval_time_ns = o.eval_time.as_nanos() as u64;
    r.solve_time_ns = o.solve_time.as_nanos() as u64;
    r.cpu_time_ns = o.cpu_time.map_or(-1, |d| d.as_nanos() as i64);
}

unsafe extern "C" fn filter_fallback(filter: Handle, u_ref: *const f64, out: *mut f64, err: *mut ErrorC) -> i32 {
    guarded(err, -1, || {
        let nu = system().nu();
        // SAFETY: a live filter handle; nu inputs each way.
        let f = unsafe { object::<dyn DynFilter>(filter) };
        f.fallback_input(unsafe { slice(u_ref, nu) }, unsafe { slice_mut(out, nu) }).map(|()| 0)
    })
}

unsafe extern "C" fn filter_settings(filter: Handle, out: *mut SettingsC) {
    // SAFETY: a live filter handle; buffers sized from the description.
    unsafe { write_settings(&object::<dyn DynFilter>(filter).settings(), out) }
}

unsafe extern "C" fn filter_worst_case(filter: Handle, out: *mut WorstCaseC) {
    // SAFETY: a live filter handle; `out` one value.
    unsafe { *out = object::<dyn DynFilter>(filter).worst_case().into() }
}

unsafe extern "C" fn filter_calibrate(
    filter: Handle,
    t: f64,
    x: *const f64,
    params: Handle,
    out: *mut crate::filter::Calibration,
    err: *mut ErrorC,
) -> i32 {
    guarded(err, -1, || {
        let s = system();
        // SAFETY: live handles; nx states; `out` one value.
        let f = unsafe { object::<dyn DynFilter>(filter) };
        let p = unsafe { object::<dyn DynParams>(params) };
        let calibration = f.calibrate(t, unsafe { slice(x, s.nx()) }, p.as_ref())?;
        unsafe { *out = calibration };
        Ok(0)
    })
}

unsafe extern "C" fn kernel_call(
    index: usize,
    inputs: *const f64,
    n_inputs: usize,
    outputs: *mut f64,
    n_outputs: usize,
    err: *mut ErrorC,
) -> i32 {
    guarded(err, -1, || {
        let s = system();
        let kernels = s.kernels();
        let kernel = kernels.get(index).ok_or_else(|| CbfError::Plugin {
            message: format!("{}: no kernel {index} (it has {})", s.name(), kernels.len()),
        })?;
        // SAFETY: the loader passes its slices' pointers and lengths (checked again here).
        s.call_kernel(kernel.name, unsafe { slice(inputs, n_inputs) }, unsafe { slice_mut(outputs, n_outputs) })?;
        Ok(0)
    })
}
