"""Planar geometry of the soles on the floor: a sole's pose and rectangle, the convex hull of
points (the support polygon) and a point's distance outside a convex polygon. World frame, z up,
metres; pure NumPy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..exceptions import ParameterError


@dataclass(frozen=True)
class SolePose:
    """Pose of a sole frame in the world (planar yaw only).

    Attributes
    ----------
    pos_m : ndarray, shape (3,)
        Sole centre [m] (z = 0 when the foot is flat on the floor).
    yaw_rad : float
        Yaw of the sole x axis about the world z axis [rad].
    """

    pos_m: np.ndarray
    yaw_rad: float

    def __post_init__(self) -> None:
        pos = np.asarray(self.pos_m, dtype=float)
        if pos.shape != (3,) or not np.all(np.isfinite(pos)):
            raise ParameterError(f"SolePose.pos_m must be 3 finite numbers [m], got {self.pos_m!r}")
        if not math.isfinite(self.yaw_rad):
            raise ParameterError(f"SolePose.yaw_rad must be finite, got {self.yaw_rad!r}")
        object.__setattr__(self, "pos_m", pos)


def sole_corners(pose: SolePose, length_m: float, width_m: float) -> np.ndarray:
    """Corners of a sole rectangle on the floor.

    Parameters
    ----------
    pose : SolePose
        Sole centre and yaw.
    length_m, width_m : float
        Rectangle sides along the sole x and y axes [m].

    Returns
    -------
    ndarray, shape (4, 2)
        Corner (x, y) coordinates [m], counter-clockwise.
    """
    c, s = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
    rot = np.array([[c, -s], [s, c]])
    half = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * np.array([0.5 * length_m, 0.5 * width_m])
    return pose.pos_m[:2] + half @ rot.T


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Convex hull of planar points (Andrew's monotone chain).

    Parameters
    ----------
    points : ndarray, shape (n, 2)

    Returns
    -------
    ndarray, shape (k, 2)
        Hull vertices counter-clockwise, without repetition (k <= n).
    """
    pts = sorted(set(map(tuple, np.asarray(points, dtype=float).reshape(-1, 2).tolist())))
    if len(pts) <= 2:
        return np.array(pts, dtype=float).reshape(-1, 2)

    def cross(o: tuple, a: tuple, b: tuple) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 1e-15:
            lower.pop()
        lower.append(p)
    upper: list[tuple] = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 1e-15:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])


def distance_outside(point_m: np.ndarray, polygon_m: np.ndarray) -> float:
    """Distance from a point to a convex polygon when outside it, 0 inside.

    Parameters
    ----------
    point_m : ndarray, shape (2,)
        Point [m].
    polygon_m : ndarray, shape (k, 2)
        Convex polygon vertices, counter-clockwise [m] (as from :func:`convex_hull`).

    Returns
    -------
    float
        Euclidean distance to the polygon [m] (0 inside or on the boundary; ``inf`` for an
        empty polygon).
    """
    p = np.asarray(point_m, dtype=float)[:2]
    poly = np.asarray(polygon_m, dtype=float)
    if len(poly) == 0:
        return math.inf
    if len(poly) == 1:
        return float(np.linalg.norm(p - poly[0]))
    # plain Python floats: a support polygon has at most a few corners per foot
    px, py = p.tolist()
    vertices = poly.tolist()
    edges = []  # per edge: its start, the edge vector and the point relative to the start
    for (ax, ay), (bx, by) in zip(vertices, vertices[1:] + vertices[:1]):
        edges.append((ax, ay, bx - ax, by - ay, px - ax, py - ay))
    if len(vertices) >= 3 and all(ex * ry - ey * rx >= -1e-12 for _, _, ex, ey, rx, ry in edges):
        return 0.0
    distance = math.inf
    for ax, ay, ex, ey, rx, ry in edges:
        t = (rx * ex + ry * ey) / max(ex * ex + ey * ey, 1e-300)
        t = 0.0 if t < 0.0 else 1.0 if t > 1.0 else t
        dx, dy = px - (ax + t * ex), py - (ay + t * ey)
        to_edge = math.sqrt(dx * dx + dy * dy)
        if not to_edge >= distance:  # a NaN wins, as in np.min
            distance = to_edge
    return distance
