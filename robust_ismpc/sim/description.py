"""A walking scene from a robot description: a URDF, or an MJCF robot without floor or floating base.

Most humanoids ship a URDF, not a MuJoCo scene. :func:`write_walking_scene` loads the description
with MuJoCo's own importer (``package://`` paths resolved first, :func:`find_package`; relative
mesh paths made absolute; ASCII STL collision meshes converted to the binary STL MuJoCo reads)
and adds only what a walking scene needs and the description does not say:

- a free joint on the root link (the floating base), the robot raised so that its lowest
  colliding geometry rests on the floor;
- a floor (a plane) and a light;
- one torque motor per joint, limited to the joint's effort limit (URDF ``<limit effort>``,
  which MuJoCo's importer keeps as the joint's actuator force range);
- collisions between the robot and the floor only, for a URDF (MuJoCo's importer lets every body
  collide with every body it is not jointed to; a description's collision meshes are rarely meant
  for that); an MJCF keeps its own contact settings;
- a physics step suited to torque control
  (:func:`~robust_ismpc.sim.model_checks.drafted_physics_step`) with the implicit-in-velocity
  integrator, which the joint damping of URDFs needs at that step;
- optionally a box sole on each foot in place of the foot's own colliding geometry
  (:class:`SoleBox`, used by ``ismpc robot init`` when the foot's own geometry gives a jumping
  centre of pressure).

Every addition is listed in :attr:`WalkingScene.additions` and as comments at the top of the
scene file, so that a user can see and change it.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from ..exceptions import ModelError
from .model_checks import drafted_physics_step
from .soles import lowest_z

#: Collision bits of a converted URDF: robot geoms collide with the floor, not with each other
#: (MuJoCo collides two geoms when ``contype₁ & conaffinity₂`` or ``contype₂ & conaffinity₁``).
ROBOT_CONTYPE, ROBOT_CONAFFINITY = 2, 1
FLOOR_CONTYPE, FLOOR_CONAFFINITY = 1, 3
#: Height of the lowest colliding geometry above the floor in the written scene [m].
CLEARANCE_M = 0.001

_PACKAGE_URI = re.compile(r"package://([^/\"'\s]+)/([^\"'\s<]*)")


@dataclass(frozen=True)
class SoleBox:
    """A box sole replacing a foot's own colliding geometry.

    Attributes
    ----------
    foot : str
        Name of the foot body.
    centre_m : tuple of float
        Centre of the box's bottom face in the foot body's frame [m].
    quat : tuple of float
        Orientation of the box in the foot body's frame (w, x, y, z).
    length_m, width_m : float
        Sides of the sole along the box's x and y [m].
    thickness_m : float
        Box height [m]; the box lies above its bottom face.
    """

    foot: str
    centre_m: tuple[float, float, float]
    quat: tuple[float, float, float, float]
    length_m: float
    width_m: float
    thickness_m: float = 0.01


@dataclass
class WalkingScene:
    """What :func:`write_walking_scene` wrote."""

    path: Path
    source: Path
    kind: str  # "urdf" or "mjcf"
    root_body: str
    additions: list[str] = field(default_factory=list)
    packages: dict[str, Path] = field(default_factory=dict)


def description_kind(path: str | Path) -> str | None:
    """``"urdf"`` for a URDF, ``"mjcf"`` for an MJCF robot without floor or free joint, None for an
    MJCF scene (floor and floating base present: used as it is)."""
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise ModelError(f"cannot read the model {str(path)!r}: {exc}") from None
    if root.tag == "robot":
        return "urdf"
    if root.tag != "mujoco":
        raise ModelError(f"{str(path)!r} is neither a URDF (<robot>) nor an MJCF (<mujoco>) file")
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except ValueError as exc:
        raise ModelError(f"cannot compile MJCF model {str(path)!r}: {exc}") from None
    has_free = any(j.type == mujoco.mjtJoint.mjJNT_FREE for j in spec.joints)
    has_floor = any(g.type == mujoco.mjtGeom.mjGEOM_PLANE for g in spec.worldbody.geoms)
    return None if has_free and has_floor else "mjcf"


def find_package(name: str, source: Path, package_dirs: Sequence[str | Path] = ()) -> Path | None:
    """The folder that ``package://NAME/`` means for a description at ``source``.

    Searched in order: each of ``package_dirs`` (the folder itself when it is named NAME, then
    NAME and share/NAME inside it), then every folder above ``source`` (NAME, share/NAME inside
    it, and the folder itself when it is named NAME). None when not found.
    """
    candidates: list[Path] = []
    for folder in package_dirs:
        folder = Path(folder).expanduser().resolve()
        candidates += [folder] if folder.name == name else []
        candidates += [folder / name, folder / "share" / name]
    for parent in Path(source).resolve().parents:
        candidates += [parent / name, parent / "share" / name]
        candidates += [parent] if parent.name == name else []
    return next((c for c in candidates if c.is_dir()), None)


def _resolve_packages(text: str, source: Path, package_dirs: Sequence[str | Path]) -> tuple[str, dict[str, Path]]:
    names = sorted({name for name, _ in _PACKAGE_URI.findall(text)})
    found = {name: find_package(name, source, package_dirs) for name in names}
    missing = [name for name, folder in found.items() if folder is None]
    if missing:
        raise ModelError(
            f"{source.name}: cannot find the package(s) {', '.join(repr(m) for m in missing)} of its package:// "
            f"paths in the folders above it; give the folder that holds them with --package-dir")
    resolved = {name: folder for name, folder in found.items() if folder is not None}
    return _PACKAGE_URI.sub(lambda m: str(resolved[m.group(1)] / m.group(2)), text), resolved


#: Mesh formats MuJoCo reads.
MESH_SUFFIXES = (".stl", ".obj", ".msh")


def _ascii_stl_to_binary(path: Path, out: Path) -> None:
    """Write the ASCII STL at ``path`` as a binary STL at ``out`` (MuJoCo reads binary STL only)."""
    numbers = re.findall(r"vertex\s+(\S+)\s+(\S+)\s+(\S+)", path.read_text(errors="replace"))
    vertices = np.array(numbers, dtype=np.float32).reshape(-1, 3, 3)
    normals = np.cross(vertices[:, 1] - vertices[:, 0], vertices[:, 2] - vertices[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    records = np.zeros(len(vertices), dtype=[("normal", "<f4", 3), ("vertices", "<f4", (3, 3)), ("attr", "<u2")])
    records["normal"], records["vertices"] = normals, vertices
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_bytes(b"converted from ASCII by robust-ismpc".ljust(80, b" ")
                    + np.uint32(len(vertices)).tobytes() + records.tobytes())


def _meshes_readable(root: ET.Element, source: Path, mesh_dir: Path) -> list[str]:
    """Make every mesh path of the URDF ``root`` absolute (relative ones are relative to
    ``source``'s folder) and readable by MuJoCo: an ASCII STL is converted to a binary one in
    ``mesh_dir``. Returns a line per conversion; raises ModelError for a format MuJoCo cannot
    read in the collision geometry (a visual mesh is left out with the other visual geometry)."""
    notes = []
    for kind in ("collision", "visual"):
        for mesh in root.iter(kind):
            for element in mesh.iter("mesh"):
                name = element.get("filename")
                if not name:
                    continue
                path = Path(name) if Path(name).is_absolute() else (source.parent / name).resolve()
                element.set("filename", str(path))
                if kind == "visual":
                    continue
                if path.suffix.lower() not in MESH_SUFFIXES:
                    raise ModelError(
                        f"{source.name}: the collision mesh {path.name} is a {path.suffix} file; MuJoCo reads STL, "
                        "OBJ and MSH. Convert it (for example with trimesh or MeshLab) or use a variant of the "
                        "description with STL collision meshes")
                if path.suffix.lower() == ".stl" and path.is_file() and path.read_bytes()[:5].lower() == b"solid" \
                        and b"facet" in path.read_bytes()[:1000]:
                    converted = mesh_dir / f"{path.parent.name}_{path.name}"
                    _ascii_stl_to_binary(path, converted)
                    element.set("filename", str(converted))
                    notes.append(f"the ASCII STL {path} converted to the binary {converted}")
    return notes


def _urdf_spec(source: Path, package_dirs: Sequence[str | Path],
               mesh_dir: Path) -> tuple[mujoco.MjSpec, dict[str, Path], list[str]]:
    text, packages = _resolve_packages(source.read_text(), source, package_dirs)
    root = ET.fromstring(text)
    notes = _meshes_readable(root, source, mesh_dir)
    for old in root.findall("mujoco"):
        root.remove(old)
    extension = ET.SubElement(root, "mujoco")
    # absolute mesh paths, the collision geometry only (a visual mesh may be a format MuJoCo cannot
    # read); bodies without joints are fused into their parents (the importer's default) only once
    # the root has its free joint, or the root itself would be fused into the world
    ET.SubElement(extension, "compiler", strippath="false", discardvisual="true", fusestatic="false")
    try:
        return mujoco.MjSpec.from_string(ET.tostring(root, encoding="unicode")), packages, notes
    except ValueError as exc:
        raise ModelError(f"MuJoCo cannot import {source.name}: {exc}") from None


def _mjcf_spec(source: Path) -> mujoco.MjSpec:
    try:
        spec = mujoco.MjSpec.from_file(str(source))
    except ValueError as exc:
        raise ModelError(f"cannot compile MJCF model {str(source)!r}: {exc}") from None
    # asset paths stay valid from the scene's folder
    for attr in ("meshdir", "texturedir"):
        value = getattr(spec, attr)
        setattr(spec, attr, str((source.parent / value).resolve()) if value else str(source.parent.resolve()))
    return spec


def _root(spec: mujoco.MjSpec) -> mujoco.MjsBody:
    bodies = list(spec.worldbody.bodies)
    if len(bodies) != 1:
        names = ", ".join(repr(b.name) for b in bodies)
        raise ModelError(f"the robot must hang from one root body; the world holds {len(bodies)}: {names}")
    return bodies[0]


def _lowest_colliding_z(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    """Lowest world z of the robot's colliding geoms [m]."""
    colliding = [g for g in range(model.ngeom)
                 if model.geom_bodyid[g] != 0 and (model.geom_contype[g] or model.geom_conaffinity[g])]
    lowest = lowest_z(model, data, colliding)
    if not np.isfinite(lowest):
        raise ModelError("no geometry of the robot collides: it cannot stand on a floor")
    return lowest


def _knee_flexion_moves_feet_forward(model: mujoco.MjModel, root: int) -> bool | None:
    """Whether bending the knees moves the feet towards the root frame's +x (the robot then faces
    −x: a knee bends forwards, its foot swings back); None when no knee is recognised.

    A knee is a hinge whose axis lies along the root frame's y (within 35°) and whose range is
    at least 1.5 rad wide and lies at least 90 % on one side of zero, with a foot below it (a body
    within 5 cm of the robot's lowest); it is bent 0.3 rad into its range and that body is followed.
    """
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    bottom_z = float(data.xpos[1:, 2].min())
    root_rot = data.xmat[root].reshape(3, 3)
    moves = []
    for j in range(model.njnt):
        if int(model.jnt_type[j]) != int(mujoco.mjtJoint.mjJNT_HINGE) or not model.jnt_limited[j]:
            continue
        low, high = (float(v) for v in model.jnt_range[j])
        if high - low < 1.5 or max(abs(low), abs(high)) < 0.9 * (abs(low) + abs(high)):
            continue
        body = int(model.jnt_bodyid[j])
        axis = root_rot.T @ data.xmat[body].reshape(3, 3) @ model.jnt_axis[j]
        if abs(axis[1]) < np.cos(np.radians(35.0)):
            continue
        below = [b for b in range(model.nbody) if b == body or _is_below(model, b, body)]
        foot = min(below, key=lambda b: float(data.xpos[b][2]))
        if data.xpos[foot][2] > bottom_z + 0.05:
            continue
        before = root_rot.T @ data.xpos[foot]
        bent = mujoco.MjData(model)
        bent.qpos[:] = data.qpos
        bent.qpos[model.jnt_qposadr[j]] += 0.3 if abs(high) > abs(low) else -0.3
        mujoco.mj_kinematics(model, bent)
        moves.append(float((root_rot.T @ bent.xpos[foot] - before)[0]))
    return None if not moves else sum(moves) > 0


def _is_below(model: mujoco.MjModel, body: int, ancestor: int) -> bool:
    while body > 0:
        body = int(model.body_parentid[body])
        if body == ancestor:
            return True
    return False


def _turned_to_face_x(spec: mujoco.MjSpec) -> tuple[mujoco.MjSpec, str]:
    """``spec`` with its root body wrapped in a new root turned by 180° about z, which carries the
    old root's inertia; returns the new spec and the new root's name."""
    root_xml = ET.fromstring(spec.to_xml())
    world = root_xml.find("worldbody")
    old = world.find("body")
    name = f"{old.get('name')}_facing_x"
    new = ET.Element("body", name=name, pos=old.get("pos", "0 0 0"))
    if old.get("quat"):
        new.set("quat", old.get("quat"))
    inertial = old.find("inertial")
    if inertial is not None:
        old.remove(inertial)
        pos = np.array([float(v) for v in inertial.get("pos", "0 0 0").split()])
        inertial.set("pos", " ".join(f"{v:.9g}" for v in (-pos[0], -pos[1], pos[2])))
        quat = np.array([float(v) for v in inertial.get("quat", "1 0 0 0").split()])
        turned = np.zeros(4)
        mujoco.mju_mulQuat(turned, np.array([0.0, 0.0, 0.0, 1.0]), quat)
        inertial.set("quat", " ".join(f"{v:.9g}" for v in turned))
        new.append(inertial)
        ET.SubElement(old, "inertial", pos="0 0 0", mass="0", diaginertia="0 0 0")
    old.set("pos", "0 0 0")
    old.set("quat", "0 0 0 1")
    world.remove(old)
    new.append(old)
    world.append(new)
    return mujoco.MjSpec.from_string(ET.tostring(root_xml, encoding="unicode")), name


def _add_sole_box(spec: mujoco.MjSpec, box: SoleBox) -> None:
    body = spec.body(box.foot)
    if body is None:
        raise ModelError(f"sole box: foot body {box.foot!r} not found")
    for geom in body.geoms:
        geom.contype, geom.conaffinity = 0, 0
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, np.asarray(box.quat, dtype=float))
    up = rot.reshape(3, 3)[:, 2]
    half = 0.5 * box.thickness_m
    body.add_geom(name=f"{box.foot}_sole", type=mujoco.mjtGeom.mjGEOM_BOX,
                  size=[0.5 * box.length_m, 0.5 * box.width_m, half],
                  pos=list(np.asarray(box.centre_m, dtype=float) + half * up), quat=list(box.quat),
                  contype=ROBOT_CONTYPE, conaffinity=ROBOT_CONAFFINITY, rgba=[0.3, 0.3, 0.3, 1.0])


def write_walking_scene(source: str | Path, out_path: str | Path, package_dirs: Sequence[str | Path] = (),
                        sole_boxes: Sequence[SoleBox] = ()) -> WalkingScene:
    """Write a walking scene for the description ``source`` at ``out_path`` (module docstring).

    Parameters
    ----------
    source : path
        A URDF, or an MJCF robot without floor or free joint.
    out_path : path
        The scene to write (an MJCF file; its folder is created).
    package_dirs : sequence of path
        Extra folders searched for ``package://`` paths (:func:`find_package`).
    sole_boxes : sequence of SoleBox
        Box soles replacing the named feet's colliding geometry.

    Raises
    ------
    ModelError
        Unreadable or unimportable description, unresolved packages, more than one root body, a
        root that already has joints, no colliding geometry.
    """
    source = Path(source).expanduser().resolve()
    if not source.is_file():
        raise ModelError(f"model file {str(source)!r} not found")
    kind = description_kind(source)
    if kind is None:
        raise ModelError(f"{source.name} is already a scene (floor and floating base): use it as it is")
    out_path = Path(out_path).expanduser().resolve()
    packages: dict[str, Path] = {}
    converted: list[str] = []
    if kind == "urdf":
        spec, packages, converted = _urdf_spec(source, package_dirs, out_path.with_name(f"{out_path.stem}_meshes"))
    else:
        spec = _mjcf_spec(source)
    additions = [f"{kind.upper()} {source} imported by MuJoCo {mujoco.__version__}"]
    additions += [f"package://{name} = {folder}" for name, folder in packages.items()] + converted
    root = _root(spec)
    if not any(j.type == mujoco.mjtJoint.mjJNT_FREE for j in root.joints) and not list(root.joints):
        try:
            model = spec.compile()
        except ValueError as exc:
            raise ModelError(f"MuJoCo cannot compile {source.name}: {exc}") from None
        if _knee_flexion_moves_feet_forward(model, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, root.name)):
            old_name = root.name
            spec, new_name = _turned_to_face_x(spec)
            root = _root(spec)
            additions.append(f"a root body {new_name!r} facing the robot's front (its knees bend towards the "
                             f"description's -x): {old_name!r} turned by 180 degrees inside it, its inertia moved up")
    floor_present = any(g.type == mujoco.mjtGeom.mjGEOM_PLANE for g in spec.worldbody.geoms)
    if not any(j.type == mujoco.mjtJoint.mjJNT_FREE for j in root.joints):
        if list(root.joints):
            raise ModelError(f"the root body {root.name!r} has joints; a floating base needs a root without any")
        root.add_freejoint(name=f"{root.name}_floating_base")
        additions.append(f"a free joint on the root body {root.name!r} (the floating base)")
    if kind == "urdf":
        for geom in spec.geoms:
            if geom.contype or geom.conaffinity:
                geom.contype, geom.conaffinity = ROBOT_CONTYPE, ROBOT_CONAFFINITY
        additions.append(f"collisions between the robot and the floor only (robot geoms contype {ROBOT_CONTYPE}, "
                         f"conaffinity {ROBOT_CONAFFINITY}; floor {FLOOR_CONTYPE}, {FLOOR_CONAFFINITY}); set a geom's "
                         f"contype to 3 to let it collide with the robot too")
    for box in sole_boxes:
        _add_sole_box(spec, box)
        additions.append(f"a {100 * box.length_m:.1f} x {100 * box.width_m:.1f} cm box sole on {box.foot!r} in place "
                         "of its own colliding geometry (collisions off; a URDF's is then left out)")
    if not floor_present:
        spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05],
                                contype=FLOOR_CONTYPE, conaffinity=FLOOR_CONAFFINITY, rgba=[0.8, 0.8, 0.8, 1])
        light = spec.worldbody.add_light(name="sun", pos=[0, 0, 5], dir=[0, 0, -1])
        if hasattr(mujoco, "mjtLightType"):  # MuJoCo >= 3.3
            light.type = mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
        else:
            light.directional = True
        additions.append("a floor (plane named 'floor') and a directional light")
    if not list(spec.actuators):
        unlimited = []
        for joint in spec.joints:
            if joint.type not in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
                continue
            limited = joint.actfrclimited != mujoco.mjtLimited.mjLIMITED_FALSE
            effort = float(joint.actfrcrange[1]) if limited else 0.0
            actuator = spec.add_actuator(name=joint.name, target=joint.name,
                                         trntype=mujoco.mjtTrn.mjTRN_JOINT)
            actuator.set_to_motor()
            if effort > 0:
                actuator.ctrlrange = [-effort, effort]
                actuator.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
            else:
                unlimited.append(joint.name)
        additions.append("a torque motor on every joint, limited to the joint's effort limit")
        if unlimited:
            additions.append(f"no effort limit, so unlimited motors: {', '.join(unlimited)}")
    if kind == "urdf":
        spec.compiler.fusestatic = True
    step, note = drafted_physics_step(float(spec.option.timestep))
    spec.option.timestep = step
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    origin = note or "the description's own"
    additions.append(f"physics step {1e3 * step:g} ms ({origin}), implicit-in-velocity integrator")
    try:
        model = spec.compile()
    except ValueError as exc:
        raise ModelError(f"the scene for {source.name} does not compile: {exc}") from None
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    lift = CLEARANCE_M - _lowest_colliding_z(model, data)
    if abs(lift) > 1e-9:
        root.pos = list(np.asarray(root.pos, dtype=float) + [0.0, 0.0, lift])
        additions.append(f"the robot placed {1e3 * CLEARANCE_M:g} mm above the floor (root raised {lift:+.3f} m)")
    text = spec.to_xml()
    header = "\n".join(["<!-- Walking scene written by `ismpc robot init`. Added to the description:"]
                       + [f"  - {line.replace('--', '-')}" for line in additions] + ["-->"])
    out_path.parent.mkdir(parents=True, exist_ok=True)
    out_path.write_text(header + "\n" + text)
    return WalkingScene(path=out_path, source=source, kind=kind, root_body=root.name, additions=additions,
                        packages=packages)


__all__ = ["CLEARANCE_M", "SoleBox", "WalkingScene", "description_kind", "find_package", "write_walking_scene"]
