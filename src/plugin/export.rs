//! The plugin's side: [`PluginV1`]'s entry points over the plugin's one `DynSystem`.
//!
//! Handles are `Box<Box<dyn …>>` turned into raw pointers: the outer box gives a thin
//! pointer to hand across, the inner one is the type-erased object.

use std::any::TypeId;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::ptr;
use std::sync::{Mutex, PoisonError};

use super::convert::{cause_c, domain_c, family_params, family_params_c, safety_c, solver, solver_c, write_error};
use super::{
    code, dynamics_op, store_op, DescriptionC, ErrorC, ErrorCode, FamilyC, Handle, KernelC, ParamC, PluginV1, ReportC,
    RowC, RowLayoutC, SettingsC, SlotC, StrC, WorstCaseC, ABI_VERSION, BACKENDS, INPUT_SOURCES, QP_STATUSES, VERDICTS,
};
use crate::dynamic::{CapacityCount, DynBarriers, DynFilter, DynParams, DynRows, DynSettings, DynSystem};
use crate::error::CbfError;
use crate::system::{FamilyKind, InstanceKind};

/// A system an entry table is made for: the marker type [`crate::export_plugin!`] and
/// [`crate::export_c!`] define, so that each exported system has a table of its own (the
/// entry points are generic over it) and several can live in one program, as static
/// libraries linked together do.
pub trait Exported: 'static {
    /// The system the table serves.
    const SYSTEM: &'static dyn DynSystem;
}

/// The entry table of `S::SYSTEM`: what the export macros put in a `static`.
pub const fn table<S: Exported>() -> PluginV1 {
    PluginV1 {
        abi_version: ABI_VERSION,
        core_version: StrC { ptr: env!("CARGO_PKG_VERSION").as_ptr(), len: env!("CARGO_PKG_VERSION").len() },
        describe: describe::<S>,
        dynamics: dynamics::<S>,
        params_new: params_new::<S>,
        params_clone: params_clone::<S>,
        params_free,
        store: store::<S>,
        barriers_new: barriers_new::<S>,
        barriers_free,
        barriers_evaluate: barriers_evaluate::<S>,
        rows_len,
        layout,
        row,
        default_settings: default_settings::<S>,
        filter_new: filter_new::<S>,
        filter_free,
        filter_update: filter_update::<S>,
        filter_report: filter_report::<S>,
        filter_fallback: filter_fallback::<S>,
        filter_settings: filter_settings::<S>,
        filter_worst_case: filter_worst_case::<S>,
        filter_calibrate: filter_calibrate::<S>,
        kernel_call: kernel_call::<S>,
    }
}

/// Export a generated system as a plugin: `cbfgen::export_plugin!(SYSTEM);` in a
/// `cdylib` crate beside `cbfgen::include_system!` (see [`crate::plugin`]). A library for
/// C and C++ programs uses [`crate::export_c!`] instead.
#[macro_export]
macro_rules! export_plugin {
    ($system:expr) => {
        /// The plugin's entry table (cbfgen's plugin ABI, of `cbfgen::plugin::ABI_VERSION`).
        #[unsafe(no_mangle)]
        pub extern "C" fn cbfgen_plugin_v1() -> *const $crate::plugin::PluginV1 {
            $crate::__entry_table!($system)
        }
    };
}

/// Export a generated system to C and C++ (`cbfgen.h`): `cbfgen::export_c!(SYSTEM,
/// "pvtol");` in a `staticlib`/`cdylib` crate exports `cbfgen_pvtol_plugin_v1`, the
/// system's entry table, named after the system so that several systems' libraries, shared
/// or static, can be linked into one program. `python -m cbfgen.embed install` writes
/// such a crate.
#[macro_export]
macro_rules! export_c {
    ($system:expr, $name:literal) => {
        /// The system's entry table (cbfgen's C ABI, `cbfgen.h`, of
        /// `cbfgen::plugin::ABI_VERSION`).
        #[unsafe(export_name = concat!("cbfgen_", $name, "_plugin_v1"))]
        pub extern "C" fn cbfgen_system_plugin_v1() -> *const $crate::plugin::PluginV1 {
            $crate::__entry_table!($system)
        }
    };
}

/// The export macros' table of `$system`: a marker type for it and a static of its own.
#[doc(hidden)]
#[macro_export]
macro_rules! __entry_table {
    ($system:expr) => {{
        struct Exported;
        impl $crate::plugin::Exported for Exported {
            const SYSTEM: &'static dyn $crate::dynamic::DynSystem = $system;
        }
        static TABLE: $crate::plugin::PluginV1 = $crate::plugin::table::<Exported>();
        &TABLE
    }};
}

/// Why a call failed: its code and message (a [`CbfError`], or the boundary's own).
struct Fault {
    code: ErrorCode,
    message: String,
}

impl From<CbfError> for Fault {
    fn from(e: CbfError) -> Self {
        Self { code: ErrorCode::of(&e), message: e.to_string() }
    }
}

/// A null `what` where a handle or buffer was needed (the system's name is put before it
/// by [`guarded`]).
fn null(what: &str) -> Fault {
    Fault { code: ErrorCode::NullPointer, message: format!("{what} is a null pointer") }
}

/// Run `f` for `S`'s table, its error (or a panic) into `err`; `fail` is what the call
/// returns then. The boundary's own errors (a null pointer, a panic) name the system.
fn guarded<S: Exported, T>(err: *mut ErrorC, fail: T, f: impl FnOnce() -> Result<T, Fault>) -> T {
    let fault = match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(v)) => return v,
        Ok(Err(fault)) => fault,
        Err(_) => Fault { code: ErrorCode::Panic, message: "the plugin panicked".into() },
    };
    let message = match fault.code {
        ErrorCode::NullPointer | ErrorCode::Panic => format!("{}: {}", S::SYSTEM.name(), fault.message),
        _ => fault.message,
    };
    write_error(fault.code, &message, err);
    fail
}

fn boxed<T: ?Sized>(object: Box<T>) -> Handle {
    Box::into_raw(Box::new(object)).cast()
}

/// The object behind `h`, which names it `what` when it is null.
///
/// # Safety
/// `h` is null, or came from [`boxed`] with this `T` and is alive.
unsafe fn object<'a, T: ?Sized>(h: Handle, what: &str) -> Result<&'a mut Box<T>, Fault> {
    // SAFETY: as the caller promises.
    unsafe { h.cast::<Box<T>>().as_mut() }.ok_or_else(|| null(what))
}

/// `p`'s `n` values, which must be `expected` of them (`what` in the message).
///
/// # Safety
/// `p` points to `n` values, or is null.
unsafe fn slice<'a, T>(p: *const T, n: usize, expected: usize, what: &'static str) -> Result<&'a [T], Fault> {
    if n != expected {
        return Err(CbfError::LengthMismatch { what, expected, got: n }.into());
    }
    if n == 0 {
        return Ok(&[]);
    }
    if p.is_null() {
        return Err(null(what));
    }
    // SAFETY: as the caller promises.
    Ok(unsafe { std::slice::from_raw_parts(p, n) })
}

/// `p`'s `n` writable values, which must be `expected` of them (`what` in the message).
///
/// # Safety
/// `p` points to `n` writable values, or is null.
unsafe fn slice_mut<'a, T>(p: *mut T, n: usize, expected: usize, what: &'static str) -> Result<&'a mut [T], Fault> {
    if n != expected {
        return Err(CbfError::LengthMismatch { what, expected, got: n }.into());
    }
    if n == 0 {
        return Ok(&mut []);
    }
    if p.is_null() {
        return Err(null(what));
    }
    // SAFETY: as the caller promises.
    Ok(unsafe { std::slice::from_raw_parts_mut(p, n) })
}

/// `p`'s one value to write (`what` in the message when it is null).
///
/// # Safety
/// `p` is null or points to one writable value.
unsafe fn out_ref<'a, T>(p: *mut T, what: &str) -> Result<&'a mut T, Fault> {
    // SAFETY: as the caller promises.
    unsafe { p.as_mut() }.ok_or_else(|| null(what))
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

unsafe extern "C" fn describe<S: Exported>() -> *const DescriptionC {
    // One description per exported system, built on first use and kept (a static in a
    // generic function would be one for every system of the program).
    static DESCRIPTIONS: Mutex<Vec<(TypeId, &'static Description)>> = Mutex::new(Vec::new());
    let mut known = DESCRIPTIONS.lock().unwrap_or_else(PoisonError::into_inner);
    if let Some((_, d)) = known.iter().find(|(id, _)| *id == TypeId::of::<S>()) {
        return &d.0;
    }
    let d: &'static Description = Box::leak(Box::new({
        let s = S::SYSTEM;
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
    }));
    known.push((TypeId::of::<S>(), d));
    &d.0
}

unsafe extern "C" fn dynamics<S: Exported>(
    op: u32,
    x: *const f64,
    n_x: usize,
    u: *const f64,
    n_u: usize,
    out: *mut f64,
    n_out: usize,
    err: *mut ErrorC,
) -> i32 {
    guarded::<S, _>(err, -1, || {
        let s = S::SYSTEM;
        let (nx, nu) = (s.nx(), s.nu());
        // SAFETY (every slice): the caller's buffers hold the lengths it passed.
        let x = unsafe { slice(x, n_x, nx, "state") }?;
        match op {
            dynamics_op::DRIFT => s.drift(x, unsafe { slice_mut(out, n_out, nx, "drift output") }?)?,
            dynamics_op::INPUT_MATRIX => {
                s.input_matrix(x, unsafe { slice_mut(out, n_out, nx * nu, "input matrix output") }?)?
            }
            dynamics_op::XDOT => {
                let u = unsafe { slice(u, n_u, nu, "input") }?;
                s.xdot(x, u, unsafe { slice_mut(out, n_out, nx, "xdot output") }?)?
            }
            _ => return Err(CbfError::NoSuchIndex { what: "dynamics operation", index: op as usize, len: 3 }.into()),
        }
        Ok(0)
    })
}

unsafe extern "C" fn params_new<S: Exported>(counts: *const CapacityCount, n: usize, err: *mut ErrorC) -> Handle {
    guarded::<S, _>(err, ptr::null_mut(), || {
        // SAFETY: `n` counts.
        let counts = unsafe { slice(counts, n, n, "capacity counts") }?;
        Ok(boxed(S::SYSTEM.params(counts)?))
    })
}

unsafe extern "C" fn params_clone<S: Exported>(params: Handle, err: *mut ErrorC) -> Handle {
    guarded::<S, _>(err, ptr::null_mut(), || {
        // SAFETY: a live parameters handle, or null.
        Ok(boxed(unsafe { object::<dyn DynParams>(params, "parameters handle") }?.clone_box()))
    })
}

unsafe extern "C" fn params_free(params: Handle) {
    if !params.is_null() {
        // SAFETY: a live parameters handle, freed once.
        drop(unsafe { Box::from_raw(params.cast::<Box<dyn DynParams>>()) });
    }
}

unsafe extern "C" fn store<S: Exported>(
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
    guarded::<S, _>(err, -1, || {
        // SAFETY: a live parameters handle or null; `values` holds `len` numbers or is null.
        let p = unsafe { object::<dyn DynParams>(params, "parameters handle") }?;
        let values = unsafe { slice_mut(values, len, len, "values") }?;
        Ok(match op {
            store_op::SET => p.set(family, member, instance, values).map(|()| 0)?,
            store_op::PUSH => p.push(family, member, values).map(|()| 0)?,
            store_op::EXISTS..=store_op::SET_ENABLED => {
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
            _ => return Err(CbfError::NoSuchIndex { what: "store operation", index: op as usize, len: 10 }.into()),
        })
    })
}

unsafe extern "C" fn barriers_new<S: Exported>(params: Handle, err: *mut ErrorC) -> Handle {
    guarded::<S, _>(err, ptr::null_mut(), || {
        // SAFETY: a live parameters handle or null.
        let p = unsafe { object::<dyn DynParams>(params, "parameters handle") }?;
        Ok(boxed(S::SYSTEM.barriers_for(p.as_ref())?))
    })
}

unsafe extern "C" fn barriers_free(barriers: Handle) {
    if !barriers.is_null() {
        // SAFETY: a live barrier handle, freed once.
        drop(unsafe { Box::from_raw(barriers.cast::<Box<dyn DynBarriers>>()) });
    }
}

unsafe extern "C" fn barriers_evaluate<S: Exported>(
    barriers: Handle,
    t: f64,
    x: *const f64,
    n_x: usize,
    params: Handle,
    err: *mut ErrorC,
) -> i32 {
    guarded::<S, _>(err, -1, || {
        // SAFETY: live handles or null; `x` holds `n_x` states.
        let b = unsafe { object::<dyn DynBarriers>(barriers, "barriers handle") }?;
        let p = unsafe { object::<dyn DynParams>(params, "parameters handle") }?;
        let x = unsafe { slice(x, n_x, S::SYSTEM.nx(), "state") }?;
        Ok(b.evaluate(t, x, p.as_ref()).map(|()| 0)?)
    })
}

/// # Safety
/// A live barrier (`filter` false) or filter handle, or null.
unsafe fn rows_of<'a>(rows: Handle, filter: bool) -> Option<&'a dyn DynRows> {
    // SAFETY: as the caller promises.
    unsafe {
        if filter {
            object::<dyn DynFilter>(rows, "").ok().map(|f| &**f as &dyn DynRows)
        } else {
            object::<dyn DynBarriers>(rows, "").ok().map(|b| &**b as &dyn DynRows)
        }
    }
}

unsafe extern "C" fn rows_len(rows: Handle, filter: bool) -> usize {
    // SAFETY: a live handle of that kind, or null.
    unsafe { rows_of(rows, filter) }.map_or(0, |r| r.layout().len())
}

unsafe extern "C" fn layout(rows: Handle, filter: bool, i: usize, out: *mut RowLayoutC) -> bool {
    // SAFETY: a live handle of that kind or null; `out` writable or null.
    let (Some(rows), Some(out)) = (unsafe { rows_of(rows, filter) }, unsafe { out.as_mut() }) else { return false };
    let Some(l) = rows.layout().get(i) else { return false };
    let (family, member, instance, row) = (l.family, l.member, l.instance, l.row);
    *out = RowLayoutC { family, member, instance, row, columns: l.columns.as_ptr(), n_columns: l.columns.len() };
    true
}

unsafe extern "C" fn row(rows: Handle, filter: bool, i: usize, out: *mut RowC) -> bool {
    // SAFETY: a live handle of that kind or null; `out` writable or null.
    let (Some(rows), Some(out)) = (unsafe { rows_of(rows, filter) }, unsafe { out.as_mut() }) else { return false };
    let Some(r) = rows.row(i) else { return false };
    *out = RowC { lie: r.lie.as_ptr(), lg: r.lg.as_ptr(), active: r.active, culled: r.culled };
    true
}

/// `s` into the caller's buffers.
///
/// # Safety
/// `out` is null or a valid `SettingsC` whose buffers hold the lengths it states.
unsafe fn write_settings(s: &DynSettings, out: *mut SettingsC) -> Result<i32, Fault> {
    // SAFETY: as the caller promises.
    let out = unsafe { out.as_mut() }.ok_or_else(|| null("settings"))?;
    let (n_families, nu) = (s.families.len(), s.input_weights.len());
    let families = unsafe { slice_mut(out.families, out.n_families, n_families, "settings' families") }?;
    for (o, p) in families.iter_mut().zip(&s.families) {
        *o = family_params_c(p);
    }
    unsafe { slice_mut(out.input_weights, out.n_inputs, nu, "settings' input weights") }?
        .copy_from_slice(&s.input_weights);
    unsafe { slice_mut(out.input_min, out.n_inputs, nu, "settings' input minima") }?.copy_from_slice(&s.input_min);
    unsafe { slice_mut(out.input_max, out.n_inputs, nu, "settings' input maxima") }?.copy_from_slice(&s.input_max);
    out.solver = solver_c(&s.solver);
    out.measure_cpu_time = s.measure_cpu_time;
    out.cull_far_rows = s.cull_far_rows;
    Ok(0)
}

unsafe extern "C" fn default_settings<S: Exported>(out: *mut SettingsC, err: *mut ErrorC) -> i32 {
    // SAFETY: the caller's settings, checked.
    guarded::<S, _>(err, -1, || unsafe { write_settings(&S::SYSTEM.default_settings(), out) })
}

unsafe extern "C" fn filter_new<S: Exported>(
    counts: *const CapacityCount,
    n: usize,
    settings: *const SettingsC,
    err: *mut ErrorC,
) -> Handle {
    guarded::<S, _>(err, ptr::null_mut(), || {
        let s = S::SYSTEM;
        let nu = s.nu();
        // SAFETY: the caller's settings and counts, their lengths checked.
        let c = unsafe { settings.as_ref() }.ok_or_else(|| null("settings"))?;
        let known = || s.families().iter().map(|f| f.defaults.class_k);
        let families = unsafe { slice(c.families, c.n_families, s.families().len(), "settings' families") }?
            .iter()
            .map(|p| unsafe { family_params(p, known()) })
            .collect::<Result<Vec<_>, _>>()?;
        let settings = DynSettings {
            families,
            input_weights: unsafe { slice(c.input_weights, c.n_inputs, nu, "settings' input weights") }?.to_vec(),
            input_min: unsafe { slice(c.input_min, c.n_inputs, nu, "settings' input minima") }?.to_vec(),
            input_max: unsafe { slice(c.input_max, c.n_inputs, nu, "settings' input maxima") }?.to_vec(),
            solver: solver(&c.solver),
            measure_cpu_time: c.measure_cpu_time,
            cull_far_rows: c.cull_far_rows,
            // The ABI does not carry the certificate's settings; the loader refuses them.
            sampled_data: None,
        };
        let counts = unsafe { slice(counts, n, n, "capacity counts") }?;
        Ok(boxed(s.filter(counts, &settings)?))
    })
}

unsafe extern "C" fn filter_free(filter: Handle) {
    if !filter.is_null() {
        // SAFETY: a live filter handle, freed once.
        drop(unsafe { Box::from_raw(filter.cast::<Box<dyn DynFilter>>()) });
    }
}

unsafe extern "C" fn filter_update<S: Exported>(
    filter: Handle,
    t: f64,
    x: *const f64,
    n_x: usize,
    u_ref: *const f64,
    n_u: usize,
    params: Handle,
    u: *mut f64,
    n_u_out: usize,
    err: *mut ErrorC,
) -> i32 {
    guarded::<S, _>(err, -1, || {
        // SAFETY: live handles or null; the buffers hold the lengths passed. The filter
        // checks the lengths against the system's (this is the per-cycle call: nothing
        // else is looked up here).
        let f = unsafe { object::<dyn DynFilter>(filter, "filter handle") }?;
        let p = unsafe { object::<dyn DynParams>(params, "parameters handle") }?;
        let x = unsafe { slice(x, n_x, n_x, "state") }?;
        let u_ref = unsafe { slice(u_ref, n_u, n_u, "nominal input") }?;
        // Checked before the update, so a refused call leaves the filter as it was.
        let u = unsafe { slice_mut(u, n_u_out, f.input().len(), "input output") }?;
        f.update(t, x, u_ref, p.as_ref())?;
        u.copy_from_slice(f.input());
        Ok(code(&VERDICTS, &f.verdict()).into())
    })
}

unsafe extern "C" fn filter_report<S: Exported>(filter: Handle, out: *mut ReportC, err: *mut ErrorC) -> i32 {
    guarded::<S, _>(err, -1, || {
        // SAFETY: a live filter handle or null; the report's buffers hold the lengths it states.
        let f = unsafe { object::<dyn DynFilter>(filter, "filter handle") }?;
        let r = unsafe { out.as_mut() }.ok_or_else(|| null("report"))?;
        let o = f.output();
        let rows = f.layout().len();
        let relaxation = f.relaxation();
        unsafe { slice_mut(r.u, r.n_u, o.u.len(), "report's input") }?.copy_from_slice(o.u);
        unsafe { slice_mut(r.active, r.n_rows, rows, "report's active rows") }?.copy_from_slice(f.active());
        unsafe { slice_mut(r.delta, r.n_rows, rows, "report's slacks") }?.copy_from_slice(f.delta());
        unsafe { slice_mut(r.relative, r.n_rows, rows, "report's relative slacks") }?
            .copy_from_slice(f.relative_slack());
        for (c, cause) in unsafe { slice_mut(r.causes, r.n_rows, rows, "report's causes") }?.iter_mut().zip(f.relaxed())
        {
            *c = cause_c(*cause);
        }
        unsafe { slice_mut(r.relaxation, r.n_families, relaxation.len(), "report's relaxations") }?
            .copy_from_slice(relaxation);
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
        Ok(0)
    })
}

unsafe extern "C" fn filter_fallback<S: Exported>(
    filter: Handle,
    u_ref: *const f64,
    n_u: usize,
    out: *mut f64,
    n_out: usize,
    err: *mut ErrorC,
) -> i32 {
    guarded::<S, _>(err, -1, || {
        let nu = S::SYSTEM.nu();
        // SAFETY: a live filter handle or null; the buffers hold the lengths passed.
        let f = unsafe { object::<dyn DynFilter>(filter, "filter handle") }?;
        let u_ref = unsafe { slice(u_ref, n_u, nu, "nominal input") }?;
        Ok(f.fallback_input(u_ref, unsafe { slice_mut(out, n_out, nu, "fallback output") }?).map(|()| 0)?)
    })
}

unsafe extern "C" fn filter_settings<S: Exported>(filter: Handle, out: *mut SettingsC, err: *mut ErrorC) -> i32 {
    guarded::<S, _>(err, -1, || {
        // SAFETY: a live filter handle or null; the caller's settings, checked.
        let f = unsafe { object::<dyn DynFilter>(filter, "filter handle") }?;
        unsafe { write_settings(&f.settings(), out) }
    })
}

unsafe extern "C" fn filter_worst_case<S: Exported>(filter: Handle, out: *mut WorstCaseC, err: *mut ErrorC) -> i32 {
    guarded::<S, _>(err, -1, || {
        // SAFETY: a live filter handle or null; `out` one value or null.
        let f = unsafe { object::<dyn DynFilter>(filter, "filter handle") }?;
        *unsafe { out_ref(out, "worst case") }? = f.worst_case().into();
        Ok(0)
    })
}

unsafe extern "C" fn filter_calibrate<S: Exported>(
    filter: Handle,
    t: f64,
    x: *const f64,
    n_x: usize,
    params: Handle,
    out: *mut crate::filter::Calibration,
    err: *mut ErrorC,
) -> i32 {
    guarded::<S, _>(err, -1, || {
        // SAFETY: live handles or null; `x` holds `n_x` states; `out` one value or null.
        let f = unsafe { object::<dyn DynFilter>(filter, "filter handle") }?;
        let p = unsafe { object::<dyn DynParams>(params, "parameters handle") }?;
        let x = unsafe { slice(x, n_x, S::SYSTEM.nx(), "state") }?;
        let out = unsafe { out_ref(out, "calibration") }?;
        *out = f.calibrate(t, x, p.as_ref())?;
        Ok(0)
    })
}

unsafe extern "C" fn kernel_call<S: Exported>(
    index: usize,
    inputs: *const f64,
    n_inputs: usize,
    outputs: *mut f64,
    n_outputs: usize,
    err: *mut ErrorC,
) -> i32 {
    guarded::<S, _>(err, -1, || {
        let s = S::SYSTEM;
        let kernels = s.kernels();
        let kernel = kernels.get(index).ok_or(CbfError::NoSuchIndex { what: "kernel", index, len: kernels.len() })?;
        // SAFETY: the caller's buffers hold the lengths it passed (the kernel checks them).
        let inputs = unsafe { slice(inputs, n_inputs, n_inputs, "kernel inputs") }?;
        let outputs = unsafe { slice_mut(outputs, n_outputs, n_outputs, "kernel outputs") }?;
        s.call_kernel(kernel.name, inputs, outputs)?;
        Ok(0)
    })
}
