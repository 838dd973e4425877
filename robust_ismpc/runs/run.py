"""One closed-loop run of a :class:`~robust_ismpc.runs.spec.RunSpec`, on the simulator it names.

This is the Python API behind ``ismpc run``; it returns results and writes nothing.
"""

from __future__ import annotations

from ..exceptions import ParameterError
from .lip import run_lip_spec
from .spec import RunResult, RunSpec


def run(spec: RunSpec, progress=None, video_path=None, viewer: bool = False) -> RunResult:
    """Run ``spec`` and return its summary and trace.

    Parameters
    ----------
    spec : RunSpec
    progress : callable, optional
        ``progress(t_s)`` called about once per simulated second. If it raises
        ``KeyboardInterrupt`` (as on Ctrl-C), the run stops there and returns what ran, with
        failure ``"interrupted"``.
    video_path : path, optional
        MuJoCo only: write an mp4 of the run there.
    viewer : bool
        MuJoCo only: show the run in MuJoCo's interactive viewer (needs a display).

    Raises
    ------
    ParameterError
        A video or viewer asked of a LIP run.
    """
    if spec.sim == "mujoco":
        from .mujoco import run_mujoco_spec  # imports mujoco

        return run_mujoco_spec(spec, progress=progress, video_path=video_path, viewer=viewer)
    if video_path is not None or viewer:
        raise ParameterError("--video and --viewer need --sim mujoco (the LIP has nothing to show)")
    return run_lip_spec(spec, progress=progress)
