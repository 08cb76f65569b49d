"""The Tachyon 3 kinematic model: state layout, kinematics and control-affine dynamics,
read from ``tachyon3.toml`` beside this file (the spec imports it; both are its
dependencies, so editing either regenerates the crate's module).

Tachyon 3 paper, section II-B (DESIGN.md "Model"). State x in R^36, input u in R^17:

=====================  ===========================================  ==================
block                  state                                        input
=====================  ===========================================  ==================
ground-moving origin   p_x, p_y, p_z (world), yaw, v, yaw_rate      a, yaw_acc
body (origin-relative) x, z, pitch, vx, vz, pitch_rate              ax, az, pitch_acc
toe i (origin-rel.)    x, z, vx, vz (in the leg's lateral plane)    ax, az
=====================  ===========================================  ==================

Origin: p' = R_z(yaw) [v, 0, 0]; everything else is a double integrator.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import symengine as se

from symbolic.linalg import matmul, matvec, rot_y, rot_z
from symbolic.spec import HALF_EXTENT_RANGE, INPUT_LIMIT_RANGE, POLE_RANGE, SSAT_ALPHA_RANGE

# The robot's numbers, beside this file.
MODEL_FILE = Path(__file__).resolve().parent / "tachyon3.toml"


class ModelError(ValueError):
    """A model file that cannot describe a robot; the message names the file and key."""


@dataclass(frozen=True)
class Leg:
    name: str
    hip: tuple[float, float, float]
    outward: float  # +1: outward is forward (front legs); -1: backward (rear legs)
    hip_min: float  # [rad]
    hip_max: float  # [rad]


@dataclass(frozen=True)
class RobotModel:
    name: str
    body_half_extents: tuple[float, float, float]
    nominal_clearance: float
    toe_radius: float
    knee_min: float
    knee_max: float
    legs: tuple[Leg, ...]
    ssat_alpha: float
    ssat_alpha_rot: float
    toe_alpha: float
    ecbf_poles: tuple[float, ...]
    input_limits: tuple[float, ...]


def _number(table: dict, key: str, where: str, positive: bool = False,
            within: tuple[float, float] = (-math.inf, math.inf)) -> float:
    if key not in table:
        raise ModelError(f"{where}: missing '{key}'")
    v = table[key]
    if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
        raise ModelError(f"{where}.{key}: expected a finite number, got {v!r}")
    if positive and v <= 0:
        raise ModelError(f"{where}.{key}: must be > 0, got {v}")
    if not within[0] <= v <= within[1]:
        raise ModelError(f"{where}.{key}: must lie in [{within[0]:g}, {within[1]:g}], got {v}")
    return float(v)


def _vector(table: dict, key: str, where: str, n: int, positive: bool = False,
            within: tuple[float, float] = (-math.inf, math.inf)) -> tuple[float, ...]:
    v = table.get(key)
    if not isinstance(v, list) or len(v) != n:
        raise ModelError(f"{where}.{key}: expected a list of {n} numbers, got {v!r}")
    return tuple(_number({key: x}, key, where, positive, within) for x in v)


def load_model(path: Path) -> RobotModel:
    """Read and validate a model file."""
    where = path.name
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as e:
        raise ModelError(f"{where}: {e}") from e
    body, toe, knee = data.get("body", {}), data.get("toe", {}), data.get("knee", {})
    smoothing, ecbf = data.get("smoothing", {}), data.get("ecbf", {})
    inputs = data.get("inputs", {})
    legs = []
    for i, leg in enumerate(data.get("legs", [])):
        lw = f"{where}: legs[{i}]"
        name = leg.get("name")
        if not isinstance(name, str) or not name.isidentifier():
            raise ModelError(f"{lw}.name: expected an identifier, got {name!r}")
        outward = {"forward": 1.0, "backward": -1.0}.get(leg.get("outward"))
        if outward is None:
            raise ModelError(f"{lw}.outward: expected 'forward' or 'backward'")
        lo, hi = _vector(leg, "hip_range_deg", lw, 2)
        if not -90.0 < lo < hi < 90.0:
            raise ModelError(f"{lw}.hip_range_deg: need -90 < min < max < 90, got {[lo, hi]}")
        legs.append(Leg(name, _vector(leg, "hip", lw, 3), outward, math.radians(lo), math.radians(hi)))
    if len(legs) != 6 or len({leg.name for leg in legs}) != 6:
        raise ModelError(f"{where}: expected six [[legs]] with distinct names")
    knee_min = _number(knee, "min_length", f"{where}: knee", positive=True)
    return RobotModel(
        name=path.stem,
        body_half_extents=_vector(body, "half_extents", f"{where}: body", 3, positive=True,
                                  within=HALF_EXTENT_RANGE),
        nominal_clearance=_number(body, "nominal_clearance", f"{where}: body", positive=True),
        toe_radius=_number(toe, "radius", f"{where}: toe", positive=True),
        knee_min=knee_min,
        knee_max=knee_min + _number(knee, "stroke", f"{where}: knee", positive=True),
        legs=tuple(legs),
        ssat_alpha=_number(smoothing, "ssat_alpha", f"{where}: smoothing", within=SSAT_ALPHA_RANGE),
        ssat_alpha_rot=_number(smoothing, "ssat_alpha_rot", f"{where}: smoothing", within=SSAT_ALPHA_RANGE),
        toe_alpha=_number(smoothing, "toe_alpha", f"{where}: smoothing", within=SSAT_ALPHA_RANGE),
        ecbf_poles=_vector(ecbf, "poles", f"{where}: ecbf", 2, within=POLE_RANGE),
        input_limits=_input_limits(inputs, f"{where}: inputs"),
    )


def _input_limits(inputs: dict, where: str) -> tuple[float, ...]:
    """Magnitude limit of each input, in the order of ``input_names``."""
    body = _vector(inputs, "body_accel", where, 2, positive=True, within=INPUT_LIMIT_RANGE)
    toe = _vector(inputs, "toe_accel", where, 2, positive=True, within=INPUT_LIMIT_RANGE)
    return (
        _number(inputs, "origin_accel", where, positive=True, within=INPUT_LIMIT_RANGE),
        _number(inputs, "yaw_accel", where, positive=True, within=INPUT_LIMIT_RANGE),
        *body,
        _number(inputs, "pitch_accel", where, positive=True, within=INPUT_LIMIT_RANGE),
        *(toe * 6),
    )


# ------------------------------------------------------------------ layout
ORIGIN_STATES = ["px", "py", "pz", "yaw", "v", "yaw_rate"]
BODY_STATES = ["bx", "bz", "pitch", "bvx", "bvz", "pitch_rate"]
TOE_STATES = ["x", "z", "vx", "vz"]
ORIGIN_INPUTS = ["a", "yaw_acc"]
BODY_INPUTS = ["bax", "baz", "pitch_acc"]
TOE_INPUTS = ["ax", "az"]


def state_names(model: RobotModel) -> list[str]:
    names = ORIGIN_STATES + BODY_STATES
    for leg in model.legs:
        names += [f"{leg.name.lower()}_{s}" for s in TOE_STATES]
    return names


def input_names(model: RobotModel) -> list[str]:
    names = ORIGIN_INPUTS + BODY_INPUTS
    for leg in model.legs:
        names += [f"{leg.name.lower()}_{s}" for s in TOE_INPUTS]
    return names


@dataclass
class Tachyon3:
    """Symbols and expressions of the model. ``x`` are the kernels' state symbols
    (``x_<name>``), so any kernel with an ``x`` array input shares them."""

    model: RobotModel

    def __post_init__(self):
        self.state_names = state_names(self.model)
        self.input_names = input_names(self.model)
        self.x = [se.Symbol(f"x_{n}") for n in self.state_names]
        self.s: dict[str, se.Symbol] = dict(zip(self.state_names, self.x, strict=False))
        nx, nu = len(self.x), len(self.input_names)
        s = self.s
        # Drift f(x) and input matrix g (constant here; kept general for the engine).
        f: dict[str, se.Expr] = {n: se.Integer(0) for n in self.state_names}
        f["px"] = s["v"] * se.cos(s["yaw"])
        f["py"] = s["v"] * se.sin(s["yaw"])
        f["yaw"] = s["yaw_rate"]
        for pos, vel in [("bx", "bvx"), ("bz", "bvz"), ("pitch", "pitch_rate")]:
            f[pos] = s[vel]
        g = [[se.Integer(0)] * nu for _ in range(nx)]
        driven = ["v", "yaw_rate", "bvx", "bvz", "pitch_rate"]
        for leg in self.model.legs:
            t = leg.name.lower()
            f[f"{t}_x"], f[f"{t}_z"] = s[f"{t}_vx"], s[f"{t}_vz"]
            driven += [f"{t}_vx", f"{t}_vz"]
        for u, name in enumerate(driven):
            g[self.state_names.index(name)][u] = se.Integer(1)
        self.f = [f[n] for n in self.state_names]
        self.g = g
        assert (nx, nu) == (36, 17)

    # ------------------------------------------------------------ kinematics
    def body_position_world(self) -> list[se.Expr]:
        s = self.s
        rel = matvec(rot_z(s["yaw"]), [s["bx"], 0, s["bz"]])
        return [s["px"] + rel[0], s["py"] + rel[1], s["pz"] + rel[2]]

    def body_rotation_world(self) -> list[list[se.Expr]]:
        return matmul(rot_z(self.s["yaw"]), rot_y(self.s["pitch"]))

    def toe_origin(self, leg: Leg) -> list[se.Expr]:
        t = leg.name.lower()
        return [self.s[f"{t}_x"], se.RealDouble(leg.hip[1]), self.s[f"{t}_z"]]

    def toe_world(self, leg: Leg) -> list[se.Expr]:
        rel = matvec(rot_z(self.s["yaw"]), self.toe_origin(leg))
        s = self.s
        return [s["px"] + rel[0], s["py"] + rel[1], s["pz"] + rel[2]]

    def leg_vector(self, leg: Leg) -> tuple[se.Expr, se.Expr]:
        """Hip-to-toe vector (x, z) in the origin frame; its y is 0 because the toe
        moves in the hip's lateral plane."""
        s = self.s
        hip = matvec(rot_y(s["pitch"]), [se.RealDouble(c) for c in leg.hip])
        toe = self.toe_origin(leg)
        return toe[0] - s["bx"] - hip[0], toe[2] - s["bz"] - hip[2]

    @staticmethod
    def knee_length(dx: se.Expr, dz: se.Expr) -> se.Expr:
        """Prismatic knee length (eq. 4) from the hip-to-toe vector of :meth:`leg_vector`:
        rotation-invariant, so the origin frame will do."""
        return se.sqrt(dx * dx + dz * dz)

    def hip_angle(self, leg: Leg, dx: se.Expr, dz: se.Expr) -> se.Expr:
        """Hip angle (eq. 4) from the hip-to-toe vector: 0 with the leg along the body's -z
        axis, positive outward. The leg's angle from straight down in the origin frame
        plus the body pitch, which equals atan2 of the body-frame vector while the leg
        points downward."""
        return leg.outward * (se.atan2(dx, -dz) + self.s["pitch"])
