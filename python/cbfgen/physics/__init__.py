"""Tachyon 3 and its ECBF filter in MuJoCo: the paper's physics validation (section V-B).

The kinematic simulation integrates the filter's own model, so it cannot show what
happens when the model is wrong. Here the robot is a MuJoCo model with contact
(:mod:`.model`, built from the same model constants as the generated code), driven at
1 kHz by the gait and the filter acting on its *measured* state (:mod:`.loop`):

    from cbfgen.physics import run

    record = run("stairs", body_cbf=True)
    print(record.summary())   # finished, contacts, clearances, tracking error, slip

``python -m cbfgen.physics`` (or ``scripts/cbf run mujoco``) runs the hardware stairs
with and without the body CBF and writes the summaries, Figs. 7–10 of the physical run
and a side-by-side GIF of the two climbs. Needs the ``mujoco`` package (pinned in
``python/requirements.txt``); the GIF needs an OpenGL back end (OSMesa from Debian's
``libosmesa6``).

:func:`mjcf_from_urdf` (:mod:`.urdf_model`) builds a MuJoCo model of any URDF from its
inertials and collision primitives, fixed links merged into the moving ones as Pinocchio
does (ANYmal C's agrees with Pinocchio's mass matrix to 1e-12).
"""

from importlib import import_module

# Loaded on first use: importing MuJoCo fixes its OpenGL back end, which the renderer
# (`python -m cbfgen.physics`) must choose first.
_HOME = {
    "MAX_CATCH_UP": "loop",
    "MAX_LEAD": "loop",
    "PENETRATION_TOLERANCE": "loop",
    "RISER_ANGLE": "loop",
    "TIP_OVER_ROLL": "loop",
    "PhysicalRobot": "loop",
    "PhysicalRun": "loop",
    "PoseEstimate": "loop",
    "anchored": "loop",
    "run": "loop",
    "ASSUMED": "model",
    "PHYSICAL_SCENARIOS": "loop",
    "TIMESTEP": "model",
    "RobotParams": "model",
    "robot_mjcf": "model",
    "mjcf_from_urdf": "urdf_model",
}


def __getattr__(name: str):
    if name in _HOME:
        return getattr(import_module(f".{_HOME[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "ASSUMED",
    "MAX_CATCH_UP",
    "MAX_LEAD",
    "PENETRATION_TOLERANCE",
    "PHYSICAL_SCENARIOS",
    "RISER_ANGLE",
    "TIMESTEP",
    "TIP_OVER_ROLL",
    "PhysicalRobot",
    "PhysicalRun",
    "PoseEstimate",
    "RobotParams",
    "anchored",
    "mjcf_from_urdf",
    "robot_mjcf",
    "run",
]
