"""What a user's model may get wrong without failing to load: a physics step too coarse for the
torque control, bodies whose inertia is a placeholder.

Both are warnings, not errors: ``ismpc robot init`` (:mod:`robust_ismpc.sim.wizard`) prints them
and writes them into the drafted robot file, ``ismpc robot check`` and ``ismpc run --sim mujoco``
print the first.

**Physics step.** The MuJoCo loop takes (control period / physics step) physics steps per 10 ms
control period, and the torque control solves its inverse-dynamics QP at every one: with a 10 ms
step the joint torques are computed once per control period, from a state up to 10 ms old, and
contacts are integrated at the same coarse rate. The built-in robots' models use 2 ms (five steps
per period), Apollo's 5 ms (two). A step longer than :data:`COARSE_PHYSICS_STEP_S` draws a
warning; the wizard drafts :data:`DRAFTED_PHYSICS_STEP_S` for such a model.

**Placeholder inertia.** A rigid body of mass m whose mass lies within a distance R of its centre
of mass c has principal moments

.. math:: I_k = \\int (|r|^2 - r_k^2)\\,dm \\le \\int |r|^2\\,dm \\le m R^2 .

Its geometry reaches at most L = max_g (|p_g - c| + ρ_g) from c (p_g a geom's centre and ρ_g
the radius of its bounding sphere, every geom of the body, visual or colliding). A body whose
largest principal moment exceeds :data:`INERTIA_REACH_FACTOR`² m L² would need its mass to reach
more than :data:`INERTIA_REACH_FACTOR` times as far from c as its geometry does: its inertia (and
most likely its mass) is a placeholder, such as 1 kg with 1 kg m² on each axis for a 25 cm sole
plate (50 m L²). On the six humanoids of the model package the largest ratio I_max / (m L²) is
1.15 (T1's hands). Bodies without geoms or mass are not judged.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from ..core.params import MpcParams
from ..robots.spec import RobotSpec
from .model import compile_model

#: Physics steps longer than this are coarse for the torque control [s] (Apollo's model uses 5 ms).
COARSE_PHYSICS_STEP_S = 0.005
#: The physics step drafted for a model whose own is coarse, or does not divide the control
#: period [s]: the built-in robots' (G1, OP3, T1).
DRAFTED_PHYSICS_STEP_S = 0.002
#: How much farther than its geometry a body's mass may reach before its inertia is implausible.
INERTIA_REACH_FACTOR = 2.0


@dataclass(frozen=True)
class ImplausibleInertia:
    """A body whose inertia its size cannot hold (module docstring).

    Attributes
    ----------
    body : str
        Its name.
    mass_kg : float
        Its mass [kg].
    inertia_kgm2 : tuple of 3 float
        Its principal moments of inertia [kg m²].
    reach_m : float
        L, how far its geometry reaches from its centre of mass [m].
    """

    body: str
    mass_kg: float
    inertia_kgm2: tuple[float, float, float]
    reach_m: float

    @property
    def largest_plausible_kgm2(self) -> float:
        """The largest principal moment its geometry allows, (factor L)² m [kg m²]."""
        return (INERTIA_REACH_FACTOR * self.reach_m) ** 2 * self.mass_kg

    def describe(self, total_mass_kg: float | None = None) -> str:
        """One line: the body, its mass and inertia, the bound, and its share of the total mass."""
        inertia = ", ".join(f"{i:.3g}" for i in self.inertia_kgm2)
        total = "mass" if total_mass_kg is None else f"{total_mass_kg:.1f} kg"
        return (f"body {self.body}: {self.mass_kg:.3g} kg with principal inertia {inertia} kg m², more than its "
                f"geometry can hold (at most {self.largest_plausible_kgm2:.3g} kg m² with the mass within "
                f"{INERTIA_REACH_FACTOR:g} x {self.reach_m:.3f} m of its CoM): a placeholder? Its {self.mass_kg:.3g} kg "
                f"are counted in the robot's {total}")


def implausible_inertias(model: mujoco.MjModel, bodies=None) -> list[ImplausibleInertia]:
    """The bodies of ``model`` (or of ``bodies``, ids) whose largest principal inertia exceeds
    (:data:`INERTIA_REACH_FACTOR` L)² m (module docstring), in body order."""
    found = []
    for body in range(1, model.nbody) if bodies is None else bodies:
        mass = float(model.body_mass[body])
        geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == body]
        if mass <= 0.0 or not geoms:
            continue
        centre = model.body_ipos[body]
        reach = max(float(np.linalg.norm(model.geom_pos[g] - centre) + model.geom_rbound[g]) for g in geoms)
        inertia = tuple(float(i) for i in model.body_inertia[body])
        if max(inertia) > (INERTIA_REACH_FACTOR * reach) ** 2 * mass:
            found.append(ImplausibleInertia(model.body(body).name, mass, inertia, reach))
    return found


def _times(count: int) -> str:
    return {1: "once", 2: "twice"}.get(count, f"{count} times")


def drafted_physics_step(model_timestep_s: float) -> tuple[float, str | None]:
    """The physics step to draft for a model whose own timestep is ``model_timestep_s`` [s], and
    why it differs (None when it is the model's own): the model's own when it divides the control
    period and is at most :data:`COARSE_PHYSICS_STEP_S`, else :data:`DRAFTED_PHYSICS_STEP_S`."""
    period = MpcParams().sampling_period_s
    steps = period / model_timestep_s
    if abs(steps - round(steps)) > 1e-6 or steps < 1.0 - 1e-9:
        return DRAFTED_PHYSICS_STEP_S, (f"the model's timestep ({1e3 * model_timestep_s:g} ms) does not divide the "
                                        f"{1e3 * period:g} ms control period")
    if model_timestep_s > COARSE_PHYSICS_STEP_S + 1e-12:
        return DRAFTED_PHYSICS_STEP_S, (f"the model's timestep ({1e3 * model_timestep_s:g} ms) is coarse for torque "
                                        f"control (more than {1e3 * COARSE_PHYSICS_STEP_S:g} ms: the inverse dynamics "
                                        f"would be solved {_times(round(steps))} per {1e3 * period:g} ms control "
                                        "period)")
    return model_timestep_s, None


def physics_step_warning(spec: RobotSpec) -> str | None:
    """A warning if the physics step ``spec`` runs with is coarse for torque control (longer than
    :data:`COARSE_PHYSICS_STEP_S`), else None; it says whether the step is the model's own or the
    robot file's."""
    step = float(compile_model(spec).opt.timestep)
    if step <= COARSE_PHYSICS_STEP_S + 1e-12:
        return None
    source = ("the robot file's [simulation] physics_step_s" if spec.physics_step_s is not None
              else "the model's own timestep; the robot file sets no [simulation] physics_step_s")
    steps = MpcParams().sampling_period_s / step
    return (f"{spec.name}: the physics step is {1e3 * step:g} ms ({source}), coarse for torque control: the "
            f"inverse dynamics is solved {_times(round(steps))} per control period "
            f"(the built-in robots: 2 ms, five); set [simulation] physics_step_s = {DRAFTED_PHYSICS_STEP_S:g}")
