"""A robot's URDF as symbolic kinematics for the spec language.

``load(path)`` reads the robot description (links, joints, their origins, axes and
limits) with Python's own XML parser and checks what the kinematics rely on: known joint
types, unit axes, one parent per link, no loops. ``Kinematics(urdf, q)`` then builds
every link's pose in the root link's frame from joint variables of the spec's choosing,
``T(link) = T(parent) · T_origin(xyz, rpy) · T_joint(q)``, with URDF's conventions:
``rpy`` is fixed-axis roll, pitch, yaw (``R = Rz(yaw) Ry(pitch) Rx(roll)``), a revolute
or continuous joint turns about its unit axis by ``q`` (Rodrigues), a prismatic one
slides along it by ``q``, a fixed one does neither.

Constant rotations are evaluated in floating point when the URDF is read; entries within
``SNAP`` of 0 or ±1 (``cos(π/2)`` written to 16 digits) are taken as exact, which keeps
zeros out of the generated expressions and moves no pose by more than ``SNAP`` (relative).

``package://name/...`` paths resolve against the packages given to ``load`` and against
example-robot-data's installed tree (the ``example-robot-data`` wheel on PyPI), so its
robots load offline: ``load(description("panda_description/urdf/panda.urdf"))``.
"""

from __future__ import annotations

import math
import sys
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import symengine as se

from .spec import SpecError

JOINT_TYPES = ("fixed", "revolute", "continuous", "prismatic")
"""The joint types the kinematics handles; ``floating`` and ``planar`` bases are the
spec's to declare (their coordinates are the spec's states)."""

AXIS_TOLERANCE = 1e-9
"""How far from 1 a joint axis's length may be (URDF axes are written as unit vectors)."""

SNAP = 1e-15
"""Constant rotation entries this close to 0 or ±1 are taken as exact."""

Matrix3 = list[list[se.Expr]]
Vector3 = list[se.Expr]


@dataclass(frozen=True)
class Joint:
    """One joint as the URDF gives it (lengths in m, angles in rad)."""

    name: str
    type: str
    parent: str
    child: str
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float]
    axis: tuple[float, float, float]
    lower: float | None
    upper: float | None
    velocity: float | None
    effort: float | None

    @property
    def moves(self) -> bool:
        return self.type != "fixed"


@dataclass(frozen=True)
class Urdf:
    """A robot description: its links and its joints, parents before children."""

    name: str
    source: Path
    root: str
    links: tuple[str, ...]
    joints: tuple[Joint, ...]

    @property
    def moving_joints(self) -> tuple[Joint, ...]:
        """The joints that take a variable, in tree order (parents first)."""
        return tuple(j for j in self.joints if j.moves)

    def joint(self, name: str) -> Joint:
        for j in self.joints:
            if j.name == name:
                return j
        raise SpecError(f"URDF {self.source.name}: no joint {name!r} (joints: {[j.name for j in self.joints]})")


def description_root() -> Path | None:
    """example-robot-data's ``robots`` folder when its wheel is installed, else None."""
    for entry in sys.path:
        candidate = Path(entry) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if candidate.is_dir():
            return candidate
    return None


def description(relative: str) -> Path:
    """A file of example-robot-data's robots (``"panda_description/urdf/panda.urdf"``)."""
    root = description_root()
    if root is None:
        raise SpecError("example-robot-data is not installed: pip install example-robot-data==6.0.0")
    path = root / relative
    if not path.is_file():
        raise SpecError(f"example-robot-data has no {relative!r} (looked in {root})")
    return path


def resolve(uri: str, source: Path, packages: Mapping[str, Path] | None = None) -> Path:
    """A URDF file reference as a path: ``package://name/rest`` against ``packages`` or
    example-robot-data, ``file://`` and relative paths against the URDF's folder."""
    if uri.startswith("package://"):
        name, _, rest = uri[len("package://"):].partition("/")
        roots = [Path(packages[name])] if packages and name in packages else []
        erd = description_root()
        if erd is not None:
            roots += [erd / name, erd.parent / name, erd]
        for r in roots:
            if (r / rest).exists():
                return r / rest
        raise SpecError(f"URDF {source.name}: cannot resolve {uri!r}; pass packages={{{name!r}: <folder>}}")
    if uri.startswith("file://"):
        return Path(uri[len("file://"):])
    return source.parent / uri


def _floats(where: str, text: str | None, default: tuple[float, ...]) -> tuple[float, ...]:
    if text is None:
        return default
    try:
        values = tuple(float(v) for v in text.split())
    except ValueError:
        raise SpecError(f"{where}: {text!r} is not a list of numbers") from None
    if len(values) != len(default) or not all(math.isfinite(v) for v in values):
        raise SpecError(f"{where}: {text!r} must be {len(default)} finite numbers")
    return values


def _limit(where: str, element: ET.Element | None, key: str) -> float | None:
    if element is None or element.get(key) is None:
        return None
    try:
        value = float(element.get(key, ""))
    except ValueError:
        raise SpecError(f"{where}: limit {key}={element.get(key)!r} is not a number") from None
    if not math.isfinite(value):
        raise SpecError(f"{where}: limit {key}={value} is not finite")
    return value


def load(path: Path | str) -> Urdf:
    """Read and check a URDF: every joint of a known type with a unit axis and a parent
    and child that are links, every link with at most one parent, one root, no loop.
    Each mistake is a SpecError naming the file and the element."""
    path = Path(path)
    try:
        robot = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise SpecError(f"URDF {path}: cannot read it ({exc})") from None
    if robot.tag != "robot":
        raise SpecError(f"URDF {path.name}: the root element is <{robot.tag}>, not <robot>")
    links = [link.get("name", "") for link in robot.findall("link")]
    if len(set(links)) != len(links) or "" in links:
        raise SpecError(f"URDF {path.name}: links must have distinct, non-empty names")
    joints: list[Joint] = []
    parent_of: dict[str, str] = {}
    for element in robot.findall("joint"):
        name = element.get("name", "")
        where = f"URDF {path.name}, joint {name!r}"
        kind = element.get("type", "")
        if kind not in JOINT_TYPES:
            raise SpecError(f"{where}: type {kind!r} is not one of {list(JOINT_TYPES)} (a floating or planar "
                            "base is the spec's states, not a URDF joint)")
        parent, child = (("" if (e := element.find(tag)) is None else e.get("link", "")) for tag in ("parent", "child"))
        for role, link in (("parent", parent), ("child", child)):
            if link not in links:
                raise SpecError(f"{where}: {role} link {link!r} is not a link of the robot")
        if child in parent_of:
            raise SpecError(f"{where}: link {child!r} already has parent {parent_of[child]!r} (a loop or a "
                            "second parent)")
        parent_of[child] = parent
        origin = element.find("origin")
        xyz = _floats(f"{where}, origin xyz", None if origin is None else origin.get("xyz"), (0.0, 0.0, 0.0))
        rpy = _floats(f"{where}, origin rpy", None if origin is None else origin.get("rpy"), (0.0, 0.0, 0.0))
        axis_element = element.find("axis")
        axis = _floats(f"{where}, axis", None if axis_element is None else axis_element.get("xyz"), (1.0, 0.0, 0.0))
        if kind != "fixed" and abs(math.sqrt(sum(a * a for a in axis)) - 1.0) > AXIS_TOLERANCE:
            raise SpecError(f"{where}: axis {axis} is not a unit vector (length "
                            f"{math.sqrt(sum(a * a for a in axis)):.6g})")
        limit = element.find("limit")
        joints.append(Joint(name, kind, parent, child, xyz, rpy, axis, _limit(where, limit, "lower"),
                            _limit(where, limit, "upper"), _limit(where, limit, "velocity"),
                            _limit(where, limit, "effort")))
    names = [j.name for j in joints]
    if len(set(names)) != len(names):
        raise SpecError(f"URDF {path.name}: joint names repeat")
    roots = [link for link in links if link not in parent_of]
    if len(roots) != 1:
        raise SpecError(f"URDF {path.name}: {len(roots)} links without a parent ({roots}); a robot is one tree")
    # Parents before children; a link that never reaches the root is on a loop.
    depth: dict[str, int] = {roots[0]: 0}
    for link in links:
        chain, seen = [link], {link}
        while chain[-1] not in depth:
            up = parent_of[chain[-1]]
            if up in seen:
                raise SpecError(f"URDF {path.name}: links {sorted(seen)} form a loop")
            chain.append(up)
            seen.add(up)
        for k in range(len(chain) - 2, -1, -1):
            depth[chain[k]] = depth[chain[k + 1]] + 1
    ordered = tuple(sorted(joints, key=lambda j: (depth[j.child], names.index(j.name))))
    return Urdf(robot.get("name", path.stem), path, roots[0], tuple(links), ordered)


def _snap(v: float) -> se.Expr:
    for exact in (0, 1, -1):
        if abs(v - exact) <= SNAP:
            return se.Integer(exact)
    return se.RealDouble(v)


def _number(v: float) -> se.Expr:
    return se.Integer(int(v)) if v == int(v) and abs(v) < 2**53 else se.RealDouble(v)


def rpy_matrix(rpy: Sequence[float]) -> Matrix3:
    """``Rz(yaw) Ry(pitch) Rx(roll)``, evaluated now, entries snapped (see ``SNAP``)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    m = [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
         [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
         [-sp, cp * sr, cp * cr]]
    return [[_snap(v) for v in row] for row in m]


def axis_rotation(axis: Sequence[float], q: se.Expr) -> Matrix3:
    """Rotation by ``q`` about the unit ``axis`` (Rodrigues): ``I cos q + sin q [a]x +
    (1 − cos q) a aᵀ``; exact for the coordinate axes."""
    a = [_snap(v) for v in axis]
    c, s = se.cos(q), se.sin(q)
    cross = [[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]]
    return [[(c if i == j else 0) + s * cross[i][j] + (1 - c) * a[i] * a[j] for j in range(3)] for i in range(3)]


def _matmul(a: Matrix3, b: Matrix3) -> Matrix3:
    return [[se.Add(*[a[i][k] * b[k][j] for k in range(3)]) for j in range(3)] for i in range(3)]


def _matvec(a: Matrix3, v: Vector3) -> Vector3:
    return [se.Add(*[a[i][k] * v[k] for k in range(3)]) for i in range(3)]


class Kinematics:
    """Every link's pose in the root link's frame, from one variable per moving joint.

    ``q`` maps each moving joint's name to its variable (a state, usually); with
    ``let_`` (a family context's ``p.let``, or ``Kernel.let_``) each pose is built from
    named intermediates ``<link>_r00 .. <link>_p2``, so families sharing a link share its
    pose. ``pose(link)`` is ``(R, p)``: R's columns are the link's axes in the root frame.
    """

    def __init__(self, urdf: Urdf, q: Mapping[str, se.Expr],
                 let_: Callable[[str, se.Expr], se.Symbol] | None = None):
        missing = [j.name for j in urdf.moving_joints if j.name not in q]
        extra = sorted(set(q) - {j.name for j in urdf.moving_joints})
        if missing or extra:
            raise SpecError(f"URDF {urdf.source.name}: give one variable per moving joint; missing {missing}, "
                            f"not a moving joint {extra}")
        self.urdf = urdf
        self._q = dict(q)
        self._let = let_
        identity = [[se.Integer(int(i == j)) for j in range(3)] for i in range(3)]
        self._poses: dict[str, tuple[Matrix3, Vector3]] = {urdf.root: (identity, [se.Integer(0)] * 3)}
        for joint in urdf.joints:
            self._poses[joint.child] = self._child_pose(joint)

    def _child_pose(self, joint: Joint) -> tuple[Matrix3, Vector3]:
        r_parent, p_parent = self._poses[joint.parent]
        r = _matmul(r_parent, rpy_matrix(joint.rpy))
        p = [p_parent[i] + e for i, e in enumerate(_matvec(r_parent, [_number(v) for v in joint.xyz]))]
        if joint.type in ("revolute", "continuous"):
            r = _matmul(r, axis_rotation(joint.axis, self._q[joint.name]))
        elif joint.type == "prismatic":
            slide = [_snap(a) * self._q[joint.name] for a in joint.axis]
            p = [p[i] + e for i, e in enumerate(_matvec(r, slide))]
        if self._let is None:
            return r, p
        name = _identifier(joint.child)
        r = [[self._let(f"{name}_r{i}{j}", r[i][j]) for j in range(3)] for i in range(3)]
        p = [self._let(f"{name}_p{i}", p[i]) for i in range(3)]
        return r, p

    def pose(self, link: str) -> tuple[Matrix3, Vector3]:
        """``(R, p)`` of ``link`` in the root link's frame."""
        if link not in self._poses:
            raise SpecError(f"URDF {self.urdf.source.name}: no link {link!r} (links: {list(self.urdf.links)})")
        return self._poses[link]


def _identifier(name: str) -> str:
    """A link name as the start of a Rust/Python identifier (``panda_link1`` stays)."""
    out = "".join(ch if ch.isalnum() or ch == "_" else "_" for ch in name).lower()
    return out if out and not out[0].isdigit() else f"l_{out}"
