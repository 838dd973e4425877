"""MuJoCo layer: robot models, measurements, scenes and forces, whole-body control, the stepped
simulation, fall and blow-up detection, video. The only package that imports mujoco.

Importing it sets ``MUJOCO_GL=egl`` on a Linux machine without display when ``MUJOCO_GL`` is
unset: mujoco chooses its OpenGL backend once, when it is imported, and offscreen video needs EGL
there. Every module of this package is imported after this file runs.
"""

import os as _os
import sys as _sys

if _sys.platform.startswith("linux") and not _os.environ.get("DISPLAY") and "mujoco" not in _sys.modules:
    _os.environ.setdefault("MUJOCO_GL", "egl")
