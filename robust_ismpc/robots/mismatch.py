"""How the simulated robot differs from the model its controller uses: a test input.

A controller is built from a robot model (masses, inertias, motors); the real robot never matches
it exactly. :class:`ModelMismatch` describes the difference a MuJoCo run simulates:

- every link's mass and inertia scaled by ``mass_scale`` (a robot heavier or lighter than its
  model; the CoM stays where the model puts it),
- a payload of ``payload_kg`` fixed rigidly to the torso at ``payload_offset_m`` from the torso
  body's origin, in its frame (something the robot carries, or a mass the model misplaces: it
  moves the true CoM away from the computed one),
- every motor's torque scaled by ``motor_strength`` (the torque a motor delivers for the one
  commanded).

The controller, its whole-body layer and its measurement keep the model: the measured CoM is the
model's CoM at the measured joint positions, the contact force is divided by the model's mass.
The difference reaches the controller only as a disturbance, which is what the robust
controller's observer is for. ``ismpc run --mismatch`` sets it; ``summary.json`` records it.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from ..exceptions import ParameterError
from ..validation import check_nonnegative, check_positive, check_vector


@dataclass(frozen=True)
class ModelMismatch:
    """The simulated robot's difference from the controller's model (the default: none).

    Attributes
    ----------
    mass_scale : float
        Factor on every link's mass and inertia [-] (1: as modelled).
    payload_kg : float
        Mass fixed to the torso [kg] (0: none).
    payload_offset_m : tuple of 3 float
        Where the payload's centre is, from the torso body's origin in its frame [m].
    motor_strength : float
        Factor on every motor's torque [-] (1: as modelled).
    """

    mass_scale: float = 1.0
    payload_kg: float = 0.0
    payload_offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    motor_strength: float = 1.0

    def __post_init__(self) -> None:
        check_positive("ModelMismatch", mass_scale=self.mass_scale, motor_strength=self.motor_strength)
        check_nonnegative("ModelMismatch", payload_kg=self.payload_kg)
        offset = check_vector("ModelMismatch", "payload_offset_m", self.payload_offset_m, 3)
        object.__setattr__(self, "payload_offset_m", tuple(float(v) for v in offset))

    @property
    def is_none(self) -> bool:
        """True when the simulated robot is the model."""
        return self.mass_scale == 1.0 and self.payload_kg == 0.0 and self.motor_strength == 1.0

    def as_dict(self) -> dict:
        """The mismatch as plain values (``summary.json``)."""
        out = asdict(self)
        out["payload_offset_m"] = list(self.payload_offset_m)
        return out


NO_MISMATCH = ModelMismatch()

_SYNTAX = "mass=FACTOR, motor=FACTOR or payload=KG[@X,Y,Z] (offset from the torso origin [m])"


def _number(text: str, item: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ParameterError(f"--mismatch {item!r}: {text!r} is not a number; use {_SYNTAX}") from None
    if not math.isfinite(value):
        raise ParameterError(f"--mismatch {item!r}: {text!r} is not a finite number")
    return value


def parse_mismatch(items: list[str] | tuple[str, ...]) -> ModelMismatch:
    """The mismatch of ``--mismatch`` items such as ``mass=1.1``, ``payload=3.3@0.05,0,0.1``,
    ``motor=0.9`` (each key at most once; the others as modelled).

    Raises
    ------
    ParameterError
        An item is malformed, a key repeats or is unknown, or a value is out of range.
    """
    values: dict = {}
    for item in items:
        key, sep, text = str(item).partition("=")
        key = key.strip()
        if not sep or key not in ("mass", "payload", "motor"):
            raise ParameterError(f"--mismatch {item!r}: expected {_SYNTAX}")
        if key in values:
            raise ParameterError(f"--mismatch {key}= given twice")
        if key == "payload":
            mass_text, at, offset_text = text.partition("@")
            offset: tuple[float, ...] = (0.0, 0.0, 0.0)
            if at:
                parts = offset_text.split(",")
                if len(parts) != 3:
                    raise ParameterError(f"--mismatch {item!r}: the offset needs three numbers X,Y,Z [m]")
                offset = tuple(_number(p, item) for p in parts)
            values[key] = (_number(mass_text, item), offset)
        else:
            values[key] = _number(text, item)
    payload_kg, offset = values.get("payload", (0.0, (0.0, 0.0, 0.0)))
    return ModelMismatch(mass_scale=values.get("mass", 1.0), payload_kg=payload_kg,
                         payload_offset_m=(offset[0], offset[1], offset[2]),
                         motor_strength=values.get("motor", 1.0))


__all__ = ["NO_MISMATCH", "ModelMismatch", "parse_mismatch"]
