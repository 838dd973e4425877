"""A small humanoid URDF written by the tests, as a robot package ships it (issue 31)."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import numpy as np

#: The biped's sole (box foot): length, width [m], and the box centre below the ankle [m].
BIPED_SOLE_M = (0.25, 0.13)
BIPED_SOLE_CENTRE_M = (0.02, 0.0, -0.06)
BIPED_EFFORT_NM = 150.0
BIPED_MASS_KG = 16.0 + 2 * (1.0 + 1.0 + 4.0 + 3.0 + 0.5 + 2.5)


def _write_stl(path: Path, vertices: np.ndarray, triangles: list[tuple[int, int, int]]) -> None:
    """A binary STL of ``triangles`` (vertex indices, counter-clockwise seen from outside)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("wb") as f:
        f.write(b"fixture".ljust(80, b" "))
        f.write(struct.pack("<I", len(triangles)))
        for a, b, c in triangles:
            p, q, r = vertices[a], vertices[b], vertices[c]
            normal = np.cross(q - p, r - p)
            normal = normal / (np.linalg.norm(normal) or 1.0)
            f.write(struct.pack("<12fH", *normal, *p, *q, *r, 0))


def _prism(outline: np.ndarray, z_low: float, z_high: float) -> tuple[np.ndarray, list[tuple[int, int, int]]]:
    """A closed prism over the convex ``outline`` (n, 2), counter-clockwise."""
    n = len(outline)
    vertices = np.array([[x, y, z_low] for x, y in outline] + [[x, y, z_high] for x, y in outline])
    triangles = []
    for i in range(1, n - 1):
        triangles.append((0, i + 1, i))  # bottom, facing down
        triangles.append((n, n + i, n + i + 1))  # top, facing up
    for i in range(n):
        j = (i + 1) % n
        triangles += [(i, j, n + j), (i, n + j, n + i)]
    return vertices, triangles


def _dome(half_l: float, half_w: float) -> tuple[np.ndarray, list[tuple[int, int, int]]]:
    """A convex foot shell over an ellipse of half axes (``half_l``, ``half_w``), 2 cm high,
    whose bottom bulges 3 mm at its centre (a housing, not a sole)."""
    from scipy.spatial import ConvexHull

    points = [[0.0, 0.0, -0.013]]
    for radius, z in ((0.35, -0.0125), (0.7, -0.0115), (1.0, -0.01)):
        angles = np.linspace(0.0, 2.0 * math.pi, 24, endpoint=False)
        points += [[radius * half_l * math.cos(a), radius * half_w * math.sin(a), z] for a in angles]
    angles = np.linspace(0.0, 2.0 * math.pi, 24, endpoint=False)
    points += [[half_l * math.cos(a), half_w * math.sin(a), 0.01] for a in angles]
    vertices = np.array(points)
    hull = ConvexHull(vertices)
    centre = vertices.mean(axis=0)
    triangles = []
    for a, b, c in hull.simplices:
        normal = np.cross(vertices[b] - vertices[a], vertices[c] - vertices[a])
        triangles.append((a, b, c) if normal @ (vertices[a] - centre) > 0 else (a, c, b))
    return vertices, triangles


def _inertial(mass: float, ixx: float, iyy: float, izz: float, xyz: str = "0 0 0") -> str:
    return (f'<inertial><origin xyz="{xyz}"/><mass value="{mass}"/>'
            f'<inertia ixx="{ixx}" ixy="0" ixz="0" iyy="{iyy}" iyz="0" izz="{izz}"/></inertial>')


def urdf_biped(folder: Path, foot: str = "box", facing: str = "x", effort_nm: float = BIPED_EFFORT_NM) -> Path:
    """A 40 kg biped URDF inside a package folder, as installed from a package registry.

    Writes ``folder/share/fixture_biped/urdf/biped.urdf`` and its meshes under
    ``folder/share/fixture_biped/meshes``, referenced as ``package://fixture_biped/meshes/...``:
    the pelvis's collision is a mesh (a box); each leg has six joints (hip yaw, roll, pitch, knee,
    ankle pitch, roll; effort limit ``effort_nm``), and its foot collides through

    - ``foot="box"``: a box sole :data:`BIPED_SOLE_M`;
    - ``foot="mesh"``: a mesh shell over the ellipse inside that rectangle whose bottom bulges
      3 mm (an ankle housing, not a sole).

    ``facing="-x"``: the description's frames are turned by 180° about z (the robot faces −x
    in its root frame, as iCub's do).

    Returns the URDF's path.
    """
    package = folder / "share" / "fixture_biped"
    meshes = package / "meshes"
    half_l, half_w = 0.5 * BIPED_SOLE_M[0], 0.5 * BIPED_SOLE_M[1]
    box = np.array([[-0.1, -0.15], [0.1, -0.15], [0.1, 0.15], [-0.1, 0.15]])
    _write_stl(meshes / "pelvis.stl", *_prism(box, 0.0, 0.35))
    if foot == "mesh":
        _write_stl(meshes / "foot.stl", *_dome(half_l, half_w))
    elif foot != "box":
        raise ValueError(f"foot must be box or mesh, got {foot!r}")
    sign = 1.0 if facing == "x" else -1.0
    cx, cy, cz = BIPED_SOLE_CENTRE_M
    foot_xyz = f"{sign * cx} {sign * cy} {cz}"
    if foot == "box":
        foot_geometry = f'<box size="{BIPED_SOLE_M[0]} {BIPED_SOLE_M[1]} 0.02"/>'
    else:
        foot_geometry = '<mesh filename="package://fixture_biped/meshes/foot.stl"/>'
    links, joints = ['<link name="pelvis">' + _inertial(16.0, 0.333, 0.267, 0.173, "0 0 0.15")
                     + '<collision><origin xyz="0 0 -0.05"/><geometry>'
                     '<mesh filename="package://fixture_biped/meshes/pelvis.stl"/></geometry></collision></link>'], []
    chain = [("hip_yaw", "0 0 1", "-0.8 0.8", 1.0), ("hip_roll", "1 0 0", "-0.6 0.6", 1.0),
             ("hip_pitch", "0 1 0", "-2 1", 4.0), ("knee", "0 1 0", "0 2.4", 3.0),
             ("ankle_pitch", "0 1 0", "-1 1", 0.5), ("ankle_roll", "1 0 0", "-0.5 0.5", 2.5)]
    offsets = {"hip_yaw": (0.0, None, -0.05), "hip_roll": (0, 0, 0), "hip_pitch": (0, 0, 0),
               "knee": (0, 0, -0.4), "ankle_pitch": (0, 0, -0.4), "ankle_roll": (0, 0, 0)}
    for side, y in (("l", 0.1), ("r", -0.1)):
        parent = "pelvis"
        for name, axis, limits, mass in chain:
            link = f"{side}_{name}_link" if name != "ankle_roll" else f"{side}_foot"
            ox, oy, oz = offsets[name]
            oy = y if oy is None else oy
            ax = np.array([float(v) for v in axis.split()])
            ax[:2] *= sign  # the same physical axis in the turned frame: the same range
            low, high = (float(v) for v in limits.split())
            lower_com = "0 0 -0.2" if name in ("hip_pitch", "knee") else "0 0 0"
            inertial = _inertial(mass, 0.04 if mass > 2 else 0.002, 0.04 if mass > 2 else 0.005, 0.005, lower_com)
            if name == "ankle_roll":
                inertial = _inertial(mass, 0.004, 0.012, 0.014, f"{sign * 0.02} 0 -0.04")
                links.append(f'<link name="{link}">{inertial}<collision><origin xyz="{foot_xyz}"/>'
                             f"<geometry>{foot_geometry}</geometry></collision></link>")
            else:
                links.append(f'<link name="{link}">{inertial}</link>')
            joints.append(
                f'<joint name="{side}_{name}" type="revolute"><parent link="{parent}"/><child link="{link}"/>'
                f'<origin xyz="{sign * ox} {sign * oy} {oz}"/><axis xyz="{ax[0]:g} {ax[1]:g} {ax[2]:g}"/>'
                f'<limit lower="{low}" upper="{high}" effort="{effort_nm}" velocity="10"/>'
                '<dynamics damping="1"/></joint>')
            parent = link
    path = package / "urdf" / "biped.urdf"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text('<?xml version="1.0"?>\n<robot name="fixture_biped">\n  ' + "\n  ".join(links + joints)
                    + "\n</robot>\n")
    return path
