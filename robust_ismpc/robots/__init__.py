"""Robot descriptions (:class:`RobotSpec`) and the built-in robots ``g1`` and ``op3``.

Importing this package (which every MuJoCo-using module of robust-ismpc does first) sets
``MUJOCO_GL=egl`` on a Linux machine without display when ``MUJOCO_GL`` is unset, because mujoco
chooses its OpenGL backend once, when it is imported, and offscreen video needs EGL there.
"""

import os as _os
import sys as _sys

if _sys.platform.startswith("linux") and not _os.environ.get("DISPLAY") and "mujoco" not in _sys.modules:
    _os.environ.setdefault("MUJOCO_GL", "egl")

from ..inputs import BUILTIN_ROBOTS  # noqa: E402
from .robot_file import load_robot, load_robot_toml  # noqa: E402
from .spec import RobotSpec  # noqa: E402

__all__ = ["BUILTIN_ROBOTS", "RobotSpec", "load_robot", "load_robot_toml"]
