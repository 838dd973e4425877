"""Robot descriptions (:class:`RobotSpec`) and the built-in robots ``g1`` and ``op3``."""

from .spec import BUILTIN_ROBOTS, RobotSpec, load_robot, load_robot_toml

__all__ = ["BUILTIN_ROBOTS", "RobotSpec", "load_robot", "load_robot_toml"]
