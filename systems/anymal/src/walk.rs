//! Seed 004's stepping-stone experiment on the rigid-contact [`plant`]: the kino-dynamic
//! MPC every [`WalkSettings::cycles_per_plan`] whole-body cycles on the measured state,
//! the whole-body controller at 400 Hz tracking its plan, the plant at 2 kHz, for each of
//! Table II's four controllers ([`Controller`]).
//!
//! Measured on the plant against the stones themselves ([`SteppingStones::misstep`]), not
//! the regions the controllers were given: each landing's misstep (how far the foot
//! centre's projection is from the nearest stone top) and height (the foot sphere's
//! lowest point above that stone's top: the plant's rigid contacts hold a foot wherever
//! its stance begins, so a foot that lands high stands on air and one that lands low
//! stands in the stone); every swing foot's barrier values against its target region
//! (Figs. 5–6) and the time they break eqs. 24 and 25.
//!
//! The plant has no unilateral contact, friction limit or impact: a fall shows as the
//! trunk sinking or a singular contact system, and is reported, not simulated. MuJoCo's
//! run (`cbfgen.physics.anymal`) is the one with those.

use cbfgen::error::{within, CbfError};

use crate::gait::{standing_on_the_ground, Trot};
use crate::mpc::{
    state_from_whole_body, FootholdConstraint, KinodynamicMpc, MpcReport, MpcSettings, Plan, Region, MAX_SIDES,
};
use crate::mpc_thread::MpcThread;
use crate::plant;
use crate::stones::SteppingStones;
use crate::terrain::{Footholds, Terrain};
use crate::vec3::dot;
use crate::wbc::{set_foothold, Growth, WbcOutput, WbcReference, WbcSettings, WholeBodyController, FEET};
use crate::wbc_generated::{self as gen, Capacity, Params};

/// Table II's four controllers: where the foothold constraints are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Controller {
    /// The CBF in the whole-body QP only; the MPC without footholds ("CBF-QP").
    CbfInQp,
    /// The CBF (eq. 25) in the MPC only ("CBF in MPC").
    CbfInMpc,
    /// Stance feet in their regions in the MPC (eq. 23), nothing in the QP ("MPC baseline").
    Baseline,
    /// The CBF in both layers: the seed's proposal ("CBF in QP & MPC").
    CbfInBoth,
}

impl Controller {
    /// All four, in Table II's order.
    pub const ALL: [Self; 4] = [Self::CbfInQp, Self::CbfInMpc, Self::Baseline, Self::CbfInBoth];

    /// Table II's name.
    pub fn name(self) -> &'static str {
        match self {
            Self::CbfInQp => "CBF-QP",
            Self::CbfInMpc => "CBF in MPC",
            Self::Baseline => "MPC baseline",
            Self::CbfInBoth => "CBF in QP & MPC",
        }
    }

    /// The MPC's foothold constraint under `settings` (eq. 25 on its set, with its γ).
    pub fn mpc_footholds(self, settings: &WalkSettings) -> FootholdConstraint {
        let gamma = settings.gamma;
        match (self, settings.barrier) {
            (Self::CbfInQp, _) => FootholdConstraint::Off,
            (Self::Baseline, _) => FootholdConstraint::StanceOnly,
            (Self::CbfInMpc | Self::CbfInBoth, FootholdBarrier::Region) => FootholdConstraint::Barrier { gamma },
            (Self::CbfInMpc | Self::CbfInBoth, FootholdBarrier::Shrinking) => {
                FootholdConstraint::ShrinkingBarrier { gamma, margin: settings.shrinking_margin }
            }
        }
    }

    fn whole_body_footholds(self) -> bool {
        matches!(self, Self::CbfInQp | Self::CbfInBoth)
    }
}

/// The set eq. 25's CBF keeps a swing foot in. The seed lost its equation bodies; its prose
/// fits both: "the foot placement constraints … posed as a CBF" (the region) after eq. 24's
/// swing-foot set "that shrinks in time and converges to the desired foot placement region".
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FootholdBarrier {
    /// The landing region itself, `h = d − n · c`: a foot lifting off outside it starts
    /// with `h < 0`.
    Region,
    /// Eq. 24's set: the region grown by `shrinking_margin` at lift-off, shrinking onto it
    /// at touchdown ([`Trot::shrinking_growth`]).
    Shrinking,
}

impl FootholdBarrier {
    /// Every reading, in [`FootholdBarrier::name`] order.
    pub const ALL: [Self; 2] = [Self::Region, Self::Shrinking];

    /// The reading's name, as Python and the command lines take it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Region => "region",
            Self::Shrinking => "shrinking",
        }
    }
}

/// The set eq. 26's CBF (in the whole-body QP) keeps a swing foot in. Measured in MuJoCo
/// (docs/anymal.md): on the set's extent the proposed controller broke eq. 25 for the least
/// time (on the region 3.6×, as a time-varying CBF 8× as long, with a misstep); before
/// the MPC aimed its swing feet at their regions it fell on the long fields with the other
/// two.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WholeBodyBarrier {
    /// The landing region: a foot lifting off outside it (15–25 cm on the stones) makes
    /// the rows ask an acceleration no foot has, and at priority 0 they take it from the
    /// trunk.
    Region,
    /// Eq. 24's set as it stands each cycle: its growth, not its shrinking, enters the
    /// rows (`h = d + m(t) − n · c` with `ṁ` taken as 0). The MPC's eq. 25 shrinks it over
    /// the swing; the whole-body QP keeps each foot within its current extent, and the
    /// row is the region's at touchdown.
    ShrinkingExtent,
    /// Eq. 24's set as a time-varying CBF (`ṁ`, `m̈` in the rows). Its rows (relative
    /// degree 2, poles at 10 /s) take the set's shrinking twice: a foot at rest is asked
    /// to be `−(m̈ + 20 ṁ) / 100 − m` inside its region, up to 23 cm (in a 5 cm region)
    /// just before mid-swing.
    Shrinking,
}

impl WholeBodyBarrier {
    /// Every reading, in [`WholeBodyBarrier::name`] order.
    pub const ALL: [Self; 3] = [Self::Region, Self::ShrinkingExtent, Self::Shrinking];

    /// The reading's name, as Python and the command lines take it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Region => "region",
            Self::ShrinkingExtent => "extent",
            Self::Shrinking => "shrinking",
        }
    }
}

/// The walk's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WalkSettings {
    /// How far inside a stone's edge its foothold region ends \[m\].
    pub margin: f64,
    /// The MPC's settings (its foothold constraint is the controller's).
    pub mpc: MpcSettings,
    /// The whole-body controller's settings.
    pub wbc: WbcSettings,
    /// The plant's step \[s\].
    pub plant_step: f64,
    /// Plant steps per whole-body cycle.
    pub steps_per_cycle: usize,
    /// Whole-body cycles per MPC iteration.
    pub cycles_per_plan: usize,
    /// Eq. 25's rate γ \[1/s\]: the MPC's CBF (where the controller has one) and the
    /// measurement of its violation. On the fixed region a swing foot lifting off its
    /// stone a stride (20 cm) behind its next region is asked for `γ · 0.15 m/s` at once:
    /// at 20 /s one MPC iteration in eight found no plan, at 5 /s none. On the shrinking
    /// set ([`FootholdBarrier::Shrinking`]) a swing foot at rest in its region is asked
    /// to be up to `max_s shrinking_margin · (g'(s)/γ − 1 + g(s))` inside it (the set
    /// shrinks fastest in mid-swing): 7.7 cm at 10 /s, more than the stones' 5 cm
    /// half-width (no MPC iteration found a plan), 1.9 cm at 20 /s, 0.7 cm at 30 /s. A
    /// larger γ also loosens the measurement itself, so 30 /s, chosen before, stays
    /// (docs/anymal.md has 20 and 40).
    pub gamma: f64,
    /// Eq. 24's growth of a swing foot's region at lift-off \[m\]: for its measurement and
    /// the shrinking set's CBFs.
    pub shrinking_margin: f64,
    /// The set eq. 25's CBF (in the MPC) keeps swing feet in, and on which its violation
    /// is measured.
    pub barrier: FootholdBarrier,
    /// The set eq. 26's CBF (in the whole-body QP) keeps swing feet in.
    pub whole_body_barrier: WholeBodyBarrier,
    /// The MPC in its own thread ([`MpcThread`]), posted every cycle, as the seed runs it;
    /// `false`: inline every `cycles_per_plan`-th cycle, deterministic. Threaded walks on
    /// the plant run in real time ([`walk`] paces them to the wall clock).
    pub threaded: bool,
}

impl WalkSettings {
    /// A whole-body cycle \[s\]: `plant_step · steps_per_cycle`.
    pub fn cycle(&self) -> f64 {
        self.plant_step * self.steps_per_cycle as f64
    }
}

impl Default for WalkSettings {
    /// A 2 cm margin; the MPC's and controller's defaults; 2 kHz, 400 Hz, 25 Hz; eq. 25 on
    /// eq. 24's shrinking set, growing the region by 25 cm at lift-off (a stride and a
    /// margin: a foot lifting off its stone starts inside), γ = 30 /s; eq. 26 on that set's
    /// extent each cycle.
    fn default() -> Self {
        Self {
            margin: 0.02,
            mpc: MpcSettings::default(),
            wbc: WbcSettings::default(),
            plant_step: 5e-4,
            steps_per_cycle: 5,
            cycles_per_plan: 16,
            gamma: 30.0,
            shrinking_margin: 0.25,
            barrier: FootholdBarrier::Shrinking,
            whole_body_barrier: WholeBodyBarrier::ShrinkingExtent,
            threaded: false,
        }
    }
}

/// One foot's landing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Landing {
    /// When \[s\].
    pub time: f64,
    /// Which foot (`LEGS` order).
    pub foot: usize,
    /// The foot sphere's centre (world) \[m\].
    pub position: [f64; 3],
    /// Its horizontal distance from the nearest stone top (0 on a stone) \[m\].
    pub misstep: f64,
    /// The sphere's lowest point above that stone's top \[m\] (negative: in it).
    pub height: f64,
    /// Where the plan the whole-body controller tracked put the foot at the swing's last
    /// cycle (the planned touchdown; the gait's own before the first plan) \[m\].
    pub planned: [f64; 3],
    /// The planned touchdown's horizontal distance from the nearest stone top \[m\]: a
    /// misstep the plan itself made (zero when only the execution missed).
    pub planned_misstep: f64,
}

/// What a walk did.
#[derive(Debug, Clone, PartialEq)]
pub struct WalkRecord {
    /// Every landing, in time order.
    pub landings: Vec<Landing>,
    /// When the walk stopped early (the trunk sank below half its standing height above
    /// the stones, the plant's contacts became singular or its state diverged), if it did
    /// \[s\].
    pub fell: Option<f64>,
    /// How far the trunk went (world x) \[m\].
    pub travelled: f64,
    /// MPC iterations that did not replace the plan, of all.
    pub mpc_failures: (usize, usize),
    /// Solver iterations (Newton steps, or ADMM's) over all MPC iterations.
    pub mpc_solver_iterations: u64,
    /// Whole-body cycles before the first plan (tracking the gait's own reference).
    pub unplanned: usize,
    /// Whole-body cycles not solved at every priority, of all.
    pub wbc_unsolved: (usize, usize),
    /// Total swing time of all feet \[s\].
    pub swing_time: f64,
    /// Time some swing foot broke eq. 24 (outside its region grown by
    /// [`Trot::shrinking_growth`] with `shrinking_margin`) \[s\].
    pub violated_24: f64,
    /// Time some swing foot broke eq. 25 (`ḣ + γ h < 0` on a side, `h` on the settings'
    /// [`FootholdBarrier`] set) \[s\].
    pub violated_25: f64,
    /// Each whole-body cycle's time and each foot's smallest barrier value `h` on its
    /// target region (swing: where it lands; stance: where it stands) \[m\].
    pub barriers: Vec<(f64, [f64; FEET])>,
    /// The same cycles' smallest `h` on eq. 24's set: a swing foot's region grown by
    /// [`Trot::shrinking_growth`], a stance foot's as in `barriers` \[m\].
    pub shrinking_barriers: Vec<[f64; FEET]>,
}

impl WalkRecord {
    /// Landings off every stone.
    pub fn missteps(&self) -> impl Iterator<Item = &Landing> {
        self.landings.iter().filter(|l| l.misstep > 0.0)
    }

    /// The mean misstep over the missteps \[m\] (0 with none).
    pub fn mean_misstep(&self) -> f64 {
        let (sum, n) = self.missteps().fold((0.0, 0), |(s, n), l| (s + l.misstep, n + 1));
        if n == 0 {
            0.0
        } else {
            sum / n as f64
        }
    }
}

/// Seed 004's two layers on a segmented terrain for any plant: every
/// [`update`](Self::update) is a whole-body cycle tracking the MPC's plan, with the foothold
/// constraints where the [`Controller`] puts them. The MPC runs inline every
/// [`WalkSettings::cycles_per_plan`]-th update on the measured state (deterministic), or,
/// with [`WalkSettings::threaded`], in its own thread ([`MpcThread`]) on the newest state
/// posted. Allocation-free after [`new`](Self::new).
#[derive(Debug)]
pub struct LayeredController {
    trot: Trot,
    footholds: Footholds,
    controller: Controller,
    settings: WalkSettings,
    upper: Upper,
    wbc: WholeBodyController,
    wbc_footholds: Params,
    cycles: usize,
}

/// Where a [`LayeredController`]'s MPC runs.
#[derive(Debug)]
enum Upper {
    /// Inline, every `cycles_per_plan`-th cycle: deterministic.
    Inline(Box<KinodynamicMpc>),
    /// In its own thread, posted every cycle; the newest plan copied in.
    Thread { thread: MpcThread, plan: Plan },
}

/// One cycle of a [`LayeredController`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayeredCycle {
    /// The whole-body controller's output (its torques drive the plant).
    pub out: WbcOutput,
    /// What it tracked: the plan's, or the gait's own while there is no plan.
    pub reference: WbcReference,
    /// Whether a plan exists (`false`: the first MPC iterations found none, and the
    /// gait's reference stood in).
    pub planned: bool,
    /// The MPC iteration this cycle ran, if it ran one (threaded: the one whose plan
    /// arrived this cycle).
    pub mpc: Option<MpcReport>,
    /// Each foot's region: where it stands, or for a swing foot where it lands.
    pub regions: [Region; FEET],
}

impl LayeredController {
    /// The two layers for `trot` over `terrain`.
    ///
    /// # Errors
    /// Settings the MPC or the whole-body controller refuse, or a margin a patch refuses
    /// ([`Footholds::new`]).
    pub fn new(
        trot: Trot,
        terrain: Terrain,
        controller: Controller,
        settings: &WalkSettings,
    ) -> Result<Self, CbfError> {
        within("whole-body cycles per MPC iteration", settings.cycles_per_plan as f64, 1.0, 1e4, "[1, 1e4]")?;
        within("walk time step [s]", settings.cycle(), 1e-5, 0.1, "[1e-5, 0.1]")?;
        let mpc_settings = MpcSettings { footholds: controller.mpc_footholds(settings), ..settings.mpc };
        let sides = if controller.whole_body_footholds() { MAX_SIDES } else { 0 };
        let capacity = Capacity { foot_region: [sides; FEET] };
        let footholds = Footholds::new(terrain, settings.margin)?;
        let mpc = KinodynamicMpc::new(mpc_settings)?;
        let upper = if settings.threaded {
            let plan = Plan::new(mpc_settings.horizon, mpc_settings.dt);
            Upper::Thread { thread: MpcThread::spawn(mpc, trot, footholds.clone())?, plan }
        } else {
            Upper::Inline(Box::new(mpc))
        };
        Ok(Self {
            trot,
            footholds,
            controller,
            settings: *settings,
            upper,
            wbc: WholeBodyController::new(capacity, settings.wbc)?,
            wbc_footholds: Params::new(capacity)?,
            cycles: 0,
        })
    }

    /// The gait.
    pub fn trot(&self) -> &Trot {
        &self.trot
    }

    /// The foothold regions.
    pub fn footholds(&self) -> &Footholds {
        &self.footholds
    }

    /// Threaded: the MPC thread's solves so far, and of them those that found no plan
    /// (inline, the cycles' reports count them).
    pub fn thread_solves(&self) -> Option<(u64, u64)> {
        match &self.upper {
            Upper::Inline(_) => None,
            Upper::Thread { thread, .. } => Some(thread.solves()),
        }
    }

    /// The plan the controller tracks.
    pub fn plan(&self) -> &Plan {
        match &self.upper {
            Upper::Inline(mpc) => mpc.latest(),
            Upper::Thread { plan, .. } => plan,
        }
    }

    /// One whole-body cycle at time `t` on the measured state `x` (the
    /// [`wbc_generated`](crate::wbc_generated) layout), an MPC iteration first when due.
    ///
    /// # Errors
    /// A non-finite state or time. The controllers' states are then unchanged.
    pub fn update(&mut self, t: f64, x: &[f64; gen::NX]) -> Result<LayeredCycle, CbfError> {
        cbfgen::error::finite("time", t)?;
        for v in x {
            cbfgen::error::finite("state", *v)?;
        }
        let (trot, footholds) = (&self.trot, &self.footholds);
        let region = |foot: usize, time: f64| footholds.region(trot, foot, time);
        let (mpc, plan) = match &mut self.upper {
            Upper::Inline(mpc) => {
                let due = self.cycles.is_multiple_of(self.settings.cycles_per_plan);
                let report = if due { Some(mpc.solve(t, &state_from_whole_body(x), trot, &region)?) } else { None };
                (report, mpc.latest())
            }
            Upper::Thread { thread, plan } => {
                thread.post(t, &state_from_whole_body(x));
                (thread.take(plan), &*plan)
            }
        };
        let planned = plan.whole_body_reference(t, trot);
        let reference = planned.unwrap_or_else(|| trot.reference(t));
        let regions: [Region; FEET] = std::array::from_fn(|foot| region(foot, t));
        if self.controller.whole_body_footholds() {
            // Eq. 26 on its set: a swing foot's shrinking one closes onto its region.
            let [m, rate, curvature] = trot.shrinking_growth(self.settings.shrinking_margin, t);
            let swinging = match self.settings.whole_body_barrier {
                WholeBodyBarrier::Region => Growth::NONE,
                WholeBodyBarrier::ShrinkingExtent => Growth { derivatives: [m, 0.0, 0.0], at: t },
                WholeBodyBarrier::Shrinking => Growth { derivatives: [m, rate, curvature], at: t },
            };
            for (foot, r) in regions.iter().enumerate() {
                let growth = if reference.stance[foot] { Growth::NONE } else { swinging };
                set_foothold(&mut self.wbc_footholds, foot, r, growth)?;
            }
        }
        let dt = self.settings.cycle();
        let out = self.wbc.update(t, x, &reference, &self.wbc_footholds, dt)?;
        self.cycles += 1;
        Ok(LayeredCycle { out, reference, planned: planned.is_some(), mpc, regions })
    }
}

/// Walk `stones` with `controller` on the rigid-contact plant.
///
/// # Errors
/// What [`LayeredController::new`] refuses.
pub fn walk(stones: &SteppingStones, controller: Controller, settings: &WalkSettings) -> Result<WalkRecord, CbfError> {
    let trot = *stones.trot();
    let mut layers = LayeredController::new(trot, stones.terrain().clone(), controller, settings)?;
    let mut x = standing_on_the_ground();
    let dt = settings.cycle();
    let cycles = (stones.end() / dt).ceil() as usize;
    let standing_height = x[2];
    let mut meter = WalkMeter::new(stones, settings);
    let clock = std::time::Instant::now();
    for cycle in 0..cycles {
        let t = cycle as f64 * dt;
        if settings.threaded {
            // Real time: the MPC thread's plans are as late as its solves make them.
            let ahead = t - clock.elapsed().as_secs_f64();
            if ahead > 0.0 {
                std::thread::sleep(std::time::Duration::from_secs_f64(ahead));
            }
        }
        let step = layers.update(t, &x)?;
        let (feet, jacobians, _) = gen::contacts(&x);
        let velocities: [[f64; 3]; FEET] = std::array::from_fn(|foot| {
            std::array::from_fn(|a| (0..gen::NU).map(|j| jacobians[3 * foot + a][j] * x[24 + j]).sum())
        });
        meter.observe(t, &step, &feet, &velocities);
        let mut singular = false;
        for _ in 0..settings.steps_per_cycle {
            let Some(accelerations) = plant::accelerations(&x, &step.out.torques, step.reference.stance) else {
                singular = true;
                break;
            };
            plant::integrate(&mut x, &accelerations.accelerations, settings.plant_step);
        }
        let ground = feet.iter().map(|p| stones.nearest_top(p[0], p[1])).sum::<f64>() / FEET as f64;
        // A state far outside anything a walk reaches (the plant diverging) is a fall too,
        // not an error: the controller refuses it next cycle.
        let diverged = x.iter().any(|v| !v.is_finite() || v.abs() > 1e3);
        if singular || diverged || x[2] - ground < 0.5 * standing_height {
            meter.fell(t);
            break;
        }
    }
    Ok(meter.finish(x[0] - layers.trot().trunk[0]))
}

/// Table II's measurements of a walk on `stones`, from what a plant says each cycle: its
/// feet's centres and velocities (world), judged against the stones themselves.
#[derive(Debug, Clone)]
pub struct WalkMeter {
    stones: SteppingStones,
    gamma: f64,
    shrinking_margin: f64,
    barrier: FootholdBarrier,
    dt: f64,
    was_stance: [bool; FEET],
    planned: [[f64; 3]; FEET],
    record: WalkRecord,
}

impl WalkMeter {
    /// A meter for a walk on `stones` under `settings` (its γ, eq. 24's margin, its cycle).
    pub fn new(stones: &SteppingStones, settings: &WalkSettings) -> Self {
        Self {
            stones: stones.clone(),
            gamma: settings.gamma,
            shrinking_margin: settings.shrinking_margin,
            barrier: settings.barrier,
            dt: settings.cycle(),
            was_stance: [true; FEET],
            planned: [[0.0; 3]; FEET],
            record: WalkRecord {
                landings: Vec::new(),
                fell: None,
                travelled: 0.0,
                mpc_failures: (0, 0),
                mpc_solver_iterations: 0,
                unplanned: 0,
                wbc_unsolved: (0, 0),
                swing_time: 0.0,
                violated_24: 0.0,
                violated_25: 0.0,
                barriers: Vec::new(),
                shrinking_barriers: Vec::new(),
            },
        }
    }

    /// Take one cycle: what the controller did at `t` and the feet's centres and
    /// velocities then (world).
    pub fn observe(&mut self, t: f64, cycle: &LayeredCycle, feet: &[[f64; 3]; FEET], velocities: &[[f64; 3]; FEET]) {
        let trot = self.stones.trot();
        let record = &mut self.record;
        if let Some(report) = cycle.mpc {
            record.mpc_failures.0 += usize::from(!report.updated);
            record.mpc_failures.1 += 1;
            record.mpc_solver_iterations += u64::from(report.iterations);
        }
        record.unplanned += usize::from(!cycle.planned);
        record.wbc_unsolved.0 += usize::from(!cycle.out.solved);
        record.wbc_unsolved.1 += 1;
        let stance = cycle.reference.stance;
        let mut smallest = [f64::INFINITY; FEET];
        let (mut broke_24, mut broke_25) = (false, false);
        let [grow, rate, _] = trot.shrinking_growth(self.shrinking_margin, t);
        // Eq. 25's set on a swing foot: its growth and the growth's rate.
        let (barrier_grow, barrier_rate) = match self.barrier {
            FootholdBarrier::Region => (0.0, 0.0),
            FootholdBarrier::Shrinking => (grow, rate),
        };
        for foot in 0..FEET {
            let r = &cycle.regions[foot];
            for (n, d) in r.sides.iter().take(r.count) {
                let h = d - dot(n, &feet[foot]);
                smallest[foot] = smallest[foot].min(h);
                if !stance[foot] {
                    broke_24 |= h + grow < 0.0;
                    broke_25 |= -dot(n, &velocities[foot]) + barrier_rate + self.gamma * (h + barrier_grow) < 0.0;
                }
            }
            if !stance[foot] {
                record.swing_time += self.dt;
            }
            if stance[foot] && !self.was_stance[foot] {
                let (p, q) = (feet[foot], self.planned[foot]);
                record.landings.push(Landing {
                    time: t,
                    foot,
                    position: p,
                    misstep: self.stones.misstep(p[0], p[1]),
                    height: p[2] - gen::FOOT_RADIUS - self.stones.nearest_top(p[0], p[1]),
                    planned: q,
                    planned_misstep: self.stones.misstep(q[0], q[1]),
                });
            }
            if !stance[foot] {
                self.planned[foot] = cycle.reference.feet[foot].position;
            }
            self.was_stance[foot] = stance[foot];
        }
        record.violated_24 += if broke_24 { self.dt } else { 0.0 };
        record.violated_25 += if broke_25 { self.dt } else { 0.0 };
        record.barriers.push((t, smallest));
        record
            .shrinking_barriers
            .push(std::array::from_fn(|foot| smallest[foot] + if stance[foot] { 0.0 } else { grow }));
    }

    /// Mark a fall at `t` (the first one counts).
    pub fn fell(&mut self, t: f64) {
        self.record.fell.get_or_insert(t);
    }

    /// The record so far.
    pub fn record(&self) -> &WalkRecord {
        &self.record
    }

    /// The record, with how far the trunk went \[m\].
    pub fn finish(mut self, travelled: f64) -> WalkRecord {
        self.record.travelled = travelled;
        self.record
    }
}
