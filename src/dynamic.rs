//! Every generated system behind object-safe traits, for code that picks its system at run
//! time: the Python bindings, tools, a controller configured from a file.
//!
//! The typed API ([`system`](crate::system), [`EcbfFilter`]) keeps sizes in types, which a
//! caller that learns the system from a string cannot name. Here the same objects take
//! slices, checked against the system's sizes, and parameters are addressed by family,
//! member and instance, each instance's numbers flattened in declaration order (vectors in
//! order, matrices row by row, as Python and the kernel table pass them, see
//! [`FamilyInfo::params`]). Nothing here is generated: a system's module implements the
//! four small traits [`FlatInstance`], [`FlatCapacity`], [`FlatParams`] and
//! [`GeneratedSystem`], and [`Erased`] does the rest for every system alike.
//!
//! A binary or binding that links system crates lists them in a [`Registry`] and picks
//! one by name; the `cbfgen-double-integrator` crate's docs show the whole round trip
//! (parameters set by name, a filter update) on its system.

use std::any::Any;
use std::marker::PhantomData;

use crate::error::CbfError;
use crate::filter::{
    Calibration, Cause, EcbfFilter, FamilyRelaxation, FilterSettings, Output, SolverSettings, Verdict, WorstCase,
};
use crate::param_domain::Domain;
use crate::system::{
    find_kernel, BarrierSet, ControlAffine, FamilyInfo, FamilyParams, InstanceKind, Instances, KernelEntry,
    KernelSignature, RowLayout, MAX_RELATIVE_DEGREE,
};

/// One instance's parameters as a flat slice of numbers (generated for every family's
/// parameter struct).
pub trait FlatInstance: Copy + Default + Send + Sync + 'static {
    /// How many numbers one instance holds (the sum of [`FamilyInfo::params`]' lengths).
    const LEN: usize;
    /// The instance from exactly [`FlatInstance::LEN`] numbers (checked by the caller).
    fn from_flat(values: &[f64]) -> Self;
    /// Write the instance's [`FlatInstance::LEN`] numbers into `out`.
    fn to_flat(&self, out: &mut [f64]);
    /// Each parameter's name and domain, in declaration order (the struct's `DOMAINS`).
    const DOMAINS: &'static [(&'static str, Domain)];
    /// The parameter struct's own domain check: every parameter in the domain its spec
    /// declares (see [`param_domain`](crate::param_domain)).
    ///
    /// # Errors
    /// As the struct's `validate`: [`CbfError::ParamOutOfDomain`] naming the family and
    /// parameter (not the instance, which the struct does not know).
    fn check(&self) -> Result<(), CbfError>;
}

/// A generated `Capacity`, addressed by family and member.
pub trait FlatCapacity: Copy + Default + PartialEq + Send + Sync + 'static {
    /// The count of capacity family `family` (member `member`); `None` for a family that
    /// is not capacity-sized or a member it does not have.
    fn count_mut(&mut self, family: usize, member: usize) -> Option<&mut usize>;
}

/// A generated `Params`, addressed by family and member.
pub trait FlatParams: Clone + Send + Sync + 'static {
    /// The system these parameters belong to.
    const SYSTEM: &'static str;
    /// Its families, in order.
    const FAMILIES: &'static [FamilyInfo];
    /// The instances of `family` (member `member`); `None` for a family without run-time
    /// parameters or a member it does not have.
    fn store(&self, family: usize, member: usize) -> Option<&dyn FamilyStore>;
    /// As [`FlatParams::store`], to change them.
    fn store_mut(&mut self, family: usize, member: usize) -> Option<&mut dyn FamilyStore>;
}

/// The typed pieces of one generated system, for [`Erased`].
pub trait GeneratedSystem<const NX: usize, const NU: usize>: ControlAffine<NX, NU> + 'static {
    /// The spec's description.
    const DOC: &'static str;
    /// Its families, in order.
    const FAMILIES: &'static [FamilyInfo];
    /// Its kernels behind the uniform signature (the module's `KERNELS`).
    const KERNELS: &'static [KernelEntry];
    /// The dynamics (`drift`, `input_matrix`) and every barrier member's kernel on
    /// intervals, members in family order (`IntervalKernel::NONE` for a member without an
    /// interval form): what certifies rows between the samples
    /// ([`crate::filter::between_samples`]). Empty: nothing can be certified.
    const INTERVAL_KERNELS: &'static [crate::filter::between_samples::IntervalKernel] = &[];
    /// How many instances each capacity family has room for.
    type Capacity: FlatCapacity;
    /// Every family's run-time instances.
    type Params: FlatParams;
    /// The rows.
    type Barriers: BarrierSet<NU, State = [f64; NX], Params = Self::Params> + Send + 'static;
    /// Parameters sized for `capacity`.
    ///
    /// # Errors
    /// A capacity above its family's maximum.
    fn params(capacity: Self::Capacity) -> Result<Self::Params, CbfError>;
    /// Rows laid out for `capacity`.
    ///
    /// # Errors
    /// A capacity above its family's maximum.
    fn barriers(capacity: Self::Capacity) -> Result<Self::Barriers, CbfError>;
    /// The capacity `params` were sized for.
    fn capacity_of(params: &Self::Params) -> Self::Capacity;
}

/// One family's instances (of one member), whatever their parameter type: what
/// [`FlatParams::store`] hands out. Implemented here for the three shapes a generated
/// `Params` field takes.
pub trait FamilyStore {
    /// How the instances are kept.
    fn kind(&self) -> InstanceKind;
    /// Numbers per instance.
    fn width(&self) -> usize;
    /// Each parameter's name and domain, in declaration order ([`FlatInstance::DOMAINS`]).
    fn domains(&self) -> &'static [(&'static str, Domain)];
    /// Instance slots: the fixed or optional count, or the capacity.
    fn slots(&self) -> usize;
    /// Instances present: every fixed one, the optional ones set, the capacity ones pushed.
    fn len(&self) -> usize;
    /// Whether no instance is present.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Write instance `instance` into `out` (`width()` numbers); `Ok(false)` when that
    /// slot is empty.
    ///
    /// # Errors
    /// No such slot, or `out` of another length; a fixed instance with a parameter never
    /// set ([`Found::NotSet`](crate::param_domain::Found::NotSet), naming it): there is no
    /// value to read.
    fn get(&self, instance: usize, out: &mut [f64]) -> Result<bool, CbfError>;
    /// Set instance `instance` (fixed, optional, or an already pushed capacity instance).
    ///
    /// # Errors
    /// No such instance, `values` of another length than `width()`, or values outside
    /// the parameters' domains ([`CbfError::ParamOutOfDomain`] naming family, instance
    /// and parameter); nothing changes then.
    fn set(&mut self, instance: usize, values: &[f64]) -> Result<(), CbfError>;
    /// Append an instance (capacity families).
    ///
    /// # Errors
    /// As [`FamilyStore::set`] (the instance named is the one it would have become); a
    /// full list; not a capacity family.
    fn push(&mut self, values: &[f64]) -> Result<(), CbfError>;
    /// Empty optional slot `instance` (optional families).
    ///
    /// # Errors
    /// No such slot, or not an optional family.
    fn remove(&mut self, instance: usize) -> Result<(), CbfError>;
    /// Remove every instance: a capacity list is emptied, optional slots all emptied.
    ///
    /// # Errors
    /// A fixed family (its instances cannot be absent).
    fn clear(&mut self) -> Result<(), CbfError>;
    /// Switch a capacity list's rows on or off, keeping its instances
    /// ([`Instances::set_enabled`]).
    ///
    /// # Errors
    /// Not a capacity family.
    fn set_enabled(&mut self, enabled: bool) -> Result<(), CbfError>;
    /// Whether the instances' rows take part (always, except a capacity list switched off).
    fn is_enabled(&self) -> bool;
}

fn unsupported(kind: InstanceKind, operation: &'static str) -> CbfError {
    CbfError::Unsupported { operation, kind: kind.name() }
}

/// `values` as the parameters of instance `instance`, checked against their domains (an
/// error names the instance).
fn instance_of<P: FlatInstance>(values: &[f64], instance: usize) -> Result<P, CbfError> {
    if values.len() != P::LEN {
        return Err(CbfError::LengthMismatch { what: "instance parameters", expected: P::LEN, got: values.len() });
    }
    let p = P::from_flat(values);
    p.check().map_err(|e| e.in_instance(instance))?;
    Ok(p)
}

fn write<P: FlatInstance>(p: &P, out: &mut [f64]) -> Result<(), CbfError> {
    if out.len() != P::LEN {
        return Err(CbfError::LengthMismatch { what: "instance parameters", expected: P::LEN, got: out.len() });
    }
    p.to_flat(out);
    Ok(())
}

fn slot<T>(items: &mut [T], instance: usize) -> Result<&mut T, CbfError> {
    let len = items.len();
    items.get_mut(instance).ok_or(CbfError::NoSuchIndex { what: "instance", index: instance, len })
}

fn slot_ref<T>(items: &[T], instance: usize) -> Result<&T, CbfError> {
    items.get(instance).ok_or(CbfError::NoSuchIndex { what: "instance", index: instance, len: items.len() })
}

impl<P: FlatInstance, const N: usize> FamilyStore for [P; N] {
    fn kind(&self) -> InstanceKind {
        InstanceKind::Fixed
    }
    fn width(&self) -> usize {
        P::LEN
    }
    fn domains(&self) -> &'static [(&'static str, Domain)] {
        P::DOMAINS
    }
    fn slots(&self) -> usize {
        N
    }
    fn len(&self) -> usize {
        N
    }
    fn get(&self, instance: usize, out: &mut [f64]) -> Result<bool, CbfError> {
        let p = slot_ref(self, instance)?;
        write(p, out)?;
        if out.iter().any(|&v| crate::param_domain::is_unset(v)) {
            // Its own check names the parameter never set.
            p.check().map_err(|e| e.in_instance(instance))?;
        }
        Ok(true)
    }
    fn set(&mut self, instance: usize, values: &[f64]) -> Result<(), CbfError> {
        // The slot first: a missing instance is refused as such, whatever the values.
        let slot = slot(self, instance)?;
        *slot = instance_of(values, instance)?;
        Ok(())
    }
    fn push(&mut self, _: &[f64]) -> Result<(), CbfError> {
        Err(unsupported(InstanceKind::Fixed, "push"))
    }
    fn remove(&mut self, _: usize) -> Result<(), CbfError> {
        Err(unsupported(InstanceKind::Fixed, "remove"))
    }
    fn clear(&mut self) -> Result<(), CbfError> {
        Err(unsupported(InstanceKind::Fixed, "clear"))
    }
    fn set_enabled(&mut self, _: bool) -> Result<(), CbfError> {
        Err(unsupported(InstanceKind::Fixed, "set_enabled"))
    }
    fn is_enabled(&self) -> bool {
        true
    }
}

impl<P: FlatInstance, const N: usize> FamilyStore for [Option<P>; N] {
    fn kind(&self) -> InstanceKind {
        InstanceKind::Optional
    }
    fn width(&self) -> usize {
        P::LEN
    }
    fn domains(&self) -> &'static [(&'static str, Domain)] {
        P::DOMAINS
    }
    fn slots(&self) -> usize {
        N
    }
    fn len(&self) -> usize {
        self.iter().flatten().count()
    }
    fn get(&self, instance: usize, out: &mut [f64]) -> Result<bool, CbfError> {
        match slot_ref(self, instance)? {
            Some(p) => write(p, out).map(|()| true),
            None => Ok(false),
        }
    }
    fn set(&mut self, instance: usize, values: &[f64]) -> Result<(), CbfError> {
        let slot = slot(self, instance)?;
        *slot = Some(instance_of(values, instance)?);
        Ok(())
    }
    fn push(&mut self, _: &[f64]) -> Result<(), CbfError> {
        Err(unsupported(InstanceKind::Optional, "push"))
    }
    fn remove(&mut self, instance: usize) -> Result<(), CbfError> {
        *slot(self, instance)? = None;
        Ok(())
    }
    fn clear(&mut self) -> Result<(), CbfError> {
        self.fill(None);
        Ok(())
    }
    fn set_enabled(&mut self, _: bool) -> Result<(), CbfError> {
        Err(unsupported(InstanceKind::Optional, "set_enabled"))
    }
    fn is_enabled(&self) -> bool {
        true
    }
}

impl<P: FlatInstance> FamilyStore for Instances<P> {
    fn kind(&self) -> InstanceKind {
        InstanceKind::Capacity
    }
    fn width(&self) -> usize {
        P::LEN
    }
    fn domains(&self) -> &'static [(&'static str, Domain)] {
        P::DOMAINS
    }
    fn slots(&self) -> usize {
        self.capacity()
    }
    fn len(&self) -> usize {
        self.as_slice().len()
    }
    fn get(&self, instance: usize, out: &mut [f64]) -> Result<bool, CbfError> {
        if instance >= self.capacity() {
            return Err(CbfError::NoSuchIndex { what: "instance", index: instance, len: self.capacity() });
        }
        match self.as_slice().get(instance) {
            Some(p) => write(p, out).map(|()| true),
            None => Ok(false),
        }
    }
    fn set(&mut self, instance: usize, values: &[f64]) -> Result<(), CbfError> {
        let slot = slot(self.as_mut_slice(), instance)?;
        *slot = instance_of(values, instance)?;
        Ok(())
    }
    fn push(&mut self, values: &[f64]) -> Result<(), CbfError> {
        let instance = self.as_slice().len();
        if instance == self.capacity() {
            // Full: refused as such whatever the values (nothing is pushed).
            return Instances::push(self, P::default());
        }
        Instances::push(self, instance_of(values, instance)?)
    }
    fn remove(&mut self, _: usize) -> Result<(), CbfError> {
        Err(unsupported(InstanceKind::Capacity, "remove"))
    }
    fn clear(&mut self) -> Result<(), CbfError> {
        Instances::clear(self);
        Ok(())
    }
    fn set_enabled(&mut self, enabled: bool) -> Result<(), CbfError> {
        Instances::set_enabled(self, enabled);
        Ok(())
    }
    fn is_enabled(&self) -> bool {
        Instances::is_enabled(self)
    }
}

/// The size of one capacity family (one member's, for an indexed family). (`repr(C)`: it
/// crosses the plugin ABI as is.)
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CapacityCount {
    /// Index into the system's families.
    pub family: usize,
    /// Member of an indexed family; 0 otherwise.
    pub member: usize,
    /// Instance slots to reserve.
    pub count: usize,
}

/// A family by name: its index, or [`CbfError::UnknownName`] listing the families.
///
/// # Errors
/// [`CbfError::UnknownName`].
pub fn family_index(families: &[FamilyInfo], name: &str) -> Result<usize, CbfError> {
    families.iter().position(|f| f.name == name).ok_or_else(|| CbfError::UnknownName {
        what: "family",
        name: name.to_string(),
        known: families.iter().map(|f| f.name).collect::<Vec<_>>().join(", "),
    })
}

/// The name of member `member` of `family`, if that family is indexed.
fn member_name(families: &[FamilyInfo], family: usize, member: usize) -> Option<&'static str> {
    families.get(family).and_then(|f| f.members.get(member)).copied()
}

/// Any system's parameters, type-erased: the [`FlatParams`] of one generated `Params`.
pub trait DynParams: Send + Sync {
    /// The system they belong to.
    fn system(&self) -> &'static str;
    /// Its families, in order.
    fn families(&self) -> &'static [FamilyInfo];
    /// Family `family` (member `member`)'s instances.
    ///
    /// # Errors
    /// No such family or member, or a family without run-time parameters.
    fn store(&self, family: usize, member: usize) -> Result<&dyn FamilyStore, CbfError>;
    /// As [`DynParams::store`], to change them.
    ///
    /// # Errors
    /// As [`DynParams::store`].
    fn store_mut(&mut self, family: usize, member: usize) -> Result<&mut dyn FamilyStore, CbfError>;
    /// The concrete `Params`, for `downcast_ref` on `dyn DynParams`.
    fn as_any(&self) -> &dyn Any;
    /// As [`DynParams::as_any`], mutable.
    fn as_any_mut(&mut self) -> &mut dyn Any;
    /// A copy.
    fn clone_box(&self) -> Box<dyn DynParams>;

    /// Index of family `name`.
    ///
    /// # Errors
    /// [`CbfError::UnknownName`] listing the families.
    fn family_index(&self, name: &str) -> Result<usize, CbfError> {
        family_index(self.families(), name)
    }
    /// [`FamilyStore::set`] on `family`/`member`.
    ///
    /// # Errors
    /// As [`DynParams::store_mut`] and [`FamilyStore::set`]; a
    /// [`CbfError::ParamOutOfDomain`] names the member of an indexed family too.
    fn set(&mut self, family: usize, member: usize, instance: usize, values: &[f64]) -> Result<(), CbfError> {
        let name = member_name(self.families(), family, member);
        self.store_mut(family, member)?.set(instance, values).map_err(|e| e.in_member(name))
    }
    /// [`FamilyStore::push`] on `family`/`member`.
    ///
    /// # Errors
    /// As [`DynParams::store_mut`] and [`FamilyStore::push`]; a
    /// [`CbfError::ParamOutOfDomain`] names the member of an indexed family too.
    fn push(&mut self, family: usize, member: usize, values: &[f64]) -> Result<(), CbfError> {
        let name = member_name(self.families(), family, member);
        self.store_mut(family, member)?.push(values).map_err(|e| e.in_member(name))
    }
}

impl dyn DynParams + '_ {
    /// The concrete `Params` of a generated system, if these are its.
    pub fn downcast_ref<P: FlatParams>(&self) -> Option<&P> {
        self.as_any().downcast_ref()
    }

    /// As `downcast_ref`, mutable.
    pub fn downcast_mut<P: FlatParams>(&mut self) -> Option<&mut P> {
        self.as_any_mut().downcast_mut()
    }
}

/// Why `family`/`member` has nothing for `operation`: no such family, no such member, or
/// a family of `kind` that does not have it.
fn not_found(
    families: &[FamilyInfo],
    family: usize,
    member: usize,
    operation: &'static str,
    kind: &'static str,
) -> CbfError {
    match families.get(family) {
        None => CbfError::NoSuchIndex { what: "family", index: family, len: families.len() },
        Some(f) if member >= f.members.len().max(1) => {
            CbfError::NoSuchIndex { what: "member", index: member, len: f.members.len().max(1) }
        }
        Some(_) => CbfError::Unsupported { operation, kind },
    }
}

impl<P: FlatParams> DynParams for P {
    fn system(&self) -> &'static str {
        P::SYSTEM
    }
    fn families(&self) -> &'static [FamilyInfo] {
        P::FAMILIES
    }
    fn store(&self, family: usize, member: usize) -> Result<&dyn FamilyStore, CbfError> {
        FlatParams::store(self, family, member)
            .ok_or_else(|| not_found(P::FAMILIES, family, member, "parameter access", "parameter-free"))
    }
    fn store_mut(&mut self, family: usize, member: usize) -> Result<&mut dyn FamilyStore, CbfError> {
        FlatParams::store_mut(self, family, member)
            .ok_or_else(|| not_found(P::FAMILIES, family, member, "parameter access", "parameter-free"))
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
    fn clone_box(&self) -> Box<dyn DynParams> {
        Box::new(self.clone())
    }
}

/// One row as last evaluated, without its system's sizes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowView<'a> {
    /// `[h, L_f h, …, L_f^r h]`, then zeros.
    pub lie: &'a [f64; MAX_RELATIVE_DEGREE + 1],
    /// `L_g L_f^{r−1} h`, one entry per input.
    pub lg: &'a [f64],
    /// Whether the row applied at the last evaluation.
    pub active: bool,
    /// Whether it was culled: `lie[0]` is then a lower bound on `h` above the activation
    /// threshold, not `h` ([`crate::system::Row::culled`]).
    pub culled: bool,
}

/// Any system's rows: layout, families and values.
pub trait DynRows {
    /// The families, indexed by [`RowLayout::family`].
    fn families(&self) -> &'static [FamilyInfo];
    /// Where each row sits.
    fn layout(&self) -> &[RowLayout];
    /// Row `i` as last evaluated; `None` past the last row.
    fn row(&self, i: usize) -> Option<RowView<'_>>;
}

/// Any system's barrier set, evaluated on slices.
pub trait DynBarriers: DynRows + Send {
    /// Evaluate every row at `t`, `x` (`nx` values) and `params` (this system's, of this
    /// capacity).
    ///
    /// # Errors
    /// `x` of another length, parameters of another system, and everything
    /// [`BarrierSet::evaluate`] refuses. Rows are left as they were.
    fn evaluate(&mut self, t: f64, x: &[f64], params: &dyn DynParams) -> Result<(), CbfError>;
}

/// [`FilterSettings`] with its sizes at run time: one [`FamilyParams`] per family and one
/// weight and limit per input.
#[derive(Debug, Clone, PartialEq)]
pub struct DynSettings {
    /// Per family, in order.
    pub families: Vec<FamilyParams>,
    /// Per input: the QP's weight on `(u_j − u_ref,j)²`.
    pub input_weights: Vec<f64>,
    /// Per input: the lower limit.
    pub input_min: Vec<f64>,
    /// Per input: the upper limit.
    pub input_max: Vec<f64>,
    /// OSQP's settings.
    pub solver: SolverSettings,
    /// Read the thread's CPU clock around each update
    /// ([`FilterSettings::measure_cpu_time`]).
    pub measure_cpu_time: bool,
    /// Skip rows whose lower bound is above their activation threshold
    /// ([`FilterSettings::cull_far_rows`]).
    pub cull_far_rows: bool,
    /// Certify each answer between the samples ([`FilterSettings::sampled_data`]).
    pub sampled_data: Option<crate::filter::SampledData>,
}

impl<const NU: usize> From<FilterSettings<NU>> for DynSettings {
    fn from(s: FilterSettings<NU>) -> Self {
        Self {
            families: s.families,
            input_weights: s.input_weights.to_vec(),
            input_min: s.input_min.to_vec(),
            input_max: s.input_max.to_vec(),
            solver: s.solver,
            measure_cpu_time: s.measure_cpu_time,
            cull_far_rows: s.cull_far_rows,
            sampled_data: s.sampled_data,
        }
    }
}

fn sized<const N: usize>(what: &'static str, values: &[f64]) -> Result<[f64; N], CbfError> {
    values.try_into().map_err(|_| CbfError::LengthMismatch { what, expected: N, got: values.len() })
}

impl<const NU: usize> TryFrom<&DynSettings> for FilterSettings<NU> {
    type Error = CbfError;

    fn try_from(s: &DynSettings) -> Result<Self, CbfError> {
        Ok(Self {
            families: s.families.clone(),
            input_weights: sized("input_weights", &s.input_weights)?,
            input_min: sized("input_min", &s.input_min)?,
            input_max: sized("input_max", &s.input_max)?,
            solver: s.solver,
            measure_cpu_time: s.measure_cpu_time,
            cull_far_rows: s.cull_far_rows,
            sampled_data: s.sampled_data.clone(),
        })
    }
}

/// Any system's ECBF filter, updated on slices.
pub trait DynFilter: DynRows + Send {
    /// One update (see [`EcbfFilter::update_at`]); read the result with
    /// [`DynFilter::output`].
    ///
    /// # Errors
    /// `x` or `u_ref` of another length, parameters of another system, and everything
    /// [`EcbfFilter::update_at`] refuses; the filter is then unchanged.
    fn update(&mut self, t: f64, x: &[f64], u_ref: &[f64], params: &dyn DynParams) -> Result<(), CbfError>;
    /// The last update's result, its input as a slice.
    fn output(&self) -> Output<&[f64]>;
    /// The last update's input: `output().u` without assembling the whole output (the C
    /// interface's per-cycle read).
    fn input(&self) -> &[f64];
    /// The last update's safety verdict: `output().safety.verdict`, as cheaply.
    fn verdict(&self) -> Verdict;
    /// [`EcbfFilter::fallback_input`] into `out`.
    ///
    /// # Errors
    /// `u_ref` or `out` of another length than the inputs.
    fn fallback_input(&self, u_ref: &[f64], out: &mut [f64]) -> Result<(), CbfError>;
    /// Which rows took part in the last QP.
    fn active(&self) -> &[bool];
    /// Per row at the last returned input: by how much it is missed (see
    /// [`EcbfFilter::delta`]).
    fn delta(&self) -> &[f64];
    /// Per row: the slack relative to the row's terms, for relaxed rows (see
    /// [`EcbfFilter::relative_slack`]).
    fn relative_slack(&self) -> &[f64];
    /// Per row: why it was relaxed, for rows missed beyond the tolerance (see
    /// [`EcbfFilter::relaxed`]).
    fn relaxed(&self) -> &[Option<Cause>];
    /// Per family: the last update's relaxations (see [`EcbfFilter::relaxation`]).
    fn relaxation(&self) -> &[FamilyRelaxation];
    /// Per row: the sampled-data margin of the last update (see
    /// [`EcbfFilter::margins`]); all 0 without the certificate.
    fn margins(&self) -> &[f64];
    /// The settings the filter was built with.
    fn settings(&self) -> DynSettings;
    /// The most one update can do (see [`EcbfFilter::worst_case`]).
    fn worst_case(&self) -> WorstCase;
    /// This machine's rates for this filter's work, its rows evaluated at `t`, `x`,
    /// `params` (see [`EcbfFilter::calibrate`]; takes a second or so, allocates).
    ///
    /// # Errors
    /// `x` of another length, parameters of another system, and what
    /// [`EcbfFilter::calibrate`] refuses.
    fn calibrate(&mut self, t: f64, x: &[f64], params: &dyn DynParams) -> Result<Calibration, CbfError>;
}

/// Any generated system: sizes, names, dynamics, and factories for its parameters, rows
/// and filter.
pub trait DynSystem: Sync {
    /// The spec's name.
    fn name(&self) -> &'static str;
    /// The spec's description.
    fn doc(&self) -> &'static str;
    /// Number of states.
    fn nx(&self) -> usize;
    /// Number of inputs.
    fn nu(&self) -> usize;
    /// What each state is.
    fn state_names(&self) -> &'static [&'static str];
    /// What each input is.
    fn input_names(&self) -> &'static [&'static str];
    /// The spec's lower input limits.
    fn input_min(&self) -> &'static [f64];
    /// The spec's upper input limits.
    fn input_max(&self) -> &'static [f64];
    /// The barrier families, in order.
    fn families(&self) -> &'static [FamilyInfo];
    /// `f(x)` into `f` (`nx` values each).
    ///
    /// # Errors
    /// Lengths other than `nx`, or a state outside
    /// [`validate_state`](crate::system::validate_state)'s domain.
    fn drift(&self, x: &[f64], f: &mut [f64]) -> Result<(), CbfError>;
    /// `g(x)` into `g`, row-major (`nx × nu` values).
    ///
    /// # Errors
    /// As [`DynSystem::drift`].
    fn input_matrix(&self, x: &[f64], g: &mut [f64]) -> Result<(), CbfError>;
    /// `ẋ = f(x) + g(x) u` into `xdot` (`nx` values).
    ///
    /// # Errors
    /// As [`DynSystem::drift`], `u` of another length than `nu`, or an entry of `u`
    /// beyond [`domain::MAX_INPUT`](crate::filter::domain::MAX_INPUT) or not finite.
    fn xdot(&self, x: &[f64], u: &[f64], xdot: &mut [f64]) -> Result<(), CbfError>;
    /// Parameters with room for `capacity` (families not named get 0 slots).
    ///
    /// # Errors
    /// A count for a family that is not capacity-sized, or above its maximum.
    fn params(&self, capacity: &[CapacityCount]) -> Result<Box<dyn DynParams>, CbfError>;
    /// The rows laid out for the capacity `params` were sized for.
    ///
    /// # Errors
    /// Parameters of another system.
    fn barriers_for(&self, params: &dyn DynParams) -> Result<Box<dyn DynBarriers>, CbfError>;
    /// The spec's default filter settings.
    fn default_settings(&self) -> DynSettings;
    /// A filter over rows laid out for `capacity`.
    ///
    /// # Errors
    /// As [`DynSystem::params`], settings of other sizes, and everything
    /// [`EcbfFilter::new`] refuses.
    fn filter(&self, capacity: &[CapacityCount], settings: &DynSettings) -> Result<Box<dyn DynFilter>, CbfError>;
    /// Its generated kernels, in the module's order: for tools and cross-checks (a
    /// SymEngine comparison, Python's `call_kernel`), not for the control path.
    fn kernels(&self) -> Vec<KernelSignature>;
    /// Call kernel `name` with every input flattened, in order, into `inputs`; every
    /// output lands flattened likewise in `outputs` (matrices row by row, symmetric ones by
    /// their upper triangle). Nothing is validated beyond the lengths: a kernel is pure
    /// arithmetic and returns what the numbers give.
    ///
    /// # Errors
    /// [`CbfError::UnknownName`] for a kernel the system does not have;
    /// [`CbfError::LengthMismatch`] for lengths other than its slots'.
    fn call_kernel(&self, name: &str, inputs: &[f64], outputs: &mut [f64]) -> Result<(), CbfError>;

    /// Index of family `name`.
    ///
    /// # Errors
    /// [`CbfError::UnknownName`] listing the families.
    fn family_index(&self, name: &str) -> Result<usize, CbfError> {
        family_index(self.families(), name)
    }
}

/// Every generated system `S` as a [`DynSystem`]; generated modules export theirs as
/// `SYSTEM`.
pub struct Erased<S, const NX: usize, const NU: usize>(PhantomData<fn() -> S>);

impl<S, const NX: usize, const NU: usize> Erased<S, NX, NU> {
    /// The (zero-sized) erased system.
    pub const NEW: Self = Self(PhantomData);
}

/// `values` as a state of `N` entries.
fn state<const N: usize>(values: &[f64]) -> Result<&[f64; N], CbfError> {
    values.try_into().map_err(|_| CbfError::LengthMismatch { what: "state", expected: N, got: values.len() })
}

fn own<S: GeneratedSystem<NX, NU>, const NX: usize, const NU: usize>(
    params: &dyn DynParams,
) -> Result<&S::Params, CbfError> {
    params.downcast_ref::<S::Params>().ok_or(CbfError::SystemMismatch { expected: S::NAME, got: params.system() })
}

fn capacity<S: GeneratedSystem<NX, NU>, const NX: usize, const NU: usize>(
    counts: &[CapacityCount],
) -> Result<S::Capacity, CbfError> {
    let mut capacity = S::Capacity::default();
    for c in counts {
        let slot = capacity
            .count_mut(c.family, c.member)
            .ok_or_else(|| not_found(S::FAMILIES, c.family, c.member, "a capacity", "fixed-count"))?;
        *slot = c.count;
    }
    Ok(capacity)
}

impl<S: GeneratedSystem<NX, NU>, const NX: usize, const NU: usize> DynSystem for Erased<S, NX, NU> {
    fn name(&self) -> &'static str {
        S::NAME
    }
    fn doc(&self) -> &'static str {
        S::DOC
    }
    fn nx(&self) -> usize {
        NX
    }
    fn nu(&self) -> usize {
        NU
    }
    fn state_names(&self) -> &'static [&'static str] {
        const { &S::STATE_NAMES }
    }
    fn input_names(&self) -> &'static [&'static str] {
        const { &S::INPUT_NAMES }
    }
    fn input_min(&self) -> &'static [f64] {
        const { &S::INPUT_MIN }
    }
    fn input_max(&self) -> &'static [f64] {
        const { &S::INPUT_MAX }
    }
    fn families(&self) -> &'static [FamilyInfo] {
        S::FAMILIES
    }
    fn drift(&self, x: &[f64], f: &mut [f64]) -> Result<(), CbfError> {
        let x = state::<NX>(x)?;
        crate::system::validate_state(x)?;
        let n = f.len();
        let f: &mut [f64; NX] =
            f.try_into().map_err(|_| CbfError::LengthMismatch { what: "drift output", expected: NX, got: n })?;
        *f = S::drift(x);
        Ok(())
    }
    fn input_matrix(&self, x: &[f64], g: &mut [f64]) -> Result<(), CbfError> {
        let x = state::<NX>(x)?;
        crate::system::validate_state(x)?;
        if g.len() != NX * NU {
            return Err(CbfError::LengthMismatch { what: "input matrix output", expected: NX * NU, got: g.len() });
        }
        g.copy_from_slice(S::input_matrix(x).as_flattened());
        Ok(())
    }
    fn xdot(&self, x: &[f64], u: &[f64], xdot: &mut [f64]) -> Result<(), CbfError> {
        let x = state::<NX>(x)?;
        crate::system::validate_state(x)?;
        let u: &[f64; NU] =
            u.try_into().map_err(|_| CbfError::LengthMismatch { what: "input", expected: NU, got: u.len() })?;
        for &v in u {
            crate::filter::domain::input("input", v)?;
        }
        let n = xdot.len();
        let xdot: &mut [f64; NX] =
            xdot.try_into().map_err(|_| CbfError::LengthMismatch { what: "xdot output", expected: NX, got: n })?;
        *xdot = S::xdot(x, u);
        Ok(())
    }
    fn params(&self, counts: &[CapacityCount]) -> Result<Box<dyn DynParams>, CbfError> {
        Ok(Box::new(S::params(capacity::<S, NX, NU>(counts)?)?))
    }
    fn barriers_for(&self, params: &dyn DynParams) -> Result<Box<dyn DynBarriers>, CbfError> {
        let capacity = S::capacity_of(own::<S, NX, NU>(params)?);
        Ok(Box::new(ErasedBarriers::<S::Barriers, NX, NU>(S::barriers(capacity)?)))
    }
    fn default_settings(&self) -> DynSettings {
        FilterSettings::<NU>::defaults(S::FAMILIES, S::INPUT_MIN, S::INPUT_MAX).into()
    }
    fn kernels(&self) -> Vec<KernelSignature> {
        S::KERNELS.iter().map(KernelEntry::signature).collect()
    }
    fn call_kernel(&self, name: &str, inputs: &[f64], outputs: &mut [f64]) -> Result<(), CbfError> {
        let (index, signature) = find_kernel(S::NAME, &self.kernels(), name)?;
        signature.check_lengths(inputs, outputs)?;
        (S::KERNELS[index].call)(inputs, outputs);
        Ok(())
    }
    fn filter(&self, counts: &[CapacityCount], settings: &DynSettings) -> Result<Box<dyn DynFilter>, CbfError> {
        let barriers = S::barriers(capacity::<S, NX, NU>(counts)?)?;
        let filter = EcbfFilter::new(barriers, FilterSettings::<NU>::try_from(settings)?)?;
        Ok(Box::new(ErasedFilter::<S, NX, NU>(filter)))
    }
}

fn row_view<const NU: usize>(row: &crate::system::Row<NU>) -> RowView<'_> {
    RowView { lie: &row.lie, lg: &row.lg, active: row.active, culled: row.culled }
}

struct ErasedBarriers<B, const NX: usize, const NU: usize>(B);

impl<B, const NX: usize, const NU: usize> DynRows for ErasedBarriers<B, NX, NU>
where
    B: BarrierSet<NU, State = [f64; NX]>,
    B::Params: FlatParams,
{
    fn families(&self) -> &'static [FamilyInfo] {
        <B::Params as FlatParams>::FAMILIES
    }
    fn layout(&self) -> &[RowLayout] {
        self.0.layout()
    }
    fn row(&self, i: usize) -> Option<RowView<'_>> {
        self.0.rows().get(i).map(row_view)
    }
}

impl<B, const NX: usize, const NU: usize> DynBarriers for ErasedBarriers<B, NX, NU>
where
    B: BarrierSet<NU, State = [f64; NX]> + Send,
    B::Params: FlatParams,
{
    fn evaluate(&mut self, t: f64, x: &[f64], params: &dyn DynParams) -> Result<(), CbfError> {
        let p = params
            .downcast_ref::<B::Params>()
            .ok_or(CbfError::SystemMismatch { expected: <B::Params as FlatParams>::SYSTEM, got: params.system() })?;
        self.0.evaluate(t, state::<NX>(x)?, p)
    }
}

struct ErasedFilter<S: GeneratedSystem<NX, NU>, const NX: usize, const NU: usize>(EcbfFilter<S::Barriers, NU>);

impl<S: GeneratedSystem<NX, NU>, const NX: usize, const NU: usize> DynRows for ErasedFilter<S, NX, NU> {
    fn families(&self) -> &'static [FamilyInfo] {
        S::FAMILIES
    }
    fn layout(&self) -> &[RowLayout] {
        self.0.barriers().layout()
    }
    fn row(&self, i: usize) -> Option<RowView<'_>> {
        self.0.rows().get(i).map(row_view)
    }
}

impl<S: GeneratedSystem<NX, NU>, const NX: usize, const NU: usize> DynFilter for ErasedFilter<S, NX, NU> {
    fn update(&mut self, t: f64, x: &[f64], u_ref: &[f64], params: &dyn DynParams) -> Result<(), CbfError> {
        let u_ref: &[f64; NU] = u_ref.try_into().map_err(|_| CbfError::LengthMismatch {
            what: "nominal input",
            expected: NU,
            got: u_ref.len(),
        })?;
        self.0.update_at(t, state::<NX>(x)?, u_ref, own::<S, NX, NU>(params)?)?;
        Ok(())
    }
    fn output(&self) -> Output<&[f64]> {
        self.0.output().map_input(|u| u.as_slice())
    }
    fn input(&self) -> &[f64] {
        &self.0.output().u
    }
    fn verdict(&self) -> Verdict {
        self.0.output().safety.verdict
    }
    fn fallback_input(&self, u_ref: &[f64], out: &mut [f64]) -> Result<(), CbfError> {
        let what = "nominal input";
        let u_ref: &[f64; NU] =
            u_ref.try_into().map_err(|_| CbfError::LengthMismatch { what, expected: NU, got: u_ref.len() })?;
        let n = out.len();
        let out: &mut [f64; NU] =
            out.try_into().map_err(|_| CbfError::LengthMismatch { what: "fallback output", expected: NU, got: n })?;
        *out = self.0.fallback_input(u_ref);
        Ok(())
    }
    fn active(&self) -> &[bool] {
        self.0.active()
    }
    fn delta(&self) -> &[f64] {
        self.0.delta()
    }
    fn relative_slack(&self) -> &[f64] {
        self.0.relative_slack()
    }
    fn relaxed(&self) -> &[Option<Cause>] {
        self.0.relaxed()
    }
    fn relaxation(&self) -> &[FamilyRelaxation] {
        self.0.relaxation()
    }
    fn margins(&self) -> &[f64] {
        self.0.margins()
    }
    fn settings(&self) -> DynSettings {
        self.0.settings().clone().into()
    }
    fn worst_case(&self) -> WorstCase {
        self.0.worst_case()
    }
    fn calibrate(&mut self, t: f64, x: &[f64], params: &dyn DynParams) -> Result<Calibration, CbfError> {
        self.0.calibrate(t, state::<NX>(x)?, own::<S, NX, NU>(params)?)
    }
}

/// Systems by name, filled by whoever links them: a binary or binding lists the system
/// crates it depends on (each generated module has a `SYSTEM`), and users pick one by
/// name at run time. The core itself knows no system.
///
/// ```
/// use cbfgen::dynamic::{DynSystem, Registry};
///
/// static NONE: Registry = Registry::new(&[]);
/// assert!(NONE.get("pvtol").is_err());
/// assert_eq!(NONE.names().count(), 0);
/// ```
#[derive(Clone, Copy)]
pub struct Registry {
    systems: &'static [&'static dyn DynSystem],
}

impl Registry {
    /// The systems given, in the order given (names should be unique; the first wins).
    pub const fn new(systems: &'static [&'static dyn DynSystem]) -> Self {
        Self { systems }
    }

    /// The system named `name`, or [`CbfError::UnknownName`] listing the names there are.
    pub fn get(&self, name: &str) -> Result<&'static dyn DynSystem, CbfError> {
        self.systems.iter().copied().find(|s| s.name() == name).ok_or_else(|| CbfError::UnknownName {
            what: "system",
            name: name.to_string(),
            known: self.names().collect::<Vec<_>>().join(", "),
        })
    }

    /// Every system, in order.
    pub fn systems(&self) -> &'static [&'static dyn DynSystem] {
        self.systems
    }

    /// Every system's name, in order.
    pub fn names(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.systems.iter().map(|s| s.name())
    }
}

impl std::fmt::Debug for Registry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.names()).finish()
    }
}
