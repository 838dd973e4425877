"""A robot's MuJoCo model: compiled from its robot file, checked against it, measured standing.

:func:`load_robot` takes a built-in robot name or a robot file, compiles the model, checks the
file's names against it, puts it in its standing posture and measures what the reduced model
needs (mass, CoM height, foot spacing, base height), returning a frozen
:class:`~robust_ismpc.robots.spec.RobotSpec`. It never steps a simulation.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import math
import os
from pathlib import Path

import mujoco
import numpy as np

from ..exceptions import ModelError, ParameterError
from ..robots.robot_file import RobotFile, read_robot_file, robot_file_path
from ..robots.spec import RobotSpec

logger = logging.getLogger("robust_ismpc")

#: Largest tilt of a sole frame in the standing posture [deg].
MAX_SOLE_TILT_DEG = 2.0


def compile_model(spec: RobotSpec) -> mujoco.MjModel:
    """The robot's MJCF scene compiled, with its sole sites and its physics step (the robot file's
    ``physics_step_s``, else the model's own timestep) (cached: copy before mutating)."""
    return _compile_model(str(spec.model_path), spec.model_path.stat().st_mtime, spec.sole_sites, spec.physics_step_s)


def scene_spec(spec: RobotSpec) -> mujoco.MjSpec:
    """The robot's MJCF scene as an editable :class:`mujoco.MjSpec`, with its sole sites added and
    its physics step set (as :func:`compile_model`)."""
    return _scene_spec(str(spec.model_path), spec.sole_sites, spec.physics_step_s)


def standing_qpos(spec: RobotSpec, model: mujoco.MjModel) -> np.ndarray:
    """Generalised coordinates of the standing posture, soles on the floor at the origin.

    Parameters
    ----------
    spec : RobotSpec
    model : mujoco.MjModel
        The robot model, or a scene built from it (extra joints keep ``qpos0``).

    Returns
    -------
    ndarray, shape (model.nq,)
        Root body at (0, 0, ``base_height_m``), identity orientation, joints in the standing
        posture.
    """
    qpos = _posture_qpos(model, spec.root_body, spec.standing_posture)
    adr = _free_qpos_adr(model, spec.root_body)
    qpos[adr + 2] = spec.base_height_m
    return qpos


#: Environment variable naming the folder of compiled models; empty disables the disk cache.
CACHE_ENV = "ROBUST_ISMPC_CACHE"


def model_cache_dir() -> Path | None:
    """Folder where compiled models are kept between processes (``$ROBUST_ISMPC_CACHE``, else
    ``$XDG_CACHE_HOME/robust-ismpc/models`` or ``~/.cache/robust-ismpc/models``); None when
    ``ROBUST_ISMPC_CACHE`` is set empty."""
    configured = os.environ.get(CACHE_ENV)
    if configured is not None:
        return Path(configured) if configured else None
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "robust-ismpc" / "models"


#: A scene folder with more files than this is not cached (its key would take long to compute).
MAX_CACHED_FOLDER_FILES = 5000


def _source_key(path: str, sites: tuple, physics_step_s: float | None = None) -> str | None:
    """Digest of what a compiled model depends on: mujoco's version, the scene path, the added
    sites, the physics step set and the size and time of every file in the scene's folder
    (includes and meshes); None for a folder of more than :data:`MAX_CACHED_FOLDER_FILES` files."""
    step = "" if physics_step_s is None else f"|timestep={physics_step_s!r}"
    digest = hashlib.sha256(f"{mujoco.__version__}|{path}|{sites!r}{step}".encode())
    files = 0
    for file in sorted(Path(path).parent.rglob("*")):
        if file.is_file():
            files += 1
            if files > MAX_CACHED_FOLDER_FILES:
                return None
            stat = file.stat()
            digest.update(f"{file}|{stat.st_size}|{stat.st_mtime_ns}".encode())
    return digest.hexdigest()[:32]


@functools.lru_cache(maxsize=8)
def _compile_model(path: str, mtime: float, sites: tuple, physics_step_s: float | None = None) -> mujoco.MjModel:
    """The scene at ``path`` with ``sites`` added and its timestep replaced by ``physics_step_s``
    (None: the model's own), compiled; kept in memory, and on disk in :func:`model_cache_dir`
    (MJCF compilation takes about a second for a humanoid, reading the binary model a few
    milliseconds)."""
    del mtime  # part of the in-memory cache key only
    folder = model_cache_dir()
    key = None if folder is None else _source_key(path, sites, physics_step_s)
    cached = None if folder is None or key is None else folder / f"{key}.mjb"
    if cached is not None and cached.is_file():
        try:
            return mujoco.MjModel.from_binary_path(str(cached))
        except ValueError:
            logger.warning("ignoring an unreadable compiled model %s", cached)
    try:
        if not sites and physics_step_s is None:
            model = mujoco.MjModel.from_xml_path(path)
        else:
            model = _scene_spec(path, sites, physics_step_s).compile()
    except ValueError as exc:
        raise ModelError(f"cannot compile MJCF model {path!r}: {exc}") from None
    if cached is not None:
        try:
            cached.parent.mkdir(parents=True, exist_ok=True)
            partial = cached.with_name(f".{cached.name}.{os.getpid()}")
            mujoco.mj_saveModel(model, str(partial), None)
            os.replace(partial, cached)
        except OSError as exc:  # a read-only home: compile every time
            logger.info("not caching the compiled model in %s: %s", folder, exc)
    return model


def _scene_spec(path: str, sites: tuple = (), physics_step_s: float | None = None) -> mujoco.MjSpec:
    """The scene at ``path`` as an MjSpec with ``sites`` ((name, body, pos, quat), ...) added and
    the timestep ``physics_step_s`` [s] (None: the model's own)."""
    try:
        spec = mujoco.MjSpec.from_file(path)
    except ValueError as exc:
        raise ModelError(f"cannot read MJCF model {path!r}: {exc}") from None
    if physics_step_s is not None:
        spec.option.timestep = physics_step_s
    for name, body_name, pos, quat in sites:
        body = spec.body(body_name)
        if body is None:
            raise ModelError(f"body {body_name!r} for the site {name!r} not found in the model {path!r}")
        body.add_site(name=name, pos=list(pos), quat=list(quat))
    return spec


def floor_geoms(model: mujoco.MjModel) -> list[int]:
    """The floor: ids of the plane geoms of the world body."""
    return [g for g in range(model.ngeom)
            if model.geom_bodyid[g] == 0 and int(model.geom_type[g]) == int(mujoco.mjtGeom.mjGEOM_PLANE)]


def has_floor(model: mujoco.MjModel) -> bool:
    """True if the model has a floor: a plane geom of the world body."""
    return bool(floor_geoms(model))


def _free_qpos_adr(model: mujoco.MjModel, root_body: str) -> int:
    body_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, root_body)
    if body_id < 0:
        raise ModelError(f"root body {root_body!r} not found in the model")
    jnt = model.body_jntadr[body_id]
    if model.body_jntnum[body_id] < 1 or model.jnt_type[jnt] != mujoco.mjtJoint.mjJNT_FREE:
        raise ModelError(f"root body {root_body!r} has no free joint (floating base)")
    return int(model.jnt_qposadr[jnt])


def _posture_qpos(
    model: mujoco.MjModel, root_body: str, posture: tuple[tuple[str, float], ...]
) -> np.ndarray:
    qpos = model.qpos0.copy()
    adr = _free_qpos_adr(model, root_body)
    qpos[adr : adr + 7] = (0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)
    for joint, value in posture:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint)
        if jid < 0:
            raise ModelError(f"standing posture joint {joint!r} not found in the model")
        qpos[model.jnt_qposadr[jid]] = value
    return qpos


def foot_frame_pose(
    model: mujoco.MjModel, data: mujoco.MjData, frame_type: str, frame_id: int
) -> tuple[np.ndarray, np.ndarray]:
    """World pose of a foot frame after kinematics: (position (3,) [m], rotation (3, 3))."""
    if frame_type == "site":
        return data.site_xpos[frame_id], data.site_xmat[frame_id].reshape(3, 3)
    return data.xpos[frame_id], data.xmat[frame_id].reshape(3, 3)


def frame_id(model: mujoco.MjModel, frame_type: str, name: str, what: str) -> int:
    """Id of a site or body, raising :class:`ModelError` naming ``what`` when absent."""
    obj = mujoco.mjtObj.mjOBJ_SITE if frame_type == "site" else mujoco.mjtObj.mjOBJ_BODY
    fid = mujoco.mj_name2id(model, obj, name)
    if fid < 0:
        raise ModelError(f"{what} {frame_type} {name!r} not found in the model")
    return int(fid)


def frame_body(model: mujoco.MjModel, frame_type: str, fid: int) -> int:
    """Body id carrying a site or body frame."""
    return int(model.site_bodyid[fid]) if frame_type == "site" else fid


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


def _check_names(robot_file: RobotFile, model: mujoco.MjModel, model_path: Path) -> None:
    """Raise :class:`ModelError` for a name of the file that the model lacks."""
    toml_path, table = robot_file.path, robot_file.table
    if not has_floor(model):
        raise ModelError(f"{toml_path}: model {str(model_path)!r} has no floor (a plane geom of the world "
                         "body); point model at a scene file that adds one")
    for key in ("root_body", "torso_body"):
        if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, str(table[key])) < 0:
            raise ModelError(f"{toml_path}: {key} {table[key]!r} not found in the model {model_path}")
    frame_type = table["foot_frame_type"]
    for side in ("left", "right"):
        name = table[f"{side}_foot"]
        obj = mujoco.mjtObj.mjOBJ_SITE if frame_type == "site" else mujoco.mjtObj.mjOBJ_BODY
        if mujoco.mj_name2id(model, obj, name) < 0:
            raise ModelError(f"{toml_path}: {side}_foot {frame_type} {name!r} not found in the model {model_path}")
    for joint in robot_file.leg_joints:
        if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint) < 0:
            raise ModelError(f"{toml_path}: leg joint {joint!r} not found in the model {model_path}")


def load_robot_file(path: str | Path) -> RobotSpec:
    """Read a robot file (:func:`~robust_ismpc.robots.robot_file.read_robot_file`), check it
    against its model and measure the model.

    Raises
    ------
    ParameterError
        Missing, unknown or ill-typed keys, or gait values that do not make valid parameters.
    ModelError
        Model file missing or not compilable, names (feet, bodies, joints) absent in it, or a
        standing posture with tilted soles or soles at different heights.
    """
    robot_file = read_robot_file(path)
    toml_path, table, model_path = robot_file.path, robot_file.table, robot_file.model_path()
    model = _compile_model(str(model_path), model_path.stat().st_mtime, ())
    _check_names(robot_file, model, model_path)
    if robot_file.sole_sites:
        model = _compile_model(str(model_path), model_path.stat().st_mtime, robot_file.sole_sites)
    try:
        measured = _measure(model, root_body=str(table["root_body"]), foot_frame_type=robot_file.foot_frame_type,
                            feet=robot_file.feet, offsets=robot_file.offsets, posture=robot_file.posture)
    except ModelError as exc:
        raise ModelError(f"{toml_path}: {exc}") from None
    try:
        spec = RobotSpec(
            name=str(table["name"]),
            model_path=model_path,
            root_body=str(table["root_body"]),
            torso_body=str(table["torso_body"]),
            left_foot=robot_file.feet[0],
            right_foot=robot_file.feet[1],
            foot_frame_type=robot_file.foot_frame_type,
            left_sole_offset_m=robot_file.offsets[0],
            right_sole_offset_m=robot_file.offsets[1],
            **robot_file.sole_size,
            leg_joints=robot_file.leg_joints,
            standing_posture=robot_file.posture,
            gait_overrides=robot_file.gait_overrides,
            sole_outline_m=robot_file.sole_outline_m,
            sole_sites=robot_file.sole_sites,
            **robot_file.simulation,
            sensors=robot_file.sensors,
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
    return load_robot_file(path)


def load_robot(name_or_toml_path: str | Path) -> RobotSpec:
    """The :class:`RobotSpec` of a built-in robot or of a robot file (cached per file version).

    Parameters
    ----------
    name_or_toml_path : str or Path
        A built-in robot name (:data:`~robust_ismpc.robots.BUILTIN_ROBOTS`) or the path of a
        TOML robot description.

    Raises
    ------
    ParameterError
        Unknown name (the message lists the built-in robots) or invalid description.
    ModelError
        Model file missing, or names absent in the model.
    """
    path = robot_file_path(name_or_toml_path)
    return _load_cached(str(path), path.stat().st_mtime)
