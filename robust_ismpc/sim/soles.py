"""Feet and soles in a model's geometry: what touches the floor, the lowest foot on each side, the
sole rectangle (for ``ismpc robot init``, :mod:`robust_ismpc.sim.wizard`).

A *foot* is a body moved by a joint (the ankle) together with the bodies welded to it (children
without joints, such as a sole plate); its *floor geometry* is the geoms of that group that
collide with the floor (``contype``/``conaffinity`` against a plane geom of the world body),
whichever body of the group carries them. Visual geometry (a mesh with collisions off) never
makes a sole, even where it reaches as low: the sole is where the floor pushes. Only a model
whose feet have no geom colliding with the floor falls back to the geoms colliding with anything,
else collision group 3, else all geoms, primitives before meshes. Explicit contact pairs with the
floor count as colliding.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from ..exceptions import ModelError
from .model import floor_geoms
from .polygon import convex_hull

#: Sole points: geometry within this distance of the foot's lowest point along its −z [m].
SOLE_TOLERANCE_M = 0.006

_MESH = int(mujoco.mjtGeom.mjGEOM_MESH)
_BOX = int(mujoco.mjtGeom.mjGEOM_BOX)
_GEOM_KINDS = {int(v): k.removeprefix("mjGEOM_").lower() for k, v in mujoco.mjtGeom.__members__.items()}


@dataclass(frozen=True)
class FootGeometry:
    """The geoms of a foot that make its sole, and what they are.

    Attributes
    ----------
    foot : int
        The foot body (the one its joint moves).
    geoms : tuple of int
        The geoms the sole is measured from.
    touches_floor : bool
        True when they collide with the floor; False for the fallback (no geom of the foot does).
    unused_visual : tuple of int
        Geoms of the foot that do not collide with the floor and were left out (visual meshes).
    """

    foot: int
    geoms: tuple[int, ...]
    touches_floor: bool
    unused_visual: tuple[int, ...]

    def describe(self, model: mujoco.MjModel) -> str:
        """The sole's geometry in words, e.g. ``"the box of its child body l_sole (colliding with
        the floor), not the visual mesh of the foot body"``."""
        text = describe_geoms(model, self.geoms, self.foot)
        text += " (colliding with the floor)" if self.touches_floor else " (no geom of the foot collides with the floor)"
        if self.unused_visual:
            text += f", not {describe_geoms(model, self.unused_visual, self.foot, 'visual ')}"
        return text


def describe_geoms(model: mujoco.MjModel, geoms, foot: int, adjective: str = "") -> str:
    """``geoms`` in words, by kind and body: ``"the 4 spheres of the foot body"``, ``"the box of
    its child body l_sole"``."""
    parts = []
    for body in sorted({int(model.geom_bodyid[g]) for g in geoms}):
        kinds: dict[str, int] = {}
        for g in geoms:
            if int(model.geom_bodyid[g]) == body:
                kind = _GEOM_KINDS.get(int(model.geom_type[g]), "geom")
                kinds[kind] = kinds.get(kind, 0) + 1
        names = [f"{n} {adjective}{k}{'es' if k.endswith(('x', 'sh')) else 's'}" if n > 1 else f"{adjective}{k}"
                 for k, n in kinds.items()]
        owner = "the foot body" if body == foot else f"its child body {model.body(body).name}"
        parts.append(f"the {' and '.join(names)} of {owner}")
    return " and ".join(parts)


def rigid_owner(model: mujoco.MjModel, body: int) -> int:
    """The body that moves ``body``: itself if it has a joint, else its nearest ancestor with one
    (a body welded to its parent moves with it); 0 for bodies welded to the world."""
    while body > 0 and model.body_jntnum[body] == 0:
        body = int(model.body_parentid[body])
    return body


def welded_bodies(model: mujoco.MjModel, foot: int) -> set[int]:
    """``foot`` and its descendants joined to it without a joint (they move with it)."""
    bodies = {foot}
    for body in range(foot + 1, model.nbody):  # MuJoCo numbers a child after its parent
        if int(model.body_parentid[body]) in bodies and model.body_jntnum[body] == 0:
            bodies.add(body)
    return bodies


def floor_touching_geoms(model: mujoco.MjModel) -> set[int]:
    """The geoms of the robot that collide with the floor: by MuJoCo's contype/conaffinity rule
    against a floor geom, or in an explicit contact ``<pair>`` with one (Apollo)."""
    floors = floor_geoms(model)
    found = {g for g in range(model.ngeom) if model.geom_bodyid[g] != 0 and any(
        (model.geom_contype[g] & model.geom_conaffinity[f]) or (model.geom_contype[f] & model.geom_conaffinity[g])
        for f in floors)}
    for a, b in zip(model.pair_geom1, model.pair_geom2):
        if int(a) in floors or int(b) in floors:
            found.update(g for g in (int(a), int(b)) if model.geom_bodyid[g] != 0)
    return found


def foot_geometry(model: mujoco.MjModel, foot: int) -> FootGeometry:
    """The geoms a sole is measured from: those of ``foot`` and of the bodies welded to it that
    collide with the floor (module docstring), primitives only when there are any."""
    touching = floor_touching_geoms(model)
    bodies = welded_bodies(model, foot)
    group = [g for g in range(model.ngeom) if int(model.geom_bodyid[g]) in bodies]
    colliding = [g for g in group if g in touching]
    if colliding:
        chosen = colliding
        unused = tuple(g for g in group if g not in touching and not (model.geom_contype[g] or model.geom_conaffinity[g]))
    else:
        chosen = ([g for g in group if model.geom_contype[g] or model.geom_conaffinity[g]]
                  or [g for g in group if model.geom_group[g] == 3] or group)
        unused = ()
    primitives = [g for g in chosen if int(model.geom_type[g]) != _MESH]
    return FootGeometry(foot, tuple(primitives or chosen), bool(colliding), unused)


def _geom_points(model: mujoco.MjModel, data: mujoco.MjData, geom: int, down: np.ndarray) -> np.ndarray:
    """Points of a geom's surface that can be its lowest along ``down`` (world frame), shape (k, 3)."""
    pos, rot = data.geom_xpos[geom], data.geom_xmat[geom].reshape(3, 3)
    size = model.geom_size[geom]
    kind = int(model.geom_type[geom])
    if kind == _BOX:
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * size
        return pos + corners @ rot.T
    if kind == int(mujoco.mjtGeom.mjGEOM_SPHERE):
        return (pos + size[0] * down)[None, :]
    if kind in (int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_CYLINDER)):
        ends = pos + np.outer([-1.0, 1.0], rot[:, 2] * size[1])
        if kind == int(mujoco.mjtGeom.mjGEOM_CAPSULE):
            return ends + size[0] * down
        angles = np.linspace(0.0, 2 * math.pi, 16, endpoint=False)
        rim = np.outer(np.cos(angles), rot[:, 0]) + np.outer(np.sin(angles), rot[:, 1])
        return (ends[:, None, :] + size[0] * rim[None, :, :]).reshape(-1, 3)
    if kind == _MESH:
        mesh = model.geom_dataid[geom]
        start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        return pos + model.mesh_vert[start:start + count] @ rot.T
    return (pos + model.geom_rbound[geom] * down)[None, :]


def _points(model, data, geoms, down: np.ndarray) -> np.ndarray:
    if not geoms:
        return np.zeros((0, 3))
    return np.vstack([_geom_points(model, data, g, down) for g in geoms])


def lowest_z(model: mujoco.MjModel, data: mujoco.MjData, geoms) -> float:
    """The lowest world z of ``geoms`` in the posture of ``data`` (after kinematics) [m]; inf
    without geoms."""
    points = _points(model, data, list(geoms), np.array([0.0, 0.0, -1.0]))
    return float(points[:, 2].min()) if len(points) else math.inf


def find_feet(model: mujoco.MjModel, data: mujoco.MjData, root: int) -> tuple[int, int]:
    """The feet (left: +y of the root frame): on each side the foot whose floor geometry reaches
    lowest, in the posture of ``data`` (after kinematics).

    Raises
    ------
    ModelError
        No foot on one side.
    """
    root_rot = data.xmat[root].reshape(3, 3)
    down = np.array([0.0, 0.0, -1.0])
    owners = {rigid_owner(model, int(model.geom_bodyid[g])) for g in floor_touching_geoms(model)}
    if not owners - {0, root}:  # nothing collides with the floor: every moving body may be a foot
        owners = {rigid_owner(model, body) for body in range(1, model.nbody)}
    lowest: dict[int, tuple[float, int]] = {}
    for body in sorted(owners - {0, root}):
        points = _points(model, data, foot_geometry(model, body).geoms, down)
        if len(points) == 0:
            continue
        side = 1 if (root_rot.T @ (data.xpos[body] - data.xpos[root]))[1] > 0 else -1
        z = float(points[:, 2].min())
        if side not in lowest or z < lowest[side][0] - 1e-6:
            lowest[side] = (z, body)
    if set(lowest) != {1, -1}:
        raise ModelError("could not find a foot on each side of the base; name them with --left-foot/--right-foot")
    return lowest[1][1], lowest[-1][1]


def sole_rotation(model: mujoco.MjModel, data: mujoco.MjData, body: int, root: int) -> np.ndarray:
    """Sole frame axes in the foot body frame, shape (3, 3) (columns x, y, z).

    The axes of the foot's largest box geom if its floor geometry has one (a box sole), else the
    body's own, signed and ordered so that z points most nearly up in the posture of ``data`` and
    x most nearly along the base's forward axis.
    """
    rot = data.xmat[body].reshape(3, 3)
    boxes = [g for g in foot_geometry(model, body).geoms if int(model.geom_type[g]) == _BOX]
    if boxes:
        box = max(boxes, key=lambda g: float(np.prod(np.sort(model.geom_size[g])[1:])))
        axes = rot.T @ data.geom_xmat[box].reshape(3, 3)
    else:
        axes = np.eye(3)
    up = rot.T @ np.array([0.0, 0.0, 1.0])
    forward = rot.T @ data.xmat[root].reshape(3, 3)[:, 0]
    iz = int(np.argmax(np.abs(axes.T @ up)))
    z = axes[:, iz] * np.sign(axes[:, iz] @ up)
    others = [i for i in range(3) if i != iz]
    ix = max(others, key=lambda i: abs(axes[:, i] @ forward))
    x = axes[:, ix] * (np.sign(axes[:, ix] @ forward) or 1.0)
    rotation = np.column_stack([x, np.cross(z, x), z])
    return np.where(np.abs(rotation) < 1e-9, 0.0, rotation)


def sole(model: mujoco.MjModel, data: mujoco.MjData, body: int,
         rotation: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The sole of the foot ``body`` from its floor geometry (:func:`foot_geometry`).

    Parameters
    ----------
    rotation : ndarray, shape (3, 3)
        The sole frame in the body frame (:func:`sole_rotation`).

    Returns
    -------
    points : ndarray, shape (k, 2)
        Sole points (x, y) in the sole frame, relative to the sole centre [m].
    centre : ndarray, shape (3,)
        The sole origin (the rectangle's centre at the lowest point) in the foot body frame [m].
    length, width : float
        The sole rectangle, the largest inside the points' hull [m].

    Raises
    ------
    ModelError
        The foot has no geometry.
    """
    rot = data.xmat[body].reshape(3, 3) @ rotation  # sole axes in the world
    points = (_points(model, data, foot_geometry(model, body).geoms, -rot[:, 2]) - data.xpos[body]) @ rot
    if len(points) == 0:
        raise ModelError(f"foot body {model.body(body).name!r} has no geometry")
    low = points[:, 2].min()
    on_floor = points[points[:, 2] <= low + SOLE_TOLERANCE_M]
    (x0, y0), (x1, y1) = inscribed_rectangle(on_floor[:, :2])
    centre = np.array([0.5 * (x0 + x1), 0.5 * (y0 + y1), low])
    return on_floor[:, :2] - centre[:2], rotation @ centre, float(x1 - x0), float(y1 - y0)


def inscribed_rectangle(points: np.ndarray, samples: int = 201) -> tuple[np.ndarray, np.ndarray]:
    """The largest axis-aligned rectangle inside the convex hull of planar points.

    Parameters
    ----------
    points : ndarray, shape (n, 2)
        Points (x, y) [m].
    samples : int
        Candidate x positions of the rectangle's sides, evenly spaced over the hull.

    Returns
    -------
    tuple of ndarray, shape (2,)
        The lower and upper corners (x, y) [m]. Points along a line give a zero-width rectangle.

    Notes
    -----
    Over the hull, the upper boundary y_hi(x) is concave and the lower y_lo(x) convex, so over
    [x0, x1] the height that fits is min(y_hi(x0), y_hi(x1)) - max(y_lo(x0), y_lo(x1)): the
    search is over pairs of sampled sides.
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    hull = convex_hull(pts)
    if len(hull) < 3 or hi[0] - lo[0] <= 0.0:
        return lo, hi
    xs = np.linspace(lo[0], hi[0], samples)
    y_lo, y_hi = np.full(samples, np.inf), np.full(samples, -np.inf)
    for a, b in zip(hull, np.roll(hull, -1, axis=0)):
        if a[0] == b[0]:
            continue
        s = (xs - a[0]) / (b[0] - a[0])
        on = (s >= -1e-12) & (s <= 1 + 1e-12)
        y = a[1] + np.clip(s, 0.0, 1.0) * (b[1] - a[1])
        y_lo[on] = np.minimum(y_lo[on], y[on])
        y_hi[on] = np.maximum(y_hi[on], y[on])
    top = np.minimum(y_hi[:, None], y_hi[None, :])
    bottom = np.maximum(y_lo[:, None], y_lo[None, :])
    area = np.triu((xs[None, :] - xs[:, None]) * np.clip(top - bottom, 0.0, None))
    i, j = np.unravel_index(int(np.argmax(area)), area.shape)
    return np.array([xs[i], bottom[i, j]]), np.array([xs[j], top[i, j]])
