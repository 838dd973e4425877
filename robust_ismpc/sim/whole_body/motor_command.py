r"""The robot's own command interface: one (q, q̇, kp, kd, τ_ff) per motor, held between updates.

A humanoid's motor drivers take, per motor, a target position and velocity, PD gains and a
feed-forward torque (Unitree's low-level command, for example), and apply

.. math::

    \tau = \mathrm{clip}\big(\tau_{ff} + k_p (q^* - q) + k_d (\dot q^* - \dot q),\ \tau_{min}, \tau_{max}\big)

at their own rate, with the joint state they measure, until the next command arrives. The
inverse-dynamics QP (:mod:`robust_ismpc.sim.whole_body.inverse_dynamics`) runs at a rate of its
own and fills the command from its solution: :math:`\tau_{ff}` its torques, :math:`q^*, \dot
q^*` the joint state its accelerations :math:`\ddot q` reach at the end of the hold :math:`\Delta`
(the next update),

.. math::

    q^* = q + \dot q\,\Delta + \tfrac12 \ddot q\,\Delta^2, \qquad \dot q^* = \dot q + \ddot q\,\Delta,

and gains that give each joint, alone, a critically damped response of bandwidth :math:`\omega`
(:attr:`~robust_ismpc.sim.whole_body.inverse_dynamics.TorqueControlSettings.joint_bandwidth_radps`)
on its own inertia: :math:`k_p = M_{ii}\,\omega^2`, :math:`k_d = 2 M_{ii}\,\omega` with
:math:`M_{ii}` the joint's diagonal of the mass matrix. :math:`\omega = 0` sends the torques alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...exceptions import ParameterError


@dataclass(frozen=True)
class MotorCommand:
    """One command per motor, in actuator order, as the motor drivers take it.

    Attributes
    ----------
    q_rad, dq_radps : ndarray, shape (nu,)
        Target joint position [rad] and velocity [rad/s].
    kp_nm_per_rad, kd_nms_per_rad : ndarray, shape (nu,)
        PD gains [N m/rad], [N m s/rad], >= 0.
    tau_ff_nm : ndarray, shape (nu,)
        Feed-forward torque [N m].
    """

    q_rad: np.ndarray
    dq_radps: np.ndarray
    kp_nm_per_rad: np.ndarray
    kd_nms_per_rad: np.ndarray
    tau_ff_nm: np.ndarray

    def __post_init__(self) -> None:
        shapes = {np.shape(getattr(self, name)) for name in
                  ("q_rad", "dq_radps", "kp_nm_per_rad", "kd_nms_per_rad", "tau_ff_nm")}
        if len(shapes) != 1 or len(next(iter(shapes))) != 1:
            raise ParameterError(f"MotorCommand: every field must be one vector of the same length, got shapes {shapes}")
        if np.any(np.asarray(self.kp_nm_per_rad) < 0) or np.any(np.asarray(self.kd_nms_per_rad) < 0):
            raise ParameterError("MotorCommand: the gains must be >= 0")

    def torques(self, q_rad: np.ndarray, dq_radps: np.ndarray, limits_nm: np.ndarray) -> np.ndarray:
        """What the drivers apply at the measured joint state, shape (nu,) [N m].

        Parameters
        ----------
        q_rad, dq_radps : ndarray, shape (nu,)
            Measured joint positions [rad] and velocities [rad/s].
        limits_nm : ndarray, shape (nu, 2)
            Lower and upper torque limit per motor [N m] (±inf: none).
        """
        tau = (self.tau_ff_nm + self.kp_nm_per_rad * (self.q_rad - q_rad)
               + self.kd_nms_per_rad * (self.dq_radps - dq_radps))
        return np.clip(tau, limits_nm[:, 0], limits_nm[:, 1])


def held_command(tau_ff_nm: np.ndarray, q_rad: np.ndarray, dq_radps: np.ndarray, qacc_radps2: np.ndarray,
                 inertia_kgm2: np.ndarray, hold_s: float, bandwidth_radps: float, check: bool = True) -> MotorCommand:
    """The command that holds the inverse dynamics' solution for ``hold_s`` (module docstring).

    Parameters
    ----------
    tau_ff_nm : ndarray, shape (nu,)
        The QP's joint torques [N m].
    q_rad, dq_radps, qacc_radps2 : ndarray, shape (nu,)
        Joint positions [rad] and velocities [rad/s] when the QP was solved, and its joint
        accelerations [rad/s²].
    inertia_kgm2 : ndarray, shape (nu,)
        The joints' diagonal of the mass matrix [kg m²].
    hold_s : float
        Δ, time until the next command [s], > 0.
    bandwidth_radps : float
        ω [rad/s], >= 0 (0: no PD, the torques alone).
    check : bool
        Check the command (:class:`MotorCommand`: one length, gains >= 0). Internal: False for
        a caller whose arrays are right by construction, the inverse dynamics at every solve
        (its inertias are the positive diagonal of a mass matrix, its ω checked by its settings).
    """
    if not hold_s > 0 or not bandwidth_radps >= 0:
        raise ParameterError(f"held_command needs hold_s > 0 and bandwidth_radps >= 0, got {hold_s!r}, {bandwidth_radps!r}")
    q_target = q_rad + dq_radps * hold_s + 0.5 * qacc_radps2 * hold_s**2
    dq_target = dq_radps + qacc_radps2 * hold_s
    inertia = np.asarray(inertia_kgm2, dtype=float)
    fields = {"q_rad": q_target, "dq_radps": dq_target, "kp_nm_per_rad": inertia * bandwidth_radps**2,
              "kd_nms_per_rad": 2.0 * inertia * bandwidth_radps, "tau_ff_nm": np.asarray(tau_ff_nm, dtype=float).copy()}
    if check:
        return MotorCommand(**fields)
    command = object.__new__(MotorCommand)  # the dataclass's own __init__ without __post_init__'s checks
    for name, value in fields.items():
        object.__setattr__(command, name, value)
    return command


__all__ = ["MotorCommand", "held_command"]
