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

**Collision geometry.** Each link's ``<collision>`` elements (boxes, spheres, cylinders,
capsules, meshes) are read with the URDF; a missing mesh file is a SpecError naming the
link. ``link_box(robot, link)`` is one oriented box, fixed in the link's frame, that
contains all of the link's collision geometry: a URDF box is reproduced as it is; for
anything else the box is fitted (the link-frame bounding box, or trimesh's minimal-volume
oriented box where that is clearly smaller, see ``FIT_ORIENTED_GAIN``) and *checked*:
every mesh vertex, and every corner of the cube or box around a sphere, cylinder or
capsule, is shown inside it in exact rational arithmetic, with at least ``FIT_MARGIN``
to spare. Fitted boxes are conservative (a
capsule's box holds its corners' empty space); that is the price of one SSAT row per
link pair. ``collision_shapes(robot, link)`` gives each element on its own: boxes and
spheres exactly, anything else as its checked box.

**Self-collision.** ``load_srdf`` reads a robot's SRDF (its disabled pairs and named
states); ``self_collision_pairs`` is every pair of links with collision geometry that the
SRDF does not disable and that is not *adjacent*: joined by at most one moving joint
(rigidly attached links, or links meeting at one joint, touch by construction).

A robot from example-robot-data is an input of generation through its pinned version
(``symbolic/requirements-urdf.txt``, part of the generator's inputs hash), so
``description`` refuses another installed version; a robot of the user's own is named
with ``System.depends_on(*robot.files)``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.metadata
import itertools
import json
import math
import sys
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
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

GEOMETRY_TYPES = ("box", "sphere", "cylinder", "capsule", "mesh")
"""The collision geometry the front end reads (``capsule`` is a common extension: a
cylinder of ``length`` along z with hemispherical ends of ``radius``)."""

FIT_QUANTUM = 1e-7
"""Fitted boxes' centres are rounded to, and half extents rounded up to, multiples of
this [m], so a fit is the same on every machine whatever the last bits of the linear
algebra underneath; the fitted rotation is rounded to 1e-9 rad of roll, pitch, yaw."""

FIT_ORIENTED_GAIN = 0.9
"""A fitted box turns away from the link's axes only when that makes it at least this much
smaller (volume ratio): a box aligned with its link keeps the rows' kernels about a fifth
shorter (the Panda's hand row: 3 600 lines against 4 400), and a turn that saves a few
percent of volume is not worth that."""

FIT_MARGIN = FIT_QUANTUM
"""Every point a fitted box must hold is inside it by at least this much [m] along each
of its axes, checked exactly; the rounding of the box's own numbers moves its faces by
less than 1e-14 m."""

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
class Collision:
    """One ``<collision>`` element of a link: its geometry in its own frame, placed in
    the link's frame by ``xyz``/``rpy``. ``size`` is the box's full size, ``(radius,)``,
    ``(radius, length)`` for a cylinder or capsule (along z), or a mesh's scale."""

    link: str
    kind: str
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float]
    size: tuple[float, ...]
    mesh: Path | None = None


@dataclass(frozen=True)
class Inertial:
    """A link's mass [kg], centre of mass [m] and rotational inertia about it [kg m²],
    both in the link's frame (the URDF's inertial ``rpy`` applied)."""

    mass: float
    com: tuple[float, float, float]
    inertia: tuple[tuple[float, float, float], ...]


@dataclass(frozen=True)
class Urdf:
    """A robot description: its links and its joints, parents before children, and each
    link's collision geometry."""

    name: str
    source: Path
    root: str
    links: tuple[str, ...]
    joints: tuple[Joint, ...]
    collisions: tuple[Collision, ...] = ()
    inertials: Mapping[str, Inertial] = dataclasses.field(default_factory=dict)
    """Per link with an ``<inertial>``; a link without one is massless."""

    @property
    def files(self) -> list[Path]:
        """The files the description was read from (the URDF and its meshes), for
        ``System.depends_on``."""
        return [self.source, *sorted({c.mesh for c in self.collisions if c.mesh is not None})]

    def collision(self, link: str) -> tuple[Collision, ...]:
        """``link``'s collision elements, in the URDF's order."""
        if link not in self.links:
            raise SpecError(f"URDF {self.source.name}: no link {link!r} (links: {list(self.links)})")
        return tuple(c for c in self.collisions if c.link == link)

    def limits(self, joints: Sequence[str], kind: str) -> list[tuple[float, float]]:
        """``(lower, upper)`` of each named joint: ``kind`` "position" from the URDF's
        lower/upper, "velocity" or "effort" as ``(-v, v)``. A limit the URDF does not give
        is a SpecError naming the joint."""
        out = []
        for name in joints:
            j = self.joint(name)
            if kind == "position":
                pair = (j.lower, j.upper)
                if j.type == "continuous":
                    pair = (None, None)
            elif kind in ("velocity", "effort"):
                v = j.velocity if kind == "velocity" else j.effort
                pair = (None, None) if v is None else (-v, v)
            else:
                raise SpecError(f"URDF {self.source.name}: limits kind {kind!r} is not position, velocity or effort")
            if pair[0] is None or pair[1] is None:
                raise SpecError(f"URDF {self.source.name}, joint {name!r}: no {kind} limit given")
            if not pair[0] < pair[1]:
                raise SpecError(f"URDF {self.source.name}, joint {name!r}: {kind} limits {pair} are empty")
            out.append((pair[0], pair[1]))
        return out

    def path_joints(self, a: str, b: str) -> list[Joint]:
        """The joints on the tree path between links ``a`` and ``b``."""
        parent = {j.child: j for j in self.joints}

        def up(link: str) -> list[Joint]:
            chain = []
            while link in parent:
                chain.append(parent[link])
                link = parent[link].parent
            return chain

        ua, ub = up(a), up(b)
        common = {j.name for j in ua} & {j.name for j in ub}
        return [j for j in ua + ub if j.name not in common]

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


def pinned_version(package: str) -> str:
    """The version of ``package`` that symbolic/requirements-urdf.txt pins."""
    for line in (Path(__file__).parent / "requirements-urdf.txt").read_text().splitlines():
        name, sep, version = line.split("#")[0].strip().partition("==")
        if sep and name.strip() == package:
            return version.strip()
    raise SpecError(f"symbolic/requirements-urdf.txt does not pin {package}")


def description(relative: str) -> Path:
    """A file of example-robot-data's robots (``"panda_description/urdf/panda.urdf"``),
    from the pinned version only: its files are generation inputs through the pin."""
    pin = pinned_version("example-robot-data")
    root = description_root()
    if root is None:
        raise SpecError(f"example-robot-data is not installed: pip install example-robot-data=={pin} "
                        "(scripts/cbf setup does)")
    installed = importlib.metadata.version("example-robot-data")
    if installed != pin:
        raise SpecError(f"example-robot-data {installed} is installed; the generator is pinned to {pin} "
                        f"(pip install example-robot-data=={pin})")
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
            roots += [erd / name, erd.parent / name, erd, erd.parent.parent / name]
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


def load(path: Path | str, packages: Mapping[str, Path] | None = None) -> Urdf:
    """Read and check a URDF: every joint of a known type with a unit axis and a parent
    and child that are links, every link with at most one parent, one root, no loop;
    every collision geometry of a known type with finite, positive sizes, and every mesh
    file present (``package://`` paths resolve against ``packages`` and
    example-robot-data). Each mistake is a SpecError naming the file and the element."""
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
    collisions = tuple(_collision(path, link, element, packages) for link_element in robot.findall("link")
                       for link in [link_element.get("name", "")] for element in link_element.findall("collision"))
    inertials = {link: _inertial(path, link, element) for link_element in robot.findall("link")
                 for link in [link_element.get("name", "")] if (element := link_element.find("inertial")) is not None}
    return Urdf(robot.get("name", path.stem), path, roots[0], tuple(links), ordered, collisions, inertials)


def _inertial(path: Path, link: str, element: ET.Element) -> Inertial:
    where = f"URDF {path.name}, link {link!r}, inertial"
    origin = element.find("origin")
    xyz = _floats(f"{where} origin xyz", None if origin is None else origin.get("xyz"), (0.0, 0.0, 0.0))
    rpy = _floats(f"{where} origin rpy", None if origin is None else origin.get("rpy"), (0.0, 0.0, 0.0))
    mass_element, inertia = element.find("mass"), element.find("inertia")
    if mass_element is None or inertia is None:
        raise SpecError(f"{where}: needs <mass> and <inertia>")
    mass = _floats(f"{where} mass", mass_element.get("value"), (math.nan,))[0]
    if not mass >= 0:
        raise SpecError(f"{where}: mass {mass} must be >= 0")
    keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    missing = [k for k in keys if inertia.get(k) is None]
    if missing:
        raise SpecError(f"{where}: inertia lacks {missing}")
    ixx, ixy, ixz, iyy, iyz, izz = (_floats(f"{where} inertia {k}", inertia.get(k), (math.nan,))[0] for k in keys)
    local = [[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]
    r = [[float(v) for v in row] for row in rpy_matrix(rpy)]
    # R I Rᵀ: the inertia in the link's axes.
    rotated = tuple(tuple(sum(r[i][a] * local[a][b] * r[j][b] for a in range(3) for b in range(3)) for j in range(3))
                    for i in range(3))
    return Inertial(mass, xyz, rotated)


def _collision(path: Path, link: str, element: ET.Element, packages: Mapping[str, Path] | None) -> Collision:
    where = f"URDF {path.name}, link {link!r}, collision"
    origin = element.find("origin")
    xyz = _floats(f"{where} origin xyz", None if origin is None else origin.get("xyz"), (0.0, 0.0, 0.0))
    rpy = _floats(f"{where} origin rpy", None if origin is None else origin.get("rpy"), (0.0, 0.0, 0.0))
    geometry = element.find("geometry")
    shapes = [] if geometry is None else list(geometry)
    if len(shapes) != 1 or shapes[0].tag not in GEOMETRY_TYPES:
        found = [e.tag for e in shapes]
        raise SpecError(f"{where}: the geometry must be one of {list(GEOMETRY_TYPES)}, found {found}")
    shape = shapes[0]
    kind = shape.tag

    def number(key: str) -> float:
        if shape.get(key) is None:
            raise SpecError(f"{where}: {kind} has no {key}")
        value = _floats(f"{where} {kind} {key}", shape.get(key), (math.nan,))[0]
        if value <= 0:
            raise SpecError(f"{where}: {kind} {key}={value} must be > 0")
        return value

    if kind == "box":
        if shape.get("size") is None:
            raise SpecError(f"{where}: box has no size")
        size = _floats(f"{where} box size", shape.get("size"), (math.nan,) * 3)
        if min(size) <= 0:
            raise SpecError(f"{where}: box size {size} must be > 0 along every axis")
        return Collision(link, kind, xyz, rpy, size)
    if kind == "sphere":
        return Collision(link, kind, xyz, rpy, (number("radius"),))
    if kind in ("cylinder", "capsule"):
        return Collision(link, kind, xyz, rpy, (number("radius"), number("length")))
    filename = shape.get("filename")
    if not filename:
        raise SpecError(f"{where}: a mesh without a filename")
    scale = _floats(f"{where} mesh scale", shape.get("scale"), (1.0, 1.0, 1.0))
    if min(abs(v) for v in scale) == 0:
        raise SpecError(f"{where}: mesh scale {scale} flattens it")
    try:
        mesh = resolve(filename, path, packages)
    except SpecError as exc:
        raise SpecError(f"{where}: {exc}") from None
    if not mesh.is_file():
        raise SpecError(f"{where}: mesh {filename!r} is missing (looked for {mesh})")
    return Collision(link, kind, xyz, rpy, scale, mesh)


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
    """Link poses from one variable per moving joint, in the frame of ``base`` (the root
    link by default).

    ``q`` maps each moving joint's name to its variable (a state) or a number (a joint
    the spec holds still). With ``let_`` (a family context's ``p.let``, or
    ``Kernel.let_``) each pose is built from named intermediates ``<link>_r00 ..
    <link>_p2`` (``<link>_in_<base>_...`` for another base), so families sharing a link
    share its pose. Poses are built when first asked for, so a kernel holds only the
    links it uses. ``pose(link)`` is ``(R, p)``: R's columns are the link's axes in the
    base frame. With a ``base`` other than the root, only links below it have poses: the
    joints above it move both ends of any pair alike and drop out, exactly. A floating base
    (a legged robot's trunk) is ``root_pose=(R, p)``: the root link's pose in the world,
    from the spec's states (``euler_zyx(roll, pitch, yaw)`` for R); every pose is then in
    the world.
    """

    def __init__(self, urdf: Urdf, q: Mapping[str, se.Expr | float],
                 let_: Callable[[str, se.Expr], se.Symbol] | None = None, base: str | None = None,
                 root_pose: tuple[Sequence[Sequence[se.Expr]], Sequence[se.Expr]] | None = None):
        require_joint_values(urdf, q)
        self.urdf = urdf
        self.base = urdf.root if base is None else base
        if self.base not in urdf.links:
            raise SpecError(f"URDF {urdf.source.name}: base {self.base!r} is not a link")
        self._q = {name: se.sympify(v) for name, v in q.items()}
        self._let = let_
        self._parent = {j.child: j for j in urdf.joints}
        identity = [[se.Integer(int(i == j)) for j in range(3)] for i in range(3)]
        start: tuple[Matrix3, Vector3] = (identity, [se.Integer(0)] * 3)
        if root_pose is not None:
            # A floating base: the root link's pose in the world, from the spec's states.
            if self.base != urdf.root:
                raise SpecError(f"URDF {urdf.source.name}: root_pose places the root link; it cannot be combined "
                                f"with base={base!r}")
            rotation, position = root_pose
            if len(rotation) != 3 or any(len(row) != 3 for row in rotation) or len(position) != 3:
                raise SpecError(f"URDF {urdf.source.name}: root_pose is (3x3 rotation, 3-vector position)")
            start = ([[se.sympify(v) for v in row] for row in rotation], [se.sympify(v) for v in position])
        self._poses: dict[str, tuple[Matrix3, Vector3]] = {self.base: start}

    def _child_pose(self, joint: Joint) -> tuple[Matrix3, Vector3]:
        r_parent, p_parent = self.pose(joint.parent)
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
        if self.base != self.urdf.root:
            name = f"{name}_in_{_identifier(self.base)}"
        r = [[self._let(f"{name}_r{i}{j}", r[i][j]) for j in range(3)] for i in range(3)]
        p = [self._let(f"{name}_p{i}", p[i]) for i in range(3)]
        return r, p

    def pose(self, link: str) -> tuple[Matrix3, Vector3]:
        """``(R, p)`` of ``link`` in the base frame (in the world with ``root_pose``)."""
        if link in self._poses:
            return self._poses[link]
        if link not in self.urdf.links:
            raise SpecError(f"URDF {self.urdf.source.name}: no link {link!r} (links: {list(self.urdf.links)})")
        if link not in self._parent:
            raise SpecError(f"URDF {self.urdf.source.name}: link {link!r} is not below the base {self.base!r}")
        pose = self._child_pose(self._parent[link])
        self._poses[link] = pose
        return pose

    def jacobian(self, link: str, variables: Sequence[se.Expr],
                 point: Sequence[se.Expr | float] | None = None) -> tuple[list[list[se.Expr]], list[list[se.Expr]]]:
        """The geometric Jacobian of ``link`` in the base frame, one column per entry of
        ``variables`` (joint variables given in ``q``): ``(linear, angular)``, each 3 x n,
        so that the velocity of the point and the link's angular velocity are
        ``linear @ q'`` and ``angular @ q'`` (Pinocchio's LOCAL_WORLD_ALIGNED frame
        Jacobian). The point is ``point`` in the link's frame (its origin by default).

        Built from each joint's axis and origin on the way down (``a x (p - o)`` and ``a``
        for a revolute joint, ``a`` and 0 for a prismatic one), so with ``let_`` it reads
        the same named intermediates as the poses; a variable that moves no joint between
        the base and the link has a zero column, as does one of a joint above the base."""
        r, p = self.pose(link)
        if point is not None:
            p = [p[i] + e for i, e in enumerate(_matvec(r, [se.sympify(v) for v in point]))]
        zero = se.Integer(0)
        linear = [[zero] * len(variables) for _ in range(3)]
        angular = [[zero] * len(variables) for _ in range(3)]
        for joint in self.urdf.path_joints(self.base, link):
            if not joint.moves:
                continue
            variable = self._q[joint.name]
            columns = [k for k, v in enumerate(variables) if se.sympify(v) == variable]
            if not columns:
                continue
            rc, o = self.pose(joint.child)
            # The child's rotation carries the joint's own turn, which leaves its axis fixed.
            a = _matvec(rc, [_snap(v) for v in joint.axis])
            if joint.type == "prismatic":
                lin, ang = a, [zero] * 3
            else:
                d = [p[i] - o[i] for i in range(3)]
                lin = [a[1] * d[2] - a[2] * d[1], a[2] * d[0] - a[0] * d[2], a[0] * d[1] - a[1] * d[0]]
                ang = a
            for k in columns:
                for i in range(3):
                    linear[i][k] += lin[i]
                    angular[i][k] += ang[i]
        return linear, angular


def require_joint_values(robot: Urdf, q: Mapping[str, object]) -> None:
    """A SpecError unless ``q`` gives exactly one value per moving joint."""
    missing = [j.name for j in robot.moving_joints if j.name not in q]
    extra = sorted(set(q) - {j.name for j in robot.moving_joints})
    if missing or extra:
        raise SpecError(f"URDF {robot.source.name}: give one variable per moving joint; missing {missing}, "
                        f"not a moving joint {extra}")


def euler_zyx(roll: se.Expr, pitch: se.Expr, yaw: se.Expr) -> Matrix3:
    """``Rz(yaw) Ry(pitch) Rx(roll)`` symbolically: a floating base's orientation from
    roll, pitch, yaw states (URDF's ``rpy`` convention), for ``Kinematics(root_pose=...)``."""
    cr, sr, cp, sp, cy, sy = se.cos(roll), se.sin(roll), se.cos(pitch), se.sin(pitch), se.cos(yaw), se.sin(yaw)
    return [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr]]


def common_ancestor(robot: Urdf, a: str, b: str) -> str:
    """The lowest link both ``a`` and ``b`` hang from (either of them, if one does)."""
    parent = {j.child: j.parent for j in robot.joints}

    def chain(link: str) -> list[str]:
        out = [link]
        while out[-1] in parent:
            out.append(parent[out[-1]])
        return out

    above_b = set(chain(b))
    return next(link for link in chain(a) if link in above_b)


def _identifier(name: str) -> str:
    """A link name as the start of a Rust/Python identifier (``panda_link1`` stays)."""
    out = "".join(ch if ch.isalnum() or ch == "_" else "_" for ch in name).lower()
    return out if out and not out[0].isdigit() else f"l_{out}"


# ------------------------------------------------------------------ collision geometry


@dataclass(frozen=True)
class FittedBox:
    """An oriented box fixed in ``link``'s frame: ``center`` [m], ``rotation`` (rows of
    a 3x3 matrix whose columns are the box's axes in the link frame) and ``half`` extents
    [m]. ``exact`` when it is a URDF box as given, else fitted and checked."""

    link: str
    center: tuple[float, float, float]
    rotation: tuple[tuple[float, float, float], ...]
    half: tuple[float, float, float]
    exact: bool

    def placed(self, pose: tuple[Matrix3, Vector3]):
        """The box in the frame ``pose`` (the link's R, p) is given in, as a ``prim.Box``."""
        from .primitives import Box

        r, p = pose
        rb = [[_snap(v) for v in row] for row in self.rotation]
        offset = _matvec(r, [_number(v) for v in self.center])
        return Box([p[i] + offset[i] for i in range(3)], _matmul(r, rb), [_number(v) for v in self.half])


@dataclass(frozen=True)
class Sphere:
    """A URDF sphere in its link's frame: ``center`` [m], ``radius`` [m]."""

    link: str
    center: tuple[float, float, float]
    radius: float

    def placed(self, pose: tuple[Matrix3, Vector3]) -> tuple[Vector3, se.Expr]:
        """``(centre, radius)`` in the frame ``pose`` is given in."""
        r, p = pose
        offset = _matvec(r, [_number(v) for v in self.center])
        return [p[i] + offset[i] for i in range(3)], _number(self.radius)


FLOAT_FILTER = 1e-9
"""Exact checks look only at points within this much [m] of a box's face in floating point:
for coordinates below ``FLOAT_FILTER_REACH`` the floating-point error of a projection is
under 1e-12 m, so a point farther in is inside, exactly, without rational arithmetic."""

FLOAT_FILTER_REACH = 1e3


@dataclass(frozen=True)
class _Points:
    """One collision element's points in its link's frame: ``local`` (element frame, the
    floats as read) placed by ``rpy``/``xyz``, scaled by ``scale``. Floats for the fit,
    each point's exact value (rationals of the same floats) on demand."""

    local: tuple[tuple[float, float, float], ...]
    scale: tuple[float, float, float]
    rpy: tuple[float, float, float]
    xyz: tuple[float, float, float]

    def floats(self):
        import numpy as np

        r = np.array([[float(v) for v in row] for row in rpy_matrix(self.rpy)])
        return (np.asarray(self.local) * np.asarray(self.scale)) @ r.T + np.asarray(self.xyz)

    def exact(self, i: int) -> tuple[Fraction, Fraction, Fraction]:
        r = [[Fraction(float(v)) for v in row] for row in rpy_matrix(self.rpy)]
        v = [Fraction(x) * Fraction(s) for x, s in zip(self.local[i], self.scale, strict=True)]
        return tuple(sum(r[a][k] * v[k] for k in range(3)) + Fraction(self.xyz[a]) for a in range(3))


def _element_points(c: Collision) -> _Points:
    """Points whose convex hull holds ``c``'s geometry: a mesh's vertices; the corners of a
    box, or of the box around a sphere, cylinder or capsule."""
    if c.kind == "mesh":
        try:
            import trimesh  # build-time only: symbolic/requirements-urdf.txt
        except ImportError:
            raise SpecError(f"link {c.link!r}: fitting a box to a mesh needs trimesh (pip install -r "
                            "symbolic/requirements-urdf.txt; scripts/cbf setup does)") from None
        try:
            mesh = trimesh.load(c.mesh, force="mesh")
            local = tuple(tuple(float(x) for x in v) for v in mesh.vertices)
        except Exception as exc:  # trimesh raises many kinds for unreadable files
            raise SpecError(f"link {c.link!r}: cannot read mesh {c.mesh} ({exc})") from None
        if not local or not all(math.isfinite(x) for v in local for x in v):
            raise SpecError(f"link {c.link!r}: mesh {c.mesh} has no vertices or a non-finite one")
        return _Points(local, c.size, c.rpy, c.xyz)
    if c.kind == "box":
        half = [v / 2 for v in c.size]
    elif c.kind == "sphere":
        half = [c.size[0]] * 3
    else:
        radius, length = c.size
        # Halving is exact; a capsule's cap added in floats is rounded up, never down.
        cap = math.nextafter(length / 2 + radius, math.inf) if c.kind == "capsule" else length / 2
        half = [radius, radius, cap]
    # The scale carries the half extents: the corners are (±1, ±1, ±1) · half exactly.
    corners = tuple(itertools.product((-1.0, 1.0), repeat=3))
    return _Points(corners, tuple(half), c.rpy, c.xyz)


def _near_faces(coordinates, lo, hi) -> list[int]:
    """Indices of points whose float coordinate lies within ``FLOAT_FILTER`` of ``lo`` or
    ``hi`` along some axis (or all points when coordinates are too large for the filter)."""
    import numpy as np

    if not np.all(np.abs(coordinates) < FLOAT_FILTER_REACH):
        return list(range(len(coordinates)))
    near = np.any((coordinates <= lo + FLOAT_FILTER) | (coordinates >= hi - FLOAT_FILTER), axis=1)
    return [int(i) for i in np.flatnonzero(near)]


_QUANTUM = Fraction(1, 10**7)  # FIT_QUANTUM, exactly


def _quantum_round(v: float) -> float:
    return float(round(Fraction(v) / _QUANTUM) * _QUANTUM)


def _box_around(points: Sequence[_Points], rpy: Sequence[float]) -> tuple[tuple, tuple, tuple]:
    """The box with axes ``rpy_matrix(rpy)`` around ``points``: (centre, rotation rows,
    half extents), its numbers rounded to ``FIT_QUANTUM``, each point inside by more than
    ``FIT_MARGIN`` along each axis (proved by ``contains``)."""
    import numpy as np

    rotation = tuple(tuple(float(v) for v in row) for row in rpy_matrix(rpy))
    r = np.array(rotation)
    axes = [[Fraction(rotation[k][i]) for k in range(3)] for i in range(3)]
    lo: list[Fraction | None] = [None] * 3
    hi: list[Fraction | None] = [None] * 3
    for element in points:
        coordinates = element.floats() @ r  # along the box's axes
        for i in _near_faces(coordinates, coordinates.min(axis=0), coordinates.max(axis=0)):
            p = element.exact(i)
            for a in range(3):
                value = sum(axes[a][k] * p[k] for k in range(3))
                lo[a] = value if lo[a] is None else min(lo[a], value)
                hi[a] = value if hi[a] is None else max(hi[a], value)
    middle = [_quantum_round(float((lo[i] + hi[i]) / 2)) for i in range(3)]
    center = tuple(float(sum(Fraction(rotation[i][k]) * Fraction(middle[k]) for k in range(3))) for i in range(3))
    half = []
    for i in range(3):
        reach = max(hi[i] - Fraction(middle[i]), Fraction(middle[i]) - lo[i]) + _QUANTUM
        # Round up by whole quanta, then one more: the centre's own rounding (R·middle
        # in floats) moves it by < 1e-16 m, far inside that quantum.
        half.append(float((math.ceil(reach / _QUANTUM) + 1) * _QUANTUM))
    return center, rotation, tuple(half)


def contains(box: FittedBox, points: Sequence[_Points], margin: float = 0.0) -> bool:
    """Whether every point lies inside ``box`` by at least ``margin`` along each of its
    axes, exactly: |Rᵀ(p − c)|_i ≤ h_i − margin in rational arithmetic on the box's own
    floats, for every point within ``FLOAT_FILTER`` of that in floating point."""
    import numpy as np

    c = [Fraction(v) for v in box.center]
    r = [[Fraction(v) for v in row] for row in box.rotation]
    bound = [Fraction(h) - Fraction(margin) for h in box.half]
    float_bound = np.array([float(b) for b in bound])
    for element in points:
        coordinates = (element.floats() - np.asarray(box.center)) @ np.asarray(box.rotation)
        for i in _near_faces(coordinates, -float_bound, float_bound):
            p = element.exact(i)
            d = [p[k] - c[k] for k in range(3)]
            for a in range(3):
                if abs(sum(r[k][a] * d[k] for k in range(3))) > bound[a]:
                    return False
    return True


def fit_box(link: str, points: Sequence[_Points]) -> FittedBox:
    """A box around ``points`` (link frame): aligned with the link frame, or along
    trimesh's minimal-volume oriented box where that is smaller by ``FIT_ORIENTED_GAIN``;
    checked to contain every point with ``FIT_MARGIN`` to spare."""
    import numpy as np

    candidates = [(0.0, 0.0, 0.0)]
    try:
        import trimesh

        transform, _ = trimesh.bounds.oriented_bounds(np.concatenate([e.floats() for e in points]))
        rotation = np.asarray(transform)[:3, :3].T  # columns: the box's axes in the link frame
        roll, pitch, yaw = trimesh.transformations.euler_from_matrix(rotation, "sxyz")
        candidates.append(tuple(round(a, 9) for a in (roll, pitch, yaw)))
    except Exception:  # flat or tiny point sets have no oriented fit; the aligned box is kept
        pass
    boxes = [FittedBox(link, *_box_around(points, rpy), exact=False) for rpy in candidates]
    best = boxes[0]
    for other in boxes[1:]:
        if math.prod(other.half) < FIT_ORIENTED_GAIN * math.prod(best.half):
            best = other
    if not contains(best, points, FIT_MARGIN):  # the construction guarantees it; this proves it
        raise SpecError(f"link {link!r}: the fitted box does not contain the link's geometry (a bug: report it)")
    return best


def collision_shapes(robot: Urdf, link: str) -> list[FittedBox | Sphere]:
    """Each of ``link``'s collision elements: a URDF box or sphere exactly as given,
    anything else as the checked box around it."""
    out: list[FittedBox | Sphere] = []
    for c in robot.collision(link):
        if c.kind == "box":
            out.append(FittedBox(link, c.xyz, tuple(tuple(float(v) for v in row) for row in rpy_matrix(c.rpy)),
                                 tuple(v / 2 for v in c.size), exact=True))
        elif c.kind == "sphere":
            out.append(Sphere(link, c.xyz, c.size[0]))
        else:
            out.append(fit_box(link, [_element_points(c)]))
    return out


def link_box(robot: Urdf, link: str) -> FittedBox:
    """One box in ``link``'s frame holding all its collision geometry: a single URDF box
    as it is, else fitted around every element and checked (see ``fit_box``)."""
    elements = robot.collision(link)
    if not elements:
        raise SpecError(f"URDF {robot.source.name}: link {link!r} has no collision geometry")
    if len(elements) == 1 and elements[0].kind == "box":
        shape = collision_shapes(robot, link)[0]
        assert isinstance(shape, FittedBox)
        return shape
    return _kept(link, elements, lambda: fit_box(link, [_element_points(c) for c in elements]))


def _kept(link: str, elements: Sequence[Collision], fit: Callable[[], FittedBox]) -> FittedBox:
    """``fit()``, kept on disk between generations by everything it reads: the generator's
    code, the elements and their mesh files' bytes. Fitting reads the meshes (and imports
    trimesh): about 1.5 s of the Panda's 3.6 s generation, spent again on every spec edit
    that leaves the robot as it was. The cache is the definition cache's folder
    (``CBFGEN_SYMBOLIC_CACHE``: ``off`` or a folder); one that cannot be read or written is
    fitted again."""
    from .definition_cache import cache_dir
    from .inputs_hash import inputs_hash

    folder = cache_dir()
    if folder is None:
        return fit()
    h = hashlib.sha256(inputs_hash(Path(__file__).resolve().parent.parent).encode())
    for c in elements:
        h.update(repr((c.link, c.kind, c.xyz, c.rpy, c.size)).encode())
        if c.mesh is not None:
            try:
                h.update(Path(c.mesh).read_bytes())
            except OSError:
                return fit()  # fit() says what is wrong with the file
    path = folder / "boxes" / f"{h.hexdigest()}.json"
    try:
        data = json.loads(path.read_text())
        return FittedBox(link, tuple(data["center"]), tuple(tuple(row) for row in data["rotation"]),
                         tuple(data["half"]), bool(data["exact"]))
    except (OSError, ValueError, KeyError, TypeError):
        pass
    box = fit()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps({"center": box.center, "rotation": box.rotation, "half": box.half,
                                          "exact": box.exact}))
    except OSError:
        pass
    return box


# ------------------------------------------------------------------------- SRDF


@dataclass(frozen=True)
class Srdf:
    """What a robot's SRDF says about collisions: the link pairs it disables (each with
    its reason), its named joint states, and its virtual joints (a floating base: the
    joint the URDF does not have, e.g. Pinocchio's ``root_joint``) with their values in
    each state (a floating joint's are x y z qx qy qz qw)."""

    source: Path
    disabled: Mapping[frozenset[str], str]
    states: Mapping[str, Mapping[str, float]]
    virtual_joints: Mapping[str, str] = dataclasses.field(default_factory=dict)
    virtual_states: Mapping[str, Mapping[str, tuple[float, ...]]] = dataclasses.field(default_factory=dict)


def load_srdf(path: Path | str, robot: Urdf) -> Srdf:
    """Read an SRDF for ``robot``; a disabled pair or a state naming a link or joint the
    URDF does not have is a SpecError naming it."""
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise SpecError(f"SRDF {path}: cannot read it ({exc})") from None
    disabled: dict[frozenset[str], str] = {}
    for element in root.findall("disable_collisions"):
        a, b = element.get("link1", ""), element.get("link2", "")
        for link in (a, b):
            if link not in robot.links:
                raise SpecError(f"SRDF {path.name}: disable_collisions names link {link!r}, not a link of "
                                f"{robot.source.name}")
        disabled[frozenset((a, b))] = element.get("reason", "")
    # A virtual joint's value count, by its type (SRDF's: floating is a position and a
    # unit quaternion, planar x y theta, fixed none).
    arity = {"floating": 7, "planar": 3, "fixed": 0}
    virtual: dict[str, str] = {}
    for element in root.findall("virtual_joint"):
        name, kind = element.get("name", ""), element.get("type", "")
        if kind not in arity:
            raise SpecError(f"SRDF {path.name}: virtual_joint {name!r} has type {kind!r}, not one of "
                            f"{sorted(arity)}")
        virtual[name] = kind
    states: dict[str, dict[str, float]] = {}
    virtual_states: dict[str, dict[str, tuple[float, ...]]] = {}
    for element in root.findall("group_state"):
        state = element.get("name", "")
        values, poses = {}, {}
        for joint in element.findall("joint"):
            name = joint.get("name", "")
            where = f"SRDF {path.name}, group_state {state!r}, joint {name!r}"
            if name in virtual:
                poses[name] = _floats(where, joint.get("value"), (math.nan,) * arity[virtual[name]])
                continue
            robot.joint(name)
            values[name] = _floats(where, joint.get("value"), (math.nan,))[0]
        states[state], virtual_states[state] = values, poses
    return Srdf(path, disabled, states, virtual, virtual_states)


def adjacent(robot: Urdf, a: str, b: str) -> bool:
    """Joined by at most one moving joint: rigidly attached, or meeting at one joint."""
    return sum(j.moves for j in robot.path_joints(a, b)) <= 1


def self_collision_pairs(robot: Urdf, srdf: Srdf | None, links: Sequence[str] | None = None) -> list[tuple[str, str]]:
    """Pairs of ``links`` (default: every link with collision geometry), in URDF order,
    that are not adjacent and that the SRDF does not disable."""
    chosen = [link for link in robot.links if robot.collision(link)] if links is None else list(links)
    disabled = {} if srdf is None else srdf.disabled
    return [(a, b) for a, b in itertools.combinations(chosen, 2)
            if not adjacent(robot, a, b) and frozenset((a, b)) not in disabled]


def box_separation(a: tuple, b: tuple) -> float:
    """The exact SAT separation [m] of two boxes given as (centre, rotation rows, half
    extents) in one frame: the largest gap over the 15 axes, < 0 when they overlap."""
    import numpy as np

    (ca, ra, ha), (cb, rb, hb) = ((np.asarray(c, float), np.asarray(r, float), np.asarray(h, float))
                                  for c, r, h in (a, b))
    t = cb - ca
    # The 15 axes as rows: A's and B's face normals, then their edges' cross products.
    axes = np.concatenate([ra.T, rb.T, np.cross(ra.T[:, None, :], rb.T[None, :, :]).reshape(9, 3)])
    norms = np.linalg.norm(axes, axis=1)
    axes = axes[norms >= 1e-9] / norms[norms >= 1e-9, None]  # parallel edges' cross product is no axis
    gaps = np.abs(axes @ t) - np.abs(axes @ ra) @ ha - np.abs(axes @ rb) @ hb
    return float(gaps.max())


def numeric_pose(fk: Kinematics, link: str) -> tuple[list[list[float]], list[float]]:
    """``fk.pose(link)`` as floats (every joint variable given as a number)."""
    r, p = fk.pose(link)
    try:
        return [[float(v) for v in row] for row in r], [float(v) for v in p]
    except (RuntimeError, TypeError):
        raise SpecError(f"URDF {fk.urdf.source.name}: numeric_pose needs a number for every joint") from None


def overlapping_pairs(robot: Urdf, pairs: Sequence[tuple[str, str]], boxes: Mapping[str, FittedBox],
                      q: Mapping[str, float]) -> list[tuple[str, str, float]]:
    """The ``pairs`` whose boxes overlap at the joint values ``q``, with their exact SAT
    separation [m]: a pair that overlaps at a reference configuration cannot be kept
    apart by a barrier that starts there."""
    fk = Kinematics(robot, q)
    placed = {}
    for link in {link for pair in pairs for link in pair}:
        r, p = numeric_pose(fk, link)
        b = boxes[link]
        center = [p[i] + sum(r[i][k] * b.center[k] for k in range(3)) for i in range(3)]
        rotation = [[sum(r[i][k] * b.rotation[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
        placed[link] = (center, rotation, b.half)
    gaps = [(a, b, box_separation(placed[a], placed[b])) for a, b in pairs]
    return [(a, b, gap) for a, b, gap in gaps if gap < 0]


def require_clear(robot: Urdf, pairs: Sequence[tuple[str, str]], boxes: Mapping[str, FittedBox],
                  q: Mapping[str, float], where: str) -> None:
    """A SpecError listing every pair whose boxes overlap at ``q`` (``where`` names the
    configuration): such a pair is the spec's to leave out, with its reason, or its boxes
    to refine; it is never dropped silently."""
    overlaps = overlapping_pairs(robot, pairs, boxes, q)
    if overlaps:
        listed = ", ".join(f"{a}/{b} ({gap * 1000:.1f} mm)" for a, b, gap in overlaps)
        raise SpecError(f"URDF {robot.source.name}: at {where}, these self-collision pairs' boxes overlap: {listed}")
