"""Time series of a run, recorded tick by tick, saved and loaded as ``.npz``.

Every channel is a numpy array with the tick as first axis. Channels not produced by a run (for
example feasibility bounds without timing adaptation) are filled with NaN.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np

# Channel name -> per-tick shape.
CHANNELS: dict[str, tuple[int, ...]] = {
    "t_s": (),
    "com_m": (2,),
    "com_vel_mps": (2,),
    "zmp_m": (2,),  # model ZMP (LIP) or measured centre of pressure (full robot)
    "zmp_ref_m": (2,),
    "dcm_m": (2,),  # shifted DCM used by the MPC
    "box_centre_m": (2,),
    "box_half_m": (2,),
    "box_yaw_rad": (),
    "zmp_violation_m": (),
    "left_foot_m": (3,),  # reference soles (the plan's)
    "right_foot_m": (3,),
    "sole_meas_m": (4,),  # measured soles (left x, y, right x, y) on a full robot; NaN on the LIP
    "sole_meas_yaw_rad": (2,),  # their yaws (left, right)
    "support": (),  # 0 double, 1 left, -1 right
    "step_index": (),
    "time_to_step_s": (),
    "disturbance_true_mps2": (2,),
    "com_read_m": (2,),  # the CoM position the controller read (the sensors' output)
    "com_vel_read_mps": (2,),  # the CoM velocity the controller read (the sensors' output)
    "disturbance_est_mps2": (2,),  # the disturbance the MPC planned with (w̃; 0 for nominal)
    "disturbance_measured_mps2": (2,),  # the robust controller's estimate ŵ before its filters; NaN without one
    "feasibility_m": (4,),  # x_min, x_max, y_min, y_max of the DCM feasibility region
    "infeasible": (),
    "timing_adapted": (),
    "adapted_time_to_step_s": (),  # time from the tick to the touchdown an adaptation set; NaN without one
    "observer_ms": (),
    "timing_ms": (),
    "build_ms": (),
    "solve_ms": (),
    "cycle_ms": (),
}


@dataclass
class Trace:
    """A recorded run.

    Attributes
    ----------
    channels : dict of str -> ndarray
        See :data:`CHANNELS` for names and per-tick shapes.
    footsteps_m : ndarray, shape (N, 2)
        Footsteps as executed/optimised at the end of the run.
    candidate_footsteps_m : ndarray, shape (N, 2)
        Candidate footsteps from the planner.
    footstep_touchdown_s : ndarray, shape (N,)
        Touchdown time of each step at the end of the run.
    footstep_side : ndarray, shape (N,)
    footstep_yaw_rad : ndarray, shape (N,)
    meta : dict
        Run description (robot, controller, modules, box sizes, ...), JSON-serialisable.
    """

    channels: dict[str, np.ndarray]
    footsteps_m: np.ndarray
    candidate_footsteps_m: np.ndarray
    footstep_touchdown_s: np.ndarray
    footstep_side: np.ndarray
    footstep_yaw_rad: np.ndarray
    meta: dict = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.channels[name]

    def __len__(self) -> int:
        return len(self.channels["t_s"])

    def save(self, path: str | Path) -> None:
        """Write ``path`` (.npz) atomically."""
        import io as _io

        from ..io import atomic_write_bytes

        buffer = _io.BytesIO()
        arrays = {f"ch_{k}": v for k, v in self.channels.items()}
        for f in fields(self):
            if f.name not in ("channels", "meta"):
                arrays[f.name] = getattr(self, f.name)
        np.savez_compressed(buffer, meta=np.array(json.dumps(self.meta)), **arrays)
        atomic_write_bytes(Path(path), buffer.getvalue())

    @classmethod
    def load(cls, path: str | Path) -> Trace:
        with np.load(Path(path), allow_pickle=False) as data:
            channels = {k[3:]: data[k] for k in data.files if k.startswith("ch_")}
            kwargs = {f.name: data[f.name] for f in fields(cls) if f.name not in ("channels", "meta")}
            meta = json.loads(str(data["meta"]))
        return cls(channels=channels, meta=meta, **kwargs)


def controller_channels(controller, reference, t_s: float) -> dict:
    """The channels every simulator records from the controller at a tick.

    Parameters
    ----------
    controller : IsmpcController
        After its ``step`` at ``t_s``.
    reference : GaitReference
        What that step returned.
    t_s : float
        Time of the tick [s]; the ZMP box (centre, half sides, yaw) is evaluated there.
    """
    from ..core.reference import Support

    plan, info = controller.plan, controller.info
    centre, half, yaw = plan.box_at(t_s)
    support_code = {Support.DOUBLE: 0, Support.LEFT: 1, Support.RIGHT: -1}[reference.support]
    return {
        "zmp_ref_m": reference.zmp_m, "dcm_m": info.dcm_m,
        "box_centre_m": centre, "box_half_m": half, "box_yaw_rad": yaw,
        "left_foot_m": reference.left_foot.pos_m, "right_foot_m": reference.right_foot.pos_m,
        "support": support_code, "step_index": reference.step_index, "time_to_step_s": reference.time_to_step_s,
        "disturbance_est_mps2": info.disturbance_mps2, "infeasible": float(info.infeasible),
        "build_ms": 1e3 * info.build_time_s, "solve_ms": 1e3 * info.solve_time_s,
        "cycle_ms": 1e3 * info.cycle_time_s,
        **controller.extra_channels(),
    }


class TraceRecorder:
    """Accumulates ticks into preallocated arrays (grown geometrically)."""

    def __init__(self, capacity: int = 1024):
        self._n = 0
        self._data = {k: np.full((capacity, *shape), np.nan) for k, shape in CHANNELS.items()}

    def record(self, **values) -> None:
        """Append one tick; channels not given stay NaN."""
        if self._n == len(self._data["t_s"]):
            for k, arr in self._data.items():
                grown = np.full((2 * len(arr), *arr.shape[1:]), np.nan)
                grown[: len(arr)] = arr
                self._data[k] = grown
        for k, v in values.items():
            self._data[k][self._n] = v
        self._n += 1

    def last_time_s(self) -> float | None:
        """Time of the last recorded tick [s] (None before the first)."""
        return float(self._data["t_s"][self._n - 1]) if self._n else None

    def finish(self, plan, meta: dict) -> Trace:
        """Freeze into a :class:`Trace` with the final footstep plan ``plan``."""
        channels = {k: v[: self._n].copy() for k, v in self._data.items()}
        return Trace(
            channels=channels,
            footsteps_m=plan.pos_m.copy(),
            candidate_footsteps_m=plan.candidate_pos_m.copy(),
            footstep_touchdown_s=plan.touchdown_s.copy(),
            footstep_side=plan.side.astype(float),
            footstep_yaw_rad=plan.yaw_rad.copy(),
            meta=meta,
        )
