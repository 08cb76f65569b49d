"""A MuJoCo model from a URDF's inertials and collision primitives.

MuJoCo's own URDF import keeps every massless frame link as a body (and refuses their
zero inertias) and cannot read Collada visual meshes; a robot description's collision
geometry and inertials are all a physics run needs. :func:`mjcf_from_urdf` writes MJCF
the way Pinocchio builds its model: each link rigidly attached to a moving link (through
fixed joints) is merged into it — its mass, centre of mass and inertia combined about the
moving link's frame (parallel-axis theorem), its collision boxes, cylinders and spheres
placed in that frame. Revolute and continuous joints become hinges (with their limits and a
torque motor each), prismatic ones slides; the root gets a free joint when ``floating``.
A site marks each point named in ``sites`` (link, offset) for measurements.

Contact: every collision geom touches the ground plane (``contype``/``conaffinity`` keep
the robot's own geoms from touching each other: the controller, not MuJoCo, keeps the
legs apart); friction ``friction`` on every pair.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


def _floats(text: str | None, n: int, default: float = 0.0) -> np.ndarray:
    return np.array([float(v) for v in text.split()]) if text else np.full(n, default)


def rpy_matrix(rpy: np.ndarray) -> np.ndarray:
    """URDF's fixed-axis roll-pitch-yaw: Rz(yaw) Ry(pitch) Rx(roll)."""
    (cr, cp, cy), (sr, sp, sy) = np.cos(rpy), np.sin(rpy)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def quaternion(r: np.ndarray) -> np.ndarray:
    """(w, x, y, z) of a rotation matrix (MuJoCo's order)."""
    w = np.sqrt(max(0.0, 1.0 + np.trace(r))) / 2.0
    if w > 1e-6:
        return np.array([4 * w * w, r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]) / (4 * w)
    i = int(np.argmax(np.diag(r)))
    j, k = (i + 1) % 3, (i + 2) % 3
    s = np.sqrt(max(0.0, 1.0 + r[i, i] - r[j, j] - r[k, k])) * 2.0
    q = np.zeros(4)
    q[0] = (r[k, j] - r[j, k]) / s
    q[1 + i] = s / 4.0
    q[1 + j] = (r[j, i] + r[i, j]) / s
    q[1 + k] = (r[k, i] + r[i, k]) / s
    return q


def _origin(element: ET.Element | None) -> tuple[np.ndarray, np.ndarray]:
    if element is None:
        return np.eye(3), np.zeros(3)
    return rpy_matrix(_floats(element.get("rpy"), 3)), _floats(element.get("xyz"), 3)


@dataclass
class _Body:
    """A moving link and everything rigidly attached to it, in its frame."""

    name: str
    mass: float = 0.0
    first_moment: np.ndarray = field(default_factory=lambda: np.zeros(3))  # sum m c
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))  # about the frame origin
    geoms: list[str] = field(default_factory=list)
    sites: list[str] = field(default_factory=list)
    children: list[tuple[ET.Element, np.ndarray, np.ndarray]] = field(default_factory=list)  # joint, R, p


def mjcf_from_urdf(path: str | Path, *, floating: bool = True, sites: dict[str, tuple[str, list[float]]] | None = None,
                   friction: float = 0.8, timestep: float = 0.0005, name: str | None = None,
                   ground: float | None = 0.0, world: list[str] | None = None) -> str:
    """MJCF text of the URDF at ``path`` (see the module docs). ``sites`` maps a site
    name to ``(link, offset in that link's frame)``; ``ground`` is the ground plane's
    height (``None``: no plane); ``world`` adds MJCF lines to the world body (terrain geoms:
    give them ``contype="2" conaffinity="1"`` as the ground's)."""
    root = ET.parse(path).getroot()
    links = {link.get("name"): link for link in root.findall("link")}
    joints = root.findall("joint")
    children: dict[str, list[ET.Element]] = {}
    has_parent = set()
    for joint in joints:
        children.setdefault(joint.find("parent").get("link"), []).append(joint)
        has_parent.add(joint.find("child").get("link"))
    (base,) = [n for n in links if n not in has_parent]
    sites_by_link: dict[str, list[tuple[str, np.ndarray]]] = {}
    for site, (link, offset) in (sites or {}).items():
        if link not in links:
            raise ValueError(f"{path}: site {site!r} names no link {link!r}")
        sites_by_link.setdefault(link, []).append((site, np.asarray(offset, dtype=float)))

    def absorb(body: _Body, link: str, r: np.ndarray, p: np.ndarray) -> None:
        """Add ``link`` (at pose r, p in the body's frame) and its rigid subtree to ``body``."""
        element = links[link]
        inertial = element.find("inertial")
        if inertial is not None:
            mass = float(inertial.find("mass").get("value"))
            ri, pi = _origin(inertial.find("origin"))
            tag = inertial.find("inertia")
            ixx, iyy, izz, ixy, ixz, iyz = (float(tag.get(k, 0.0)) for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz"))
            local = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
            rot = r @ ri
            c = p + r @ pi
            # About the frame origin: rotated, then shifted by the parallel-axis theorem.
            body.inertia += rot @ local @ rot.T + mass * (c @ c * np.eye(3) - np.outer(c, c))
            body.mass += mass
            body.first_moment += mass * c
        for k, collision in enumerate(element.findall("collision")):
            rc, pc = _origin(collision.find("origin"))
            geometry = collision.find("geometry")[0]
            rot, pos = r @ rc, p + r @ pc
            attrs = f'name="{link}_{k}" pos="{_text(pos)}" quat="{_text(quaternion(rot))}"'
            if geometry.tag == "box":
                size = _floats(geometry.get("size"), 3) / 2.0
                body.geoms.append(f'<geom type="box" size="{_text(size)}" {attrs}/>')
            elif geometry.tag == "cylinder":
                size = [float(geometry.get("radius")), float(geometry.get("length")) / 2.0]
                body.geoms.append(f'<geom type="cylinder" size="{_text(size)}" {attrs}/>')
            elif geometry.tag == "sphere":
                body.geoms.append(f'<geom type="sphere" size="{float(geometry.get("radius"))!r}" {attrs}/>')
            else:
                raise ValueError(f"{path}: link {link!r} has a {geometry.tag} collision; only boxes, cylinders "
                                 "and spheres are taken")
        for site, offset in sites_by_link.get(link, []):
            body.sites.append(f'<site name="{site}" pos="{_text(p + r @ offset)}" size="0.005"/>')
        for joint in children.get(link, []):
            rj, pj = _origin(joint.find("origin"))
            child = joint.find("child").get("link")
            if joint.get("type") == "fixed":
                absorb(body, child, r @ rj, p + r @ pj)
            else:
                body.children.append((joint, r @ rj, p + r @ pj))

    actuators: list[str] = []

    def write(link: str, joint: ET.Element | None, r: np.ndarray, p: np.ndarray, indent: str) -> list[str]:
        body = _Body(link)
        absorb(body, link, np.eye(3), np.zeros(3))
        lines = [f'{indent}<body name="{link}" pos="{_text(p)}" quat="{_text(quaternion(r))}">']
        inner = indent + "  "
        if joint is None:
            if floating:
                lines.append(f'{inner}<freejoint name="root"/>')
        else:
            kind = {"revolute": "hinge", "continuous": "hinge", "prismatic": "slide"}.get(joint.get("type"))
            if kind is None:
                raise ValueError(f"{path}: joint {joint.get('name')!r} of type {joint.get('type')!r} is not taken")
            axis = _floats(joint.find("axis").get("xyz") if joint.find("axis") is not None else None, 3, 0.0)
            if not axis.any():
                axis = np.array([1.0, 0.0, 0.0])
            limit = joint.find("limit")
            extra = ""
            if limit is not None and joint.get("type") != "continuous":
                extra = f' range="{float(limit.get("lower", 0.0))!r} {float(limit.get("upper", 0.0))!r}" limited="true"'
            lines.append(f'{inner}<joint name="{joint.get("name")}" type="{kind}" axis="{_text(axis)}"{extra}/>')
            effort = float(limit.get("effort", 0.0)) if limit is not None else 0.0
            ctrl = f' ctrlrange="{-effort!r} {effort!r}" ctrllimited="true"' if effort > 0 else ""
            actuators.append(f'    <motor name="{joint.get("name")}" joint="{joint.get("name")}"{ctrl}/>')
        if body.mass > 0:
            com = body.first_moment / body.mass
            about_com = body.inertia - body.mass * (com @ com * np.eye(3) - np.outer(com, com))
            full = [about_com[0, 0], about_com[1, 1], about_com[2, 2], about_com[0, 1], about_com[0, 2],
                    about_com[1, 2]]
            lines.append(f'{inner}<inertial pos="{_text(com)}" mass="{body.mass!r}" fullinertia="{_text(full)}"/>')
        lines += [inner + g for g in body.geoms] + [inner + s for s in body.sites]
        for child_joint, rc, pc in body.children:
            lines += write(child_joint.find("child").get("link"), child_joint, rc, pc, inner)
        lines.append(f"{indent}</body>")
        return lines

    bodies = write(base, None, np.eye(3), np.zeros(3), "    ")
    return "\n".join([
        f'<mujoco model="{name or root.get("name", "robot")}">',
        f'  <option timestep="{timestep!r}" integrator="implicitfast"/>',
        '  <compiler angle="radian" inertiafromgeom="false"/>',
        f'  <default><geom contype="1" conaffinity="2" friction="{friction!r} 0.005 0.0001" condim="3"/></default>',
        '  <visual><headlight ambient="0.4 0.4 0.4" diffuse="0.6 0.6 0.6"/></visual>',
        "  <asset>",
        '    <texture name="grid" type="2d" builtin="checker" rgb1="0.75 0.75 0.75" rgb2="0.55 0.55 0.55" '
        'width="256" height="256"/>',
        '    <material name="grid" texture="grid" texrepeat="10 10" texuniform="true"/>',
        "  </asset>",
        "  <worldbody>",
        '    <light pos="0 0 4" dir="0 0 -1" directional="true"/>',
        *([f'    <geom name="ground" type="plane" size="0 0 1" pos="0 0 {ground!r}" material="grid" contype="2" '
           'conaffinity="1"/>'] if ground is not None else []),
        *(world or []),
        *bodies,
        "  </worldbody>",
        "  <actuator>",
        *actuators,
        "  </actuator>",
        "</mujoco>",
    ]) + "\n"


def _text(values) -> str:
    return " ".join(repr(float(v)) for v in values)
