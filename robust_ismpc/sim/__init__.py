"""MuJoCo layer: measurements, disturbances, closed loop, fall detection and video.

This subpackage (with :mod:`robust_ismpc.wbik` and :mod:`robust_ismpc.robots`) is the only
place that imports mujoco.
"""

# isort: off
from .. import robots as _robots  # noqa: F401  (sets the MUJOCO_GL default before mujoco is imported)

# isort: on

from .disturbances import Force, ForceSchedule, Impulse, Payload, SwingingBall, build_scene
from .inverse_dynamics import InverseDynamicsQp, TorqueControlSettings
from .mujoco_loop import (
    LoopSettings,
    MujocoSimulation,
    initial_state,
)
from .mujoco_robot import (
    ContactState,
    FallCriteria,
    MujocoRobot,
    SolePose,
    convex_hull,
    distance_outside,
    sole_corners,
    standing_state,
)
from .video import VideoRecorder, VideoSettings, configure_offscreen_gl

__all__ = [
    "ContactState",
    "FallCriteria",
    "Force",
    "ForceSchedule",
    "Impulse",
    "InverseDynamicsQp",
    "LoopSettings",
    "MujocoRobot",
    "MujocoSimulation",
    "Payload",
    "SolePose",
    "SwingingBall",
    "TorqueControlSettings",
    "VideoRecorder",
    "VideoSettings",
    "build_scene",
    "configure_offscreen_gl",
    "convex_hull",
    "distance_outside",
    "initial_state",
    "sole_corners",
    "standing_state",
]
