# Type stubs for the Rust extension module (src/python/). Arrays out are new float64
# numpy arrays, always finite: a kernel value that would be NaN or infinite raises
# CbfError instead. "ArrayLike" inputs accept lists, tuples and arrays of booleans,
# integers or floats, read as float64; complex, string and object arrays raise
# ValueError. Shapes are exact: a vector of N values is (N,); a rotation is 9 row-major
# values (9,) or a 3x3 array; foothold normals are (k, 2) and offsets (k,).
# Counts outside their integer type (negative, >= 2**64) raise OverflowError.
# python/tests/test_api.py checks that this file and the module list the same names.

from collections.abc import Sequence
from typing import Literal

import numpy as np
import numpy.typing as npt

ArrayLike = npt.ArrayLike
Vector = npt.NDArray[np.float64]
Matrix = npt.NDArray[np.float64]
Leg = int | str
"""A leg: its index in LEG_NAMES order (0..6) or its name ("LF", "mf", ...)."""
Rows = tuple[Matrix, Matrix]
"""(lie, lg_lf): lie[i] = [h, L_f h, L_f^2 h] (rows x 3); lg_lf[i] = L_g L_f h (rows x NU)."""
SsatVariant = Literal["lse_xtanh", "lse_sqrt", "boltzmann_xtanh", "boltzmann_sqrt"]
Family = Literal["joint_limits", "foot_height", "stability", "body_edge", "toe_edge", "foothold"]

class CbfError(ValueError):
    """An error reported by cbfgen's Rust core (bad value, capacity, solver set-up...)."""

NX: int
NU: int
STATE_NAMES: list[str]
INPUT_NAMES: list[str]
LEG_NAMES: list[str]
INPUT_LIMITS: list[float]
TOE_RADIUS: float
BODY_HALF_EXTENTS: list[float]
RELATIVE_DEGREE: int
FAMILIES: list[str]
DT: float
MAX_EDGES: int
"""Most edge cuboids an Environment or EcbfFilter may be sized for."""
MAX_FOOTHOLD_EDGES: int
"""Most foothold half-planes per leg an Environment or EcbfFilter may be sized for."""
MAX_ITERATIONS: int
"""Largest EcbfFilter max_iter."""
MAX_TIME_LIMIT_US: float
"""Largest EcbfFilter time_limit_us (1 s)."""
MAX_INPUT: float
"""Largest |nominal input| and |input limit| the filter accepts."""
STATE_LIMIT: float
"""Largest |state entry| accepted by the kernels, the filter and the course."""
MAX_SIM_TIME: float
"""Longest simulate max_time [s]."""
SSAT_ALPHA_RANGE: tuple[float, float]
"""Accepted SSAT alpha and alpha_rot, inclusive."""
MAX_COORDINATE: float
"""Largest |box centre coordinate| [m] (ssat boxes, edge cuboids)."""
HALF_EXTENT_RANGE: tuple[float, float]
"""Accepted box half extents [m], inclusive."""
SSAT_VARIANTS: list[str]
JOINT_LIMIT_ROWS: list[str]
SCENARIOS: list[str]
INPUT_SOURCES: list[str]

# ----------------------------------------------------------------------- SSAT
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

# ------------------------------------------------------------------- families
def joint_limits(leg: Leg, x: ArrayLike) -> Rows:
    """The four joint-limit rows of a leg, in JOINT_LIMIT_ROWS order.

    Like every function taking a state, raises CbfError for an entry that is not finite
    or beyond STATE_LIMIT; like every row function, raises CbfError ("constraint row i
    is not finite") where the geometry is singular (a toe exactly at its hip)."""

def foot_height(leg: Leg, x: ArrayLike, floor_z: float) -> Rows:
    """Toe wheel bottom above the floor plane at height floor_z: one row."""

def stability(leg: Leg, x: ArrayLike, a: float, b: float) -> Rows:
    """Static stability bound a (x_toe - x_body) + b >= 0 (eq. 13): one row."""

def body_edge(x: ArrayLike, edge_center: ArrayLike, edge_rotation: ArrayLike, edge_half: ArrayLike) -> Rows:
    """Body vs edge cuboid: smooth SAT minus its certified margin (eq. 10): one row."""

def toe_edge(leg: Leg, x: ArrayLike, edge_center: ArrayLike, edge_rotation: ArrayLike, edge_half: ArrayLike) -> Rows:
    """Toe sphere vs edge cuboid by superellipsoid (eq. 11): one row."""

def foothold(leg: Leg, x: ArrayLike, normal: ArrayLike, offset: float) -> Rows:
    """Toe inside the half-plane normal . p_xy + offset >= 0 (eq. 12): one row."""

def sine_barrier(x: ArrayLike, t: float, amplitude: float, omega: float, offset: float) -> tuple[list[float], float]:
    """Double integrator x = [q, q'] above A sin(w t) + c: ([h, L_f h, L_f^2 h] with the dh/dt terms, L_g L_f h)."""

def kernel_table() -> list[tuple[str, str, list[tuple[str, int]], list[tuple[str, int]]]]:
    """Every generated kernel of every built-in system: (module, name, inputs, outputs), each
    input and output as (name, number of values), in the kernel's order."""

def call_kernel(module: str, name: str, inputs: ArrayLike) -> Vector:
    """Kernel ``module::name`` with every input flattened in order into one vector; every
    output flattened likewise (matrices row by row, symmetric ones by upper triangle)."""

# ------------------------------------------------------------------- dynamics
def dynamics_f(x: ArrayLike) -> Vector:
    """Drift f(x), shape (NX,)."""

def dynamics_g(x: ArrayLike) -> Matrix:
    """Input matrix g(x), dense, shape (NX, NU)."""

def xdot(x: ArrayLike, u: ArrayLike) -> Vector:
    """f(x) + g(x) u, shape (NX,)."""

def world_kinematics(x: ArrayLike) -> tuple[Vector, Matrix, Matrix]:
    """(body_center (3,), body_rotation (3, 3), toes (6, 3)), world frame."""

def standard_posture() -> Vector:
    """The standard low posture at rest at the world origin, shape (NX,)."""

# --------------------------------------------------------------------- filter
class Environment:
    """Edge cuboids, floors, foothold polygons, swing legs and stability bounds, sized once."""

    def __init__(self, edges: int = 20, foothold_edges: Sequence[int] | None = None) -> None:
        """Raises CbfError above MAX_EDGES / MAX_FOOTHOLD_EDGES, OverflowError below 0."""
    @property
    def capacity(self) -> tuple[int, list[int]]: ...
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
        """Row k: normals[k] . p_xy + offsets[k] >= 0; normals is (k, 2), offsets (k,).

        Raises ValueError for other shapes and CbfError for more rows than the leg's
        capacity or a zero or non-finite normal."""
    def foothold(self, leg: Leg) -> tuple[Matrix, Vector]: ...
    def set_stability(
        self, leg: Leg, lower: tuple[float, float] | None = None, upper: tuple[float, float] | None = None
    ) -> None: ...

class FilterOutput:
    """One update's result."""

    @property
    def u(self) -> Vector: ...
    @property
    def source(self) -> Literal["qp", "unconverged", "last_safe", "nominal_clipped"]: ...
    @property
    def status(self) -> str | None: ...
    @property
    def nonfinite_row(self) -> int | None: ...
    @property
    def iterations(self) -> int: ...
    @property
    def polished(self) -> bool: ...
    @property
    def active_rows(self) -> int: ...
    @property
    def consecutive_fallbacks(self) -> int: ...
    @property
    def eval_time_us(self) -> float: ...
    @property
    def solve_time_us(self) -> float: ...

class EcbfFilter:
    """The ECBF-QP safety filter on OSQP; one allocation-free update per control cycle."""

    def __init__(
        self,
        edges: int = 20,
        foothold_edges: Sequence[int] | None = None,
        *,
        activation: dict[str, float] | None = None,
        slack_weight: dict[str, float] | None = None,
        poles: dict[str, tuple[float, float]] | None = None,
        input_weights: ArrayLike | None = None,
        input_min: ArrayLike | None = None,
        input_max: ArrayLike | None = None,
        eps_abs: float | None = None,
        eps_rel: float | None = None,
        max_iter: int | None = None,
        polish: bool | None = None,
        time_limit_us: float | None = None,
    ) -> None:
        """Keyword arguments override the Rust defaults. Raises CbfError for capacities
        above MAX_EDGES / MAX_FOOTHOLD_EDGES and for settings outside their documented
        domain: max_iter in 1..=MAX_ITERATIONS, eps_abs and eps_rel in [1e-12, 1e3],
        time_limit_us in (0, MAX_TIME_LIMIT_US], |input limits| <= MAX_INPUT, input
        weights in [1e-6, 1e6], poles in [1e-6, 1e4], slack weights in [1e-6, 1e12];
        ValueError for unknown family names; OverflowError for negative counts or a
        max_iter of 2**32 or more."""
    def update(self, x: ArrayLike, u_ref: ArrayLike, env: Environment) -> FilterOutput:
        """One control cycle; ``u`` is always finite. Raises CbfError for x outside
        STATE_LIMIT, u_ref outside MAX_INPUT (NaN and inf included) or an environment of
        another capacity (the filter is then unchanged). Releases the GIL while the rows
        are evaluated and the QP solved."""
    def fallback_input(self, u_ref: ArrayLike) -> Vector: ...
    @property
    def output(self) -> FilterOutput: ...
    @property
    def row_count(self) -> int: ...
    @property
    def slots(self) -> list[tuple[str, int | None, int]]: ...
    @property
    def lie(self) -> Matrix: ...
    @property
    def lg_lf(self) -> Matrix: ...
    @property
    def applicable(self) -> list[bool]: ...
    @property
    def active(self) -> list[bool]: ...
    @property
    def slack(self) -> Vector: ...

# ------------------------------------------------------------------ scenarios
class Course:
    """A scenario's stairs and nominal gait, stepped by your own loop."""

    def __init__(self, scenario: Literal["step", "stairs"] = "step") -> None: ...
    def initial_state(self, start_gap: float = 0.3) -> Vector: ...
    def plan(self, t: float, x: ArrayLike) -> Vector:
        """The gait's nominal input; also updates `environment`."""
    @property
    def environment(self) -> Environment: ...
    @property
    def nominal_body_height(self) -> float | None:
        """The gait's nominal body-centre height at the last plan [m]; None before."""
    @property
    def swinging(self) -> int | None: ...
    def clearance(self, x: ArrayLike) -> tuple[float, float]: ...
    def finished(self, x: ArrayLike) -> bool: ...
    def floor_height(self, x: float) -> float: ...

def simulate(
    scenario: Literal["step", "stairs"] = "stairs", body_cbf: bool = True, max_time: float | None = None
) -> dict[str, np.ndarray | dict]:
    """The Rust closed loop's time series as numpy arrays, plus a "summary" dict.

    ``min_h`` is inf where no row of a family applied; every other series is finite.
    Raises CbfError for a max_time outside [DT, MAX_SIM_TIME]. Samples are stored as the
    run goes (a run that completes early holds only its own). Releases the GIL while it
    runs."""
