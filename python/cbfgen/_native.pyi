# Type stubs for the Rust extension module (python/src/). The generic part is re-exported
# by `cbfgen`, Tachyon 3's own by `cbfgen.tachyon3`. Arrays out are new float64 numpy
# arrays, finite: a kernel value that would be NaN or infinite raises CbfError instead,
# and a diagnostic array of rows (lie, lg_lf) that would hold one is None. The only inf
# are documented sentinels where nothing applies (simulate's min_h and
# toe_riser_clearance, Course.clearance's riser entry).
# "ArrayLike" inputs accept lists, tuples and arrays of booleans, integers or floats, read
# as float64; complex, string and object arrays raise ValueError. Shapes
# are exact: a vector of N values is (N,); a matrix parameter is (r, c) or its r*c values
# row by row; a rotation is 9 row-major values (9,) or a 3x3 array.
# Counts outside their integer type (negative, >= 2**64) raise OverflowError.
# python/tests/test_api.py checks that this file and the module list the same names.

import os
from collections.abc import Mapping, Sequence
from typing import Any, Literal, NotRequired, TypedDict

import numpy as np
import numpy.typing as npt

ArrayLike = npt.ArrayLike
Vector = npt.NDArray[np.float64]
Matrix = npt.NDArray[np.float64]
Leg = int | str
"""A leg: its index in LEG_NAMES order (0..6) or its name ("LF", "mf", ...)."""
Member = int | str
"""A member of an indexed family: its index or its name (case-insensitive)."""
Values = Mapping[str, ArrayLike] | ArrayLike
"""One instance's parameters: {name: value} with every parameter of the family, or one
flat vector of all of them in declaration order (matrices row by row)."""
RowPlace = tuple[str, str | None, int, str]
"""Where a row sits: (family, member or None, instance, row name)."""
SsatVariant = Literal["lse_xtanh", "lse_sqrt", "boltzmann_xtanh", "boltzmann_sqrt"]
Backend = Literal["dense", "osqp", "dense_then_osqp"]
"""A filter's solver (SOLVERS): the dense solve only, OSQP only, or the dense solve with
OSQP when it does not verify within dense_max_steps."""

ParamDomain = (
    tuple[Literal["real"]]
    | tuple[Literal["positive"]]
    | tuple[Literal["non_negative"]]
    | tuple[Literal["interval"], float, float]
    | tuple[Literal["unit_vector"], float]
    | tuple[Literal["rotation"], float]
)
"""A parameter's domain (every entry also finite, within PARAM_LIMIT): ("real",);
("positive",) every entry > 0; ("non_negative",) >= 0; ("interval", lo, hi); ("unit_vector",
tol) a vector of length 1 within tol; ("rotation", tol) a matrix with R^T R within tol of I
and det R > 0."""

class FamilyInfo(TypedDict):
    name: str
    kind: Literal["barrier", "lyapunov"]
    """A CBF (h >= 0 kept), or a CLF whose rows are h = -V (the decrease V' + rate V <= 0)."""
    relative_degree: int
    row_names: list[str]
    members: list[str]
    instances: Literal["fixed", "optional", "capacity"]
    count: int
    """Instances per member (fixed, optional), or the largest capacity per member."""
    params: list[tuple[str, list[int]]]
    """(name, shape) per parameter: [] a scalar, [n] a vector, [r, c] a matrix."""
    domains: dict[str, ParamDomain]
    """Each parameter's domain, which Params.set/push enforce (CbfError outside it)."""
    poles: list[float]
    priority: int
    """Who yields when rows conflict: 0 is met first (0 ..= 15)."""
    activation: float
    class_k: str
    """The last ECBF term's alpha(s) as the spec wrote it ("s": the plain ECBF)."""

class SolverSettings(TypedDict):
    backend: Backend
    dense_max_steps: int
    dense_max_work: int
    eps_abs: float
    eps_rel: float
    max_iter: int
    polish: bool
    time_limit_us: float | None

class UpdateWork(TypedDict):
    qp_solves: int
    dense_trips: int
    """The dense solver's inner-loop trips over every solve."""
    osqp_iterations: int

class WorstCase(TypedDict):
    """The most one update can do (``EcbfFilter.worst_case``)."""

    qp_solves: int
    dense_trips: int
    osqp_iterations: int
    row_ops: int | None
    """One row evaluation's floating-point operations as the kernels state them."""
    enclosures: int
    """The certificate's enclosures per update (0 without it)."""
    interval_ops: int | None
    """Their interval operations (0 without the certificate)."""
    cpu_time_us: NotRequired[float | None]
    """With a calibration: the bound in CPU time on that machine."""

class Calibration(TypedDict):
    """This machine's slowest rate per unit of work (``EcbfFilter.calibrate``)."""

    ns_per_dense_trip: float
    ns_per_osqp_iteration: float
    ns_per_row_op: float
    ns_per_interval_op: float
    """0 without ``sample_period``."""

class CbfError(ValueError):
    """An error reported by cbfgen's Rust core (bad value, capacity, solver set-up...)."""

MAX_ITERATIONS: int
"""Largest EcbfFilter max_iter and dense_max_steps."""
MAX_TIME_LIMIT_US: float
"""Largest EcbfFilter time_limit_us (1 s)."""
MAX_INPUT: float
"""Largest |nominal input| and |input limit| the filter accepts."""
STATE_LIMIT: float
"""Largest |state entry| accepted by the kernels, the filter and the course."""
PARAM_LIMIT: float
"""Largest |parameter value| a family accepts."""
MAX_INSTANCES: int
"""Largest capacity of one capacity family (each family may set a lower one)."""
POLE_RANGE: tuple[float, float]
"""Accepted ECBF poles, inclusive."""
MAX_PRIORITY: int
"""Largest family priority (0 is met first)."""
SSAT_ALPHA_RANGE: tuple[float, float]
"""Accepted SSAT alpha and alpha_rot, inclusive."""
MAX_COORDINATE: float
"""Largest |box centre coordinate| [m] (ssat boxes, edge cuboids)."""
HALF_EXTENT_RANGE: tuple[float, float]
"""Accepted box half extents [m], inclusive."""
SSAT_VARIANTS: list[str]
INPUT_SOURCES: list[str]
SOLVERS: list[str]
"""The EcbfFilter backend choices: "dense", "osqp", "dense_then_osqp"."""

# ---------------------------------------------------------------- any system
def systems() -> list[str]:
    """The names of every built-in system, then of every system loaded with cbfgen.load."""

def core_sources() -> list[tuple[str, bytes]]:
    """The core's sources this module was built from, ``(path relative to the repository,
    contents)``: what cbfgen.load builds a spec against when no clone is at hand."""

PLUGIN_ABI_VERSION: int

def load_plugin(path: str | os.PathLike[str]) -> System:
    """The system of a plugin library (what cbfgen.load builds), checked for its ABI and
    core version; a path loads once per process."""

class System:
    """A generated system by name: sizes, names, dynamics, families; factories for its
    parameters, rows and filter. Raises CbfError for an unknown name."""

    def __init__(self, name: str) -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def doc(self) -> str: ...
    @property
    def nx(self) -> int: ...
    @property
    def nu(self) -> int: ...
    @property
    def state_names(self) -> list[str]: ...
    @property
    def input_names(self) -> list[str]: ...
    @property
    def input_min(self) -> Vector: ...
    @property
    def input_max(self) -> Vector: ...
    @property
    def families(self) -> list[FamilyInfo]: ...
    def drift(self, x: ArrayLike) -> Vector:
        """f(x), shape (nx,). Raises CbfError for an entry not finite or beyond STATE_LIMIT."""
    def input_matrix(self, x: ArrayLike) -> Matrix:
        """g(x), shape (nx, nu)."""
    def xdot(self, x: ArrayLike, u: ArrayLike) -> Vector:
        """f(x) + g(x) u, shape (nx,)."""
    def params(self, capacity: Mapping[str, int | Sequence[int]] | None = None) -> Params:
        """Parameters with room for capacity ({family: count, or a count per member})."""
    def rows(self, x: ArrayLike, params: Params, t: float = 0.0) -> Rows:
        """Every row at time t, state x and params (laid out for their capacity)."""
    def filter(self, capacity: Params | Mapping[str, int | Sequence[int]] | None = None,
               **settings: object) -> EcbfFilter:
        """EcbfFilter(self, capacity, **settings)."""

class Params:
    """Every family's run-time instances for one system and capacity. Families by name,
    members of an indexed family by name or index (member=None: the only one, or for
    clear/set_enabled every member). Nothing changes when a call raises."""

    @property
    def system(self) -> str: ...
    @property
    def capacity(self) -> dict[str, int | list[int]]:
        """Slots of every capacity family: a count, or a list per member (what params()
        and filter() take)."""
    def set(self, family: str, values: Values, *, member: Member | None = None, instance: int = 0) -> None:
        """Set a fixed or optional instance, or one already pushed. CbfError (a ValueError)
        for a value outside its parameter's domain (a half extent <= 0, a matrix that is
        not a proper rotation, a normal not of unit length, NaN...), naming family,
        member, instance and parameter; nothing changes then."""
    def push(self, family: str, values: Values, *, member: Member | None = None) -> None:
        """Append an instance to a capacity family; CbfError when it is full, or for a
        value outside its parameter's domain (as set)."""
    def get(
        self, family: str, *, member: Member | None = None, instance: int = 0
    ) -> dict[str, float | Vector | Matrix] | None:
        """An instance's parameters, or None for an empty slot."""
    def remove(self, family: str, *, member: Member | None = None, instance: int = 0) -> None:
        """Empty an optional slot."""
    def clear(self, family: str, *, member: Member | None = None) -> None:
        """Remove every instance of a capacity or optional family."""
    def set_enabled(self, family: str, enabled: bool, *, member: Member | None = None) -> None:
        """Switch a capacity family's rows on or off, keeping its instances."""
    def is_enabled(self, family: str, *, member: Member | None = None) -> bool: ...
    def count(self, family: str, *, member: Member | None = None) -> int:
        """Instances present."""
    def copy(self) -> Params: ...

class Rows:
    """Rows as evaluated by System.rows."""

    @property
    def layout(self) -> list[RowPlace]: ...
    @property
    def lie(self) -> Matrix | None:
        """[h, L_f h, ..., L_f^r h] per row (zeros past its degree), (rows, max degree + 1);
        None when a value is not finite (a degenerate state)."""
    @property
    def lg_lf(self) -> Matrix | None:
        """L_g L_f^(r-1) h per row, (rows, nu); None when a value is not finite."""
    @property
    def applicable(self) -> list[bool]: ...
    def __len__(self) -> int: ...

class RelaxedRow(TypedDict):
    """One row an update relaxed (FilterOutput.relaxed)."""

    row: int
    place: RowPlace
    slack: float
    """By how much it is missed, -(a.u + b), in the row's units (those of h^(r))."""
    relative: float
    """The slack over the row's terms |b| + sum_j |a_j u_j|."""
    cause: Literal["input_limit", "higher_priority", "same_priority", "no_authority", "unsolved"]
    input: str | None
    """The input at its limit (cause "input_limit")."""
    limit: Literal["min", "max"] | None
    other_row: int | None
    """The row it yields to (cause "higher_priority" or "same_priority")."""
    other_place: RowPlace | None

class FamilyRelaxation(TypedDict):
    relaxed_rows: int
    max_slack: float
    max_relative: float

class FilterOutput:
    """One update's result: the input, how the solve ended, and (separately) whether every
    active row holds at that input."""

    @property
    def u(self) -> Vector: ...
    @property
    def source(self) -> Literal["qp", "unconverged", "last_safe", "nominal_clipped"]: ...
    @property
    def status(self) -> str | None: ...
    @property
    def nonfinite_row(self) -> int | None: ...
    @property
    def iterations(self) -> int:
        """OSQP's ADMM iterations this cycle; 0 when OSQP did not run."""
    @property
    def backend(self) -> Literal["dense", "osqp"] | None:
        """Which solver answered: "dense" or "osqp"; None when no solve ran."""
    @property
    def dense_steps(self) -> int:
        """Active-set changes of the dense solve over its stages (0 when it did not run)."""
    @property
    def dense_fallback(self) -> bool:
        """The dense solve's first stage did not verify within its budget (OSQP ran)."""
    @property
    def verdict(self) -> Literal["met", "relaxed", "unassessed"]:
        """Measured at u, whatever its source: every active row holds, some are relaxed
        (see relaxed), or a row was not finite."""
    @property
    def relaxed_rows(self) -> int: ...
    @property
    def between_samples(self) -> Literal["off", "certified", "uncertified"]:
        """With sample_period set: whether every active row met at u keeps its ECBF
        condition over the whole period the input is held (see uncertified_why)."""
    @property
    def uncertified_why(self) -> Literal["deficit", "no_interval_form", "flow", "not_solved"] | None: ...
    @property
    def convergence(self) -> Literal["met", "relaxed", "unassessed"]:
        """The Lyapunov families' verdict (never part of verdict): every decrease
        V' + rate V <= 0 holds at u (or there is none), or some gave way (in relaxed)."""
    @property
    def relaxed(self) -> list[RelaxedRow]:
        """Every active row missed at u beyond the solver's tolerance, with why."""
    @property
    def worst(self) -> RelaxedRow | None:
        """The relaxed row with the largest relative slack."""
    @property
    def relaxation(self) -> dict[str, FamilyRelaxation]:
        """Per family name: its relaxed rows and their largest slack this update."""
    @property
    def polished(self) -> bool: ...
    @property
    def active_rows(self) -> int: ...
    @property
    def consecutive_fallbacks(self) -> int: ...
    @property
    def work(self) -> UpdateWork:
        """The work this update did, counted as it ran."""
    @property
    def eval_time_us(self) -> float: ...
    @property
    def solve_time_us(self) -> float: ...
    @property
    def cpu_time_us(self) -> float | None:
        """The thread's CPU time over the whole update [us], beside its wall time
        eval_time_us + solve_time_us (far less CPU than wall = the thread waited). None
        unless the filter was built with measure_cpu_time=True, or where the platform has
        no per-thread clock."""

class EcbfFilter:
    """The ECBF-QP safety filter of any system. Its rows are laid out for a capacity:
    give the Params it will run with (their capacities taken), or {family: count}; with
    none, the first update's Params give theirs (a later Params of other capacities is a
    CbfError naming the fix). Keyword settings override the spec's
    defaults: activation, priority and poles map family names to values;
    input_weights, input_min, input_max have nu values; backend picks the solver (one of
    SOLVERS, else ValueError) and dense_max_steps bounds the dense solve (1 ..=
    MAX_ITERATIONS, else CbfError), dense_max_work its work in inner-loop trips (1 ..=
    1e10; 2e6 by default); eps_abs, eps_rel, max_iter, polish and time_limit_us
    tune OSQP; measure_cpu_time=True reads the thread's CPU clock around each update
    (off by default: each reading is a system call); cull_far_rows=False evaluates every
    row every cycle (by default rows whose lower bound is above their activation threshold
    are skipped: the same input, less work). sample_period [s] certifies each answer for
    the period it is held (the output's between_samples, margins per row), with
    input_delay, certify_rounds (solves per update, 1-16) and certify_exempt (family
    names)."""

    def __init__(
        self,
        system: str | System,
        capacity: Params | Mapping[str, int | Sequence[int]] | None = None,
        *,
        activation: Mapping[str, float] | None = None,
        priority: Mapping[str, int] | None = None,
        poles: Mapping[str, Sequence[float]] | None = None,
        input_weights: ArrayLike | None = None,
        input_min: ArrayLike | None = None,
        input_max: ArrayLike | None = None,
        backend: Backend | None = None,
        dense_max_steps: int | None = None,
        dense_max_work: int | None = None,
        eps_abs: float | None = None,
        eps_rel: float | None = None,
        max_iter: int | None = None,
        polish: bool | None = None,
        time_limit_us: float | None = None,
        measure_cpu_time: bool | None = None,
        cull_far_rows: bool | None = None,
        sample_period: float | None = None,
        input_delay: bool | None = None,
        certify_rounds: int | None = None,
        certify_exempt: Sequence[str] | None = None,
    ) -> None: ...
    @property
    def system(self) -> str: ...
    def update(self, x: ArrayLike, u_ref: ArrayLike, params: Params, t: float = 0.0) -> FilterOutput:
        """One control update. Raises CbfError for NaN/inf input or parameters of another
        system or capacity (the filter is then unchanged); releases the GIL."""
    def fallback_input(self, u_ref: ArrayLike) -> Vector: ...
    @property
    def output(self) -> FilterOutput: ...
    @property
    def row_count(self) -> int: ...
    @property
    def layout(self) -> list[RowPlace]: ...
    @property
    def lie(self) -> Matrix | None:
        """Every row's [h, L_f h, ...] at the last update; None when a value is not finite."""
    @property
    def lg_lf(self) -> Matrix | None: ...
    @property
    def applicable(self) -> list[bool]: ...
    @property
    def culled(self) -> list[bool]:
        """Rows not evaluated at the last update: their family's lower bound was above the
        activation threshold (h holds that bound). All False with cull_far_rows=False."""
    @property
    def active(self) -> list[bool]: ...
    @property
    def slack(self) -> Vector:
        """Per row at the last returned input: by how much it is missed (0 when met)."""
    @property
    def margins(self) -> Vector:
        """Per row: the margin the last update asked of it at the sample to certify the
        period (all 0 without sample_period)."""
    @property
    def family_settings(self) -> dict[str, tuple[list[float], int, float]]:
        """Per family: (poles, priority, activation) in use."""
    @property
    def solver_settings(self) -> SolverSettings:
        """The solver settings in use, as the keywords of the same names set them."""
    def worst_case(self, calibration: Calibration | None = None) -> WorstCase:
        """The most one update can do, from the rows and settings alone; with a
        calibration also in CPU time (``cpu_time_us``)."""
    def calibrate(self, x: ArrayLike, params: Params, t: float = 0.0) -> Calibration:
        """This machine's rates for this filter's work (a second or so)."""

# ---------------------------------------------------------------------- SSAT
def ssat(
    p_a: ArrayLike, r_a: ArrayLike, half_a: ArrayLike,
    p_b: ArrayLike, r_b: ArrayLike, half_b: ArrayLike,
    alpha: float = 200.0, alpha_rot: float = 200.0, variant: SsatVariant = "lse_xtanh",
) -> float:
    """Smooth SAT value h of boxes A and B (> 0 apart, < 0 overlapping).

    Raises CbfError for a centre beyond MAX_COORDINATE, half extents outside
    HALF_EXTENT_RANGE, an improper rotation (a reflection, or not orthonormal within
    1e-9), alpha or alpha_rot outside SSAT_ALPHA_RANGE, or a value that is not finite."""

def ssat_derivatives(
    p_a: ArrayLike, r_a: ArrayLike, half_a: ArrayLike,
    p_b: ArrayLike, r_b: ArrayLike, half_b: ArrayLike,
    alpha: float = 200.0, alpha_rot: float = 200.0, variant: SsatVariant = "lse_xtanh",
) -> tuple[float, Vector, Matrix]:
    """(h, gradient (3,), hessian (3, 3)) with respect to box B's centre."""

def ssat_margin(
    half_a: ArrayLike, half_b: ArrayLike,
    alpha: float = 200.0, alpha_rot: float = 200.0, variant: SsatVariant = "lse_xtanh",
) -> float:
    """Certified margin m: ssat(...) - m >= 0 proves the exact boxes do not overlap."""

# ------------------------------------------------------------- kernel table
def kernel_table() -> list[tuple[str, str, list[tuple[str, int]], list[tuple[str, int]]]]:
    """Every generated kernel of every built-in system: (module, name, inputs, outputs), each
    input and output as (name, number of values), in the kernel's order."""

def call_kernel(module: str, name: str, inputs: ArrayLike) -> Vector:
    """Kernel ``module::name`` with every input flattened in order into one vector; every
    output flattened likewise (matrices row by row, symmetric ones by upper triangle)."""

# ------------------------------------------------------- Tachyon 3 (cbfgen.tachyon3)
LEG_NAMES: list[str]
TOE_RADIUS: float
BODY_HALF_EXTENTS: list[float]
NOMINAL_CLEARANCE: float
"""Body underside above ground in the standard posture [m]."""
KNEE_RANGE: list[float]
"""Knee length limits [m]."""
HIP_POSITIONS: list[list[float]]
"""Hip mounts, body frame [m], rows in LEG_NAMES order."""
TRIPODS: list[list[int]]
"""The two tripods' legs (LEG_NAMES indices): LR RR MF, then MR LF RF."""
STANCE_AXLE: list[list[int]]
"""The drive axle left down while each tripod swings (LF RF, then LR RR): a turning
swing turns the robot about its centre."""
HIP_RANGES: list[list[float]]
"""Hip angle limits [rad], positive outward."""
HIP_OUTWARD: list[float]
"""+1 where outward is forward, -1 backward."""
DT: float
MAX_EDGES: int
"""Most edge cuboids an Environment or filter may be sized for."""
MAX_FOOTHOLD_EDGES: int
"""Most foothold half-planes per leg an Environment or filter may be sized for."""
MAX_SIM_TIME: float
"""Longest simulate max_time [s]."""
_Scenario = Literal["step", "stairs", "unequal_rises", "landing", "box", "platform"]
SCENARIOS: list[str]

def world_kinematics(x: ArrayLike) -> tuple[Vector, Matrix, Matrix]:
    """(body_center (3,), body_rotation (3, 3), toes (6, 3)), world frame."""

def standard_posture() -> Vector:
    """The standard low posture at rest at the world origin, shape (NX,)."""

def leg_joints(x: ArrayLike) -> Matrix:
    """Each leg's joints, shape (6, 4), rows in LEG_NAMES order: knee length [m], hip angle
    [rad, positive outward], knee rate [m/s], hip rate [rad/s] (the joint-limit kernels'
    quantities)."""

def roll_clearance(roll: float) -> float:
    """The farthest any point of the body box moves when it rolls by ``roll`` [rad] about
    its own x axis [m]: what Course.set_body_roll keeps the body rows clear by."""

class Environment(Params):
    """Tachyon 3's Params with typed helpers: edge cuboids, floors, footholds, swing legs,
    stability bounds. Sized once (edges, foothold_edges per leg)."""

    def __init__(self, edges: int = 20, foothold_edges: Sequence[int] | None = None) -> None: ...
    @property
    def sizes(self) -> tuple[int, list[int]]:
        """(edges, foothold_edges) this environment was sized for."""
    def push_edge(self, center: ArrayLike, rotation: ArrayLike, half_extents: ArrayLike) -> None: ...
    def clear_edges(self) -> None: ...
    @property
    def edge_count(self) -> int: ...
    @property
    def floor_z(self) -> Vector: ...
    @floor_z.setter
    def floor_z(self, values: ArrayLike) -> None: ...
    @property
    def swing(self) -> list[bool]: ...
    @swing.setter
    def swing(self, values: Sequence[bool]) -> None: ...
    def set_foothold(self, leg: Leg, normals: ArrayLike, offsets: ArrayLike) -> None:
        """Replace a leg's foothold polygon: normals (k, 2), offsets (k,)."""
    def foothold(self, leg: Leg) -> tuple[Matrix, Vector]: ...
    def set_stability(
        self, leg: Leg, lower: tuple[float, float] | None = None, upper: tuple[float, float] | None = None
    ) -> None: ...

class Course:
    """A scenario's stairs and nominal gait, stepped by your own loop."""

    def __init__(
        self,
        scenario: _Scenario = "step",
        perception: bool = False,
        perception_seed: int = 1,
        floor_lift: float | None = None,
        origin: Literal["rolling", "jump_at_exchange"] = "rolling",
    ) -> None: ...
    def initial_state(self, start_gap: float = 0.3) -> Vector: ...
    def plan(self, t: float, x: ArrayLike) -> Vector:
        """The gait's nominal input; also updates `environment`."""
    def perceive(self, t: float, x: ArrayLike, truth: ArrayLike | None = None) -> None:
        """Perception before the cycle at ``t`` (a ``Course(perception=True)`` only): the
        LiDAR scans from ``truth`` (the physical state; ``x`` when None) and maps its
        returns from ``x`` (the state estimate the gait and filter are given); 10 Hz scans,
        1 Hz updates applied 0.5 s after their request. Updates `environment`."""
    def exchange_origin(self, t: float, x: ArrayLike) -> tuple[Vector, float | None]:
        """x with its origin moved where the support puts it (every world pose kept) and
        the jump [m], else (x, None): onto the drive axle a turning swing turns about and
        back off it; with origin="jump_at_exchange" also to the six wheels' centroid at
        each support exchange. Call it before plan each cycle."""
    def command(self, speed: float, yaw_rate: float) -> None:
        """The velocity command: roll at speed [m/s], turn at yaw_rate [rad/s] (at most
        max_yaw_rate) by three-leg turning swings about a drive axle."""
    @property
    def time_allowed(self) -> float:
        """The time a run on this course gets to finish [s]: each flight's climb and turn."""
    @property
    def max_yaw_rate(self) -> float:
        """The fastest yaw rate command accepts [rad/s]."""
    def set_body_roll(self, roll: float) -> None:
        """The body's measured roll [rad] (an IMU's): the body rows keep the model's body
        roll_clearance(roll) from every edge, now and after every perception update."""
    @property
    def perception_updates(self) -> int:
        """Perception updates applied so far (0 without perception)."""
    def environment_edges(self) -> list[tuple[Vector, Matrix, Vector]]:
        """The edge boxes the filter was last given, as terrain_boxes gives boxes, as its
        body rows see them (grown by roll_clearance of the roll given to set_body_roll)."""
    @property
    def environment(self) -> Environment: ...
    @property
    def nominal_body_height(self) -> float | None:
        """The gait's nominal body-centre height at the last plan [m]; None before."""
    @property
    def swinging(self) -> int | None: ...
    def clearance(self, x: ArrayLike) -> tuple[float, float, float]:
        """Exact (body, wheel, wheel_riser) clearance to the true terrain's solids [m]
        (terrain_boxes); negative = depth into a solid. The nearest wheel reads about 0
        on a tread; wheel_riser is the nearest wheel to a riser (contact normal more than
        30° from vertical), inf if none."""
    def finished(self, x: ArrayLike) -> bool: ...
    def floor_height(self, x: float) -> float: ...
    def terrain_boxes(self) -> list[tuple[Vector, Matrix, Vector]]:
        """The true terrain as solid boxes (center, rotation, half_extents): a floor with
        its top at z = 0 and one box per raised level."""
    def edge_boxes(self) -> list[tuple[Vector, Matrix, Vector]]:
        """The true edge cuboids (nosings), one per change of height, as terrain_boxes
        gives boxes."""

def simulate(
    scenario: _Scenario = "stairs",
    body_cbf: bool = True,
    max_time: float | None = None,
    episode: int | None = None,
    seed: int = 0,
    ranges: dict[str, tuple[float, float] | list[float]] | None = None,
    perception: bool = False,
) -> dict[str, np.ndarray | dict]:
    """The Rust closed loop's time series as numpy arrays, plus a "summary" dict.

    With ``episode`` (and the ``seed`` and ``ranges`` given to :func:`campaign`) the course
    is that campaign episode's instead of ``scenario``. With ``perception=True`` the gait
    and filter see only what a LiDAR on the body perceives; ``summary["perception_updates"]``
    counts the 1 Hz updates.

    Timings per cycle: eval_us, solve_us and update_us (wall time) and cpu_us (the
    thread's CPU time over the update); the summary holds median/p99/max of update_us
    (*_update_us) and of cpu_us (*_cpu_us), and over_period_wall / over_period_cpu, the
    cycles over 1 ms on each clock.

    Clearances (body_clearance, toe_clearance, toe_riser_clearance per cycle; the
    summary's min_*_clearance, where each was in body_nearest / toe_nearest /
    toe_riser_nearest, and riser_contact_cycles) are measured against the true terrain's
    solids, as Course.clearance. ``summary["relaxed_cycles"]`` counts, per family, the
    cycles in which the filter reported rows of it relaxed.

    ``min_h`` is inf where no row of a family applied, ``toe_riser_clearance`` where no
    wheel faces a riser; every other series is finite.
    Raises CbfError for a max_time outside [DT, MAX_SIM_TIME]. Samples are stored as the
    run goes (a run that completes early holds only its own). Releases the GIL while it
    runs."""

def campaign(
    episodes: int = 200,
    seed: int = 0,
    first_id: int = 0,
    body_cbf: bool = True,
    threads: int | None = None,
    ranges: dict[str, tuple[float, float] | list[float]] | None = None,
    perception: bool = False,
) -> dict[str, np.ndarray | list | str]:
    """A Monte Carlo campaign of random staircases, run in Rust on a thread pool.

    With ``perception=True`` every episode runs on perceived terrain (as
    ``simulate(perception=True)``).

    ``ranges``: ``[lo, hi]`` per key ``rise``, ``run``, ``steps``, ``start_gap``, ``speed``
    (defaults as ``cbfgen campaign``). Returns one entry per episode in id order (numpy
    arrays: id, rise, run, steps, start_gap, speed, duration, min_body_clearance,
    min_toe_clearance, min_toe_riser_clearance, riser_contact_cycles, min_h (n, 6),
    median/p99/max_cpu_us, median/p99/max_wall_us, over_1ms_cpu, over_1ms_wall, cycles;
    ``outcome``, a list of "finished", "not_finished", "error"), ``errors`` as (id, message) pairs and ``report``, the
    printed table, and ``csv``, the episodes.csv text at full precision (what
    :func:`merge_campaign` joins). Summary columns read 0 for an episode whose outcome is
    "error". Raises CbfError for invalid ranges or settings. Releases the GIL while it runs."""

COURSE_RANGES: dict[str, list[float] | list[int]]
"""The ranges a campaign draws its courses from by default, ``[lo, hi]`` per key
``rise``, ``run``, ``steps``, ``start_gap``, ``speed`` (as ``cbfgen campaign``)."""

CAMPAIGN_TIMING_COLUMNS: list[str]
"""The columns of a campaign's episodes.csv that depend on the machine and the moment."""

def merge_campaign(shards: Sequence[str], out: str | os.PathLike[str] | None = None) -> dict[str, object]:
    """Join campaign shards (each a :func:`campaign` ``csv``, or an episodes.csv written by
    ``cbfgen campaign --shard``) into one campaign: ``csv`` (merged, id order), ``report``
    (the printed table), ``missing`` ((first, last) id spans no shard held) and ``written``
    (the files, when ``out`` names a directory: episodes.csv, report.txt and the figures,
    as the command line writes them). Raises CbfError for a text that is not a campaign
    CSV of this version, shards of different seeds, or an episode in two shards."""

# ----------------------------------------------------------- ANYmal C (cbfgen.anymal)
ANYMAL_LEGS: list[str]
ANYMAL_JOINT_NAMES: list[str]
ANYMAL_TOTAL_MASS: float
ANYMAL_FOOT_RADIUS: float
ANYMAL_CONTROLLERS: list[str]
ANYMAL_FOOTHOLD_BARRIERS: list[str]
ANYMAL_WHOLE_BODY_BARRIERS: list[str]

def anymal_standing() -> Vector:
    """The SRDF's standing joints, the trunk level at the height where the feet touch
    z = 0, at rest: the ``anymal_wbc`` state, shape (42,)."""

def anymal_trot(
    t: float,
    swing: float,
    lift: float,
    reach: float,
    home: ArrayLike,
    trunk: ArrayLike,
    velocity: ArrayLike | None = None,
) -> tuple[list[bool], Vector, Vector, Matrix, Matrix, Matrix]:
    """The trot at time ``t``: stance flags, the trunk's position and velocity, and the
    feet's positions, velocities and accelerations, each (4, 3), world."""

class WholeBodyController:
    """Seed 004's hierarchical whole-body controller on ANYmal C (docs/anymal.md)."""

    def __init__(
        self,
        half_spaces: int = 4,
        friction: float = 0.7,
        min_normal_force: float = 5.0,
        trunk_position_gains: tuple[float, float] = (400.0, 40.0),
        trunk_orientation_gains: tuple[float, float] = (400.0, 40.0),
        swing_gains: tuple[float, float] = (900.0, 60.0),
        integral_gain: float = 0.0,
    ) -> None: ...
    def set_footholds(
        self,
        foot: int,
        normals: ArrayLike,
        offsets: ArrayLike,
        growth: tuple[float, float, float] | None = None,
        at: float = 0.0,
    ) -> None:
        """Replace a foot's region by the half-spaces ``n . c <= d`` (loosened by m(t),
        given as ``growth = (m, m', m'')`` at time ``at``: seed 004's eq. 24 set)."""
    def update(
        self,
        x: ArrayLike,
        stance: Sequence[bool],
        trunk_position: ArrayLike,
        trunk_rotation: ArrayLike,
        trunk_velocity: ArrayLike,
        trunk_angular_velocity: ArrayLike,
        foot_positions: ArrayLike,
        foot_velocities: ArrayLike,
        foot_accelerations: ArrayLike,
        forces: ArrayLike | None = None,
        dt: float = 2.5e-3,
        t: float = 0.0,
    ) -> dict[str, Any]:
        """One cycle: torques, accelerations, forces, relaxed, solved, residuals, status."""

class SteppingStones:
    """Seed 004's stepping stones: square stones along a forward trot, displaced from a
    seeded stream; ``layout="gait"`` under the trot's footholds (displacements ±10/15/20 mm
    by default), ``"rows"`` in a row per side ``pitch`` apart, away from the footholds
    (±30/20/20 mm by default); ``stones`` (n, 4): top centre x, y, z, half side."""

    def __init__(
        self,
        strides: int = 8,
        seed: int = 0,
        swing: float = 0.3,
        lift: float = 0.1,
        size: float = 0.14,
        displacement: tuple[float, float, float] | None = None,
        swings_between: int = 7,
        layout: str = "gait",
        pitch: float = 0.24,
    ) -> None: ...
    @property
    def stones(self) -> Matrix: ...
    @property
    def end(self) -> float: ...
    @property
    def speed(self) -> float: ...
    @property
    def swing(self) -> float: ...
    @property
    def distance(self) -> float: ...
    def misstep(self, x: float, y: float) -> float:
        """Horizontal distance from (x, y) to the nearest stone top (0 on one) [m]."""
    def nearest_top(self, x: float, y: float) -> float:
        """Top height of the stone nearest (x, y) [m]."""

class StoneWalk:
    """Seed 004's two layers (MPC and whole-body controller) walking a stone field on a
    plant Python drives, with Table II's measurements."""

    def __init__(
        self,
        stones: SteppingStones,
        controller: str = "CBF in QP & MPC",
        margin: float = 0.02,
        gamma: float | None = None,
        threaded: bool = False,
        barrier: str | None = None,
        mpc_stage: float | None = None,
        whole_body_barrier: str | None = None,
    ) -> None: ...
    def update(self, t: float, x: ArrayLike, feet: ArrayLike, velocities: ArrayLike) -> dict[str, Any]:
        """One 2.5 ms cycle: torques, stance, solved, relaxed, planned, mpc."""
    def fell(self, t: float) -> None:
        """Mark a fall at t."""
    def record(self) -> dict[str, Any]:
        """Table II's measurements so far."""

# ------------------------------------------ Panda among obstacles (cbfgen.campaign)
ARM_MAX_OBSTACLES: int

def arm_episode(
    obstacles: int = 25,
    seed: int = 0,
    duration: float = 10.0,
    cruise_speed: float = 0.8,
    filter: bool = True,
) -> dict[str, float | int]:
    """One run of the Panda under its torque filter among ``obstacles`` random spheres
    drawn from ``seed`` above a table, the hand swept low across them: exact minimum
    ``min_obstacle_clearance`` and ``min_table_clearance`` [m], ``cycles``,
    ``fallback_cycles``, ``median_cpu_us``, ``max_cpu_us``. Releases the GIL."""
