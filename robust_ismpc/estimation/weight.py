r"""The mass the feet carry, weighed from the vertical contact force.

A robot carrying something (a payload strapped to it, a bag in its hand) or whose model's masses
are off pushes on the floor with its true weight, and its horizontal contact force accelerates
that whole mass. Dividing the measured contact force by the model's mass then reads part of the
robot's own walking as a disturbance: the CoM's acceleration :math:`\eta^2 (c - z)` scaled by
:math:`(M - m)/m`, swinging with the support foot. The feet weigh the robot instead: over a walk
the CoM's vertical acceleration averages out, so the mean vertical contact force over gravity is
the mass the contacts bear,

.. math::

    \hat M_k = \hat M_{k-1} + \frac{\delta}{\tau + \delta}\Big(\frac{\bar F_{z,k}}{g} - \hat M_{k-1}\Big),

a first-order low-pass filter of time constant :math:`\tau` (:data:`WEIGHING_TIME_CONSTANT_S`,
long against a step so that the CoM's bounce does not enter), started at the model's mass.
Samples in which the contacts bear less than half the model's weight (a foot barely touching,
the robot jumping or falling) are not weighings and leave the estimate as it is.
"""

from __future__ import annotations

from ..core.params import GRAVITY_MPS2
from ..exceptions import ParameterError

#: Time constant of the weighing's low-pass filter [s]: two strides of a usual gait.
WEIGHING_TIME_CONSTANT_S = 2.0


def weigh(previous_kg: float, vertical_force_n: float, model_mass_kg: float, period_s: float,
          time_constant_s: float = WEIGHING_TIME_CONSTANT_S) -> float:
    """The weighed mass [kg] after one control period.

    Parameters
    ----------
    previous_kg : float
        The previous estimate [kg] (the model's mass before the first period).
    vertical_force_n : float
        The vertical contact force averaged over the period [N] (upwards positive).
    model_mass_kg : float
        The model's mass [kg]: below half its weight a sample is not a weighing.
    period_s : float
        The control period δ [s].
    time_constant_s : float
        τ [s].
    """
    if not (model_mass_kg > 0 and period_s > 0 and time_constant_s >= 0):
        raise ParameterError(f"weigh needs model_mass_kg > 0, period_s > 0 and time_constant_s >= 0, got "
                             f"{model_mass_kg!r}, {period_s!r}, {time_constant_s!r}")
    if not vertical_force_n >= 0.5 * model_mass_kg * GRAVITY_MPS2:
        return previous_kg
    alpha = period_s / (time_constant_s + period_s)
    return previous_kg + alpha * (vertical_force_n / GRAVITY_MPS2 - previous_kg)


__all__ = ["WEIGHING_TIME_CONSTANT_S", "weigh"]
