"""Robot descriptions: robot files (TOML) and the built-in robots. Data only, no MuJoCo.

:func:`robust_ismpc.sim.model.load_robot` turns a robot file into a measured
:class:`RobotSpec`.
"""

from .robot_file import (
           BUILTIN_ROBOTS,
           RobotFile,
           is_robot_file,
           read_robot_file,
           robot_file_path,
           robot_reference,
)
from .spec import RobotSpec

__all__ = ["BUILTIN_ROBOTS", "RobotFile", "RobotSpec", "is_robot_file", "read_robot_file", "robot_file_path",
           "robot_reference"]
