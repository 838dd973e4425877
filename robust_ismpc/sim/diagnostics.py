"""What a MuJoCo run measures about why a robot model cannot stand or walk.

:class:`ModelDiagnostics` is updated once per control tick and gathers the signs of the usual
defects of a robot model brought from elsewhere (a URDF, a scene written for another purpose):

- **self-contacts**: contacts between two of the robot's own bodies, by body name, with the
  largest normal force;
- **centre-of-pressure jitter**: how far the measured CoP moves from one tick to the next while
  the robot stands still (a foot that touches the floor through a mesh whose contact points jump
  between its vertices);
- **torque limits**: the joints whose actuator reached its torque limit, and for how long;
- **joint limits**: the joints held at a limit of their range, and for how long;
- **the CoM outside the soles**: how long the CoM's ground projection was outside the support
  polygon of the feet in contact.

:func:`likeliest_causes` turns a summary into sentences, likeliest first.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from .polygon import distance_outside

#: A self-contact counts once its normal force exceeds this fraction of the robot's weight.
SELF_CONTACT_WEIGHT_FRACTION = 0.01
#: The standing CoP is jittery when its rms move from one control tick to the next exceeds this
#: fraction of the sole's width (a box or capsule sole: under 0.5 %; a foot touching through its
#: ankle's collision mesh: 66 %, measured on Talos).
COP_JITTER_SOLE_FRACTION = 0.05
#: A torque (or joint) limit counts as a cause when it was hit in this fraction of the ticks.
LIMIT_TIME_FRACTION = 0.02
#: An actuator is at its limit within this fraction of it.
_AT_LIMIT = 0.99
_LIMIT_JOINT = int(mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT)  # a plain int: numpy compares it fast


class ModelDiagnostics:
    """Accumulates the defects of a robot model over a run (module docstring).

    Parameters
    ----------
    model : mujoco.MjModel
        The simulated scene (its actuators as the simulation applies them).
    robot_bodies : iterable of int
        Body ids of the robot (:attr:`~robust_ismpc.sim.robot.MujocoRobot.robot_body_ids`; contacts
        with other bodies, such as a ball or a carried bag, are not self-contacts).
    weight_n : float
        The robot's weight [N].
    torque_limits_nm : ndarray, shape (nu, 2), optional
        Each actuator's torque interval [N m]; None: the model's force ranges.
    settle_samples : int
        CoP samples left out of the jitter (the robot settling).
    """

    def __init__(self, model: mujoco.MjModel, robot_bodies, weight_n: float,
                 torque_limits_nm: np.ndarray | None = None, settle_samples: int = 0) -> None:
        self.model = model
        self.robot_bodies = {int(b) for b in robot_bodies}
        self.weight_n = float(weight_n)
        if torque_limits_nm is None:
            limited = model.actuator_forcelimited.astype(bool)
            torque_limits_nm = np.where(limited[:, None], model.actuator_forcerange, [-np.inf, np.inf])
        self.torque_limits_nm = np.asarray(torque_limits_nm, dtype=float)
        self._geom_body = model.geom_bodyid.tolist()
        self.ticks = 0
        self.self_contacts_n: dict[tuple[str, str], float] = {}
        self.torque_limit_ticks = np.zeros(model.nu, dtype=int)
        self.joint_limit_ticks = np.zeros(model.njnt, dtype=int)
        self.com_outside_ticks = 0
        # the CoP jitter, accumulated: samples seen, the last one, and the squared moves after settling
        self._settle_samples = int(settle_samples)
        self._cop_samples = 0
        self._last_cop: np.ndarray | None = None
        self._cop_moves = 0
        self._cop_move_sq_m2 = 0.0
        self._force = np.zeros(6)

    def update(self, data: mujoco.MjData, com_xy_m: np.ndarray, cop_xy_m: np.ndarray | None,
               support_polygon_m: np.ndarray | None) -> None:
        """Record one control tick: the contacts, actuator forces and constraint forces in
        ``data``, the CoM's and the CoP's ground projections [m] and the support polygon (rows
        of vertices [m]; None or empty: the robot is in the air)."""
        model = self.model
        self.ticks += 1
        if data.ncon:
            geom_body, robot = self._geom_body, self.robot_bodies
            for i, (g1, g2) in enumerate(zip(data.contact.geom1.tolist(), data.contact.geom2.tolist())):
                b1, b2 = geom_body[g1], geom_body[g2]
                if b1 not in robot or b2 not in robot or b1 == b2:
                    continue
                mujoco.mj_contactForce(model, data, i, self._force)
                force = abs(float(self._force[0]))
                pair = tuple(sorted((model.body(b1).name, model.body(b2).name)))
                self.self_contacts_n[pair] = max(self.self_contacts_n.get(pair, 0.0), force)
        if model.nu:
            low, high = self.torque_limits_nm[:, 0], self.torque_limits_nm[:, 1]
            force = data.actuator_force
            self.torque_limit_ticks += (force >= _AT_LIMIT * high) & np.isfinite(high) & (high > 0)
            self.torque_limit_ticks += (force <= _AT_LIMIT * low) & np.isfinite(low) & (low < 0)
        limit_rows = (data.efc_type[:data.nefc] == _LIMIT_JOINT) & (np.abs(data.efc_force[:data.nefc]) > 1e-6)
        for joint in set(data.efc_id[:data.nefc][limit_rows].tolist()):
            self.joint_limit_ticks[joint] += 1
        if cop_xy_m is not None:
            cop = np.asarray(cop_xy_m, dtype=float)[:2].copy()
            self._cop_samples += 1
            if self._last_cop is not None and self._cop_samples > self._settle_samples + 1:
                self._cop_moves += 1
                self._cop_move_sq_m2 += float(np.sum((cop - self._last_cop) ** 2))
            self._last_cop = cop
        if support_polygon_m is not None and len(support_polygon_m) >= 3:
            if distance_outside(np.asarray(com_xy_m, dtype=float)[:2], support_polygon_m) > 0:
                self.com_outside_ticks += 1

    def cop_jitter_m(self) -> float | None:
        """Rms of the CoP's move from one sample to the next [m], after the settling samples;
        None without two CoP samples after them."""
        return math.sqrt(self._cop_move_sq_m2 / self._cop_moves) if self._cop_moves else None

    def summary(self, period_s: float) -> dict:
        """JSON-ready: ``self_contacts`` (pairs with the largest normal force above
        :data:`SELF_CONTACT_WEIGHT_FRACTION` of the weight, strongest first), ``cop_jitter_m``,
        ``torque_limits_s`` and ``joint_limits_s`` (time at the limit per joint, longest first),
        ``com_outside_soles_s`` and ``duration_s``."""
        model = self.model
        threshold = SELF_CONTACT_WEIGHT_FRACTION * self.weight_n
        contacts = sorted(((pair, f) for pair, f in self.self_contacts_n.items() if f > threshold),
                          key=lambda item: -item[1])
        jitter = self.cop_jitter_m()

        def timed(ticks: np.ndarray, name) -> dict[str, float]:
            order = np.argsort(-ticks, kind="stable")
            return {name(int(i)): round(float(ticks[i]) * period_s, 3) for i in order if ticks[i] > 0}

        return {
            "duration_s": round(self.ticks * period_s, 3),
            "self_contacts": [{"bodies": list(pair), "max_force_n": round(f, 2)} for pair, f in contacts],
            "cop_jitter_m": None if jitter is None else round(jitter, 5),
            "torque_limits_s": timed(self.torque_limit_ticks,
                                     lambda a: model.joint(int(model.actuator_trnid[a, 0])).name),
            "joint_limits_s": timed(self.joint_limit_ticks, lambda j: model.joint(j).name),
            "com_outside_soles_s": round(self.com_outside_ticks * period_s, 3),
        }


def likeliest_causes(summary: dict, sole_width_m: float) -> list[str]:
    """Sentences naming what in ``summary`` (:meth:`ModelDiagnostics.summary`) can make a robot
    fall, likeliest first: self-contacts, a jittery CoP, torque limits, joint limits, the CoM
    outside the soles. Empty when nothing was measured beyond its threshold."""
    causes = []
    duration = max(float(summary.get("duration_s") or 0.0), 1e-9)
    for entry in summary.get("self_contacts", [])[:3]:
        a, b = entry["bodies"]
        causes.append(f"self-contact: {a} touches {b} (up to {entry['max_force_n']:.1f} N); switch off "
                      "collisions between the robot's own bodies or fix the posture")
    jitter = summary.get("cop_jitter_m")
    if jitter is not None and jitter > COP_JITTER_SOLE_FRACTION * sole_width_m:
        causes.append(f"the centre of pressure jumps by {100 * jitter:.1f} cm rms from one 10 ms tick to the next "
                      f"while standing ({jitter / sole_width_m:.0%} of the sole's width): the feet touch the floor "
                      "through geometry that does not hold a flat contact (a mesh?); give each foot a box sole")
    for key, what in (("torque_limits_s", "at their torque limit"), ("joint_limits_s", "at a limit of their range")):
        hits = {j: t for j, t in summary.get(key, {}).items() if t >= LIMIT_TIME_FRACTION * duration}
        if hits:
            listed = ", ".join(f"{j} {t:.2f} s" for j, t in list(hits.items())[:4])
            causes.append(f"joints {what}: {listed} (of {duration:.2f} s)")
    outside = float(summary.get("com_outside_soles_s") or 0.0)
    if outside > 0 and outside >= LIMIT_TIME_FRACTION * duration:
        causes.append(f"the CoM was outside the soles' outline for {outside:.2f} s of {duration:.2f} s")
    return causes


__all__ = ["COP_JITTER_SOLE_FRACTION", "LIMIT_TIME_FRACTION", "ModelDiagnostics", "SELF_CONTACT_WEIGHT_FRACTION",
           "likeliest_causes"]
