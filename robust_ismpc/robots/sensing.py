r"""What a robot's sensors make of its true state: noise, bias and latency on the measurement.

A simulator knows the robot's true state; a robot only measures it. :class:`Sensors` sits
between the two: every control tick it receives the true :class:`~robust_ismpc.core.reference.Measurement`
and returns the one the controller gets, with

- the CoM position offset by a constant bias (a mass-model error moves the computed CoM; its
  direction is drawn once per run from the seed) and white noise,
- white noise on the CoM velocity (what an IMU-and-leg-kinematics base estimate gives),
- white noise on the horizontal contact force and on the contact moment (foot force-torque
  sensors; a standard deviation given as a fraction of the robot's weight, per axis and tick);
  the contact moment is taken about the measured CoM, so the CoM bias :math:`b` shows in the
  external moment (:attr:`~robust_ismpc.core.reference.Measurement.external_moment_acc_mps2`) as
  :math:`-\eta^2 b`: the weight, acting at the true CoM, has a moment :math:`-b \times m g`
  about the measured one,
- white noise on the measured soles and the centre of pressure,
- a latency: the controller gets the reading of ``latency_s`` ago.

On a robot with joints (MuJoCo) the sensors themselves are modelled too: encoders, a pelvis IMU
and the foot contacts feed a state estimator (:mod:`robust_ismpc.sim.state_estimation`), whose
errors replace the CoM position, sole and CoP noise above
(:meth:`SensingParams.for_estimated_state`); the rest of the list still applies.

:data:`SENSING_PRESETS` names the models a run may ask for: ``ideal`` (the simulator's ground
truth, for tests and for comparisons with the paper) and ``realistic`` (the orders of magnitude of
a humanoid's sensors and state estimate, below). Noise is drawn from the run's seed, so a run is
reproducible.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from ..core.params import GRAVITY_MPS2
from ..core.reference import Measurement
from ..estimation.estimator import EstimatorParams
from ..exceptions import ParameterError
from ..validation import check_nonnegative

#: The fields that model the sensors themselves (encoders, IMU) rather than the estimate; a robot
#: file's ``[sensors]`` table may set them (:func:`robot_sensing`).
SENSOR_FIELDS = ("joint_pos_resolution_rad", "joint_vel_noise_radps", "gyro_noise_radps", "gyro_bias_radps",
                  "accel_noise_mps2", "accel_bias_mps2", "imu_tilt_error_rad", "imu_orientation_noise_rad")


@dataclass(frozen=True)
class SensingParams:
    """A sensor model: standard deviations of white noise, a bias and a latency.

    Attributes
    ----------
    name : str
        The preset's name, recorded with every run.
    com_pos_noise_m : float
        σ of the horizontal CoM position, per axis and tick [m].
    com_pos_bias_m : float
        Length of a constant horizontal offset of the CoM position [m]; its direction is drawn
        once per run.
    com_vel_noise_mps : float
        σ of the horizontal CoM velocity, per axis and tick [m/s].
    contact_force_noise : float
        σ of the horizontal contact force per axis and tick, as a fraction of the robot's weight
        [-]; the contact moment about the CoM gets the same σ as an LIP acceleration.
    position_noise_m : float
        σ of the measured soles and centre of pressure, per axis and tick [m].
    latency_s : float
        Age of the reading the controller gets [s]; a whole number of control periods.
    joint_pos_resolution_rad : float
        Encoder resolution: joint positions are read rounded to it [rad].
    joint_vel_noise_radps : float
        σ of the joint velocities the motor drivers report [rad/s].
    gyro_noise_radps, gyro_bias_radps : float
        σ of the IMU's angular velocity per axis and sample, and the length of its constant bias
        (direction drawn once per run) [rad/s].
    accel_noise_mps2, accel_bias_mps2 : float
        σ of the IMU's specific force per axis and sample, and the length of its constant bias
        [m/s²].
    imu_tilt_error_rad : float
        Constant error of the roll and pitch the IMU's attitude filter reports (its direction drawn
        once per run) [rad].
    imu_orientation_noise_rad : float
        σ of the white noise on the IMU's orientation, per axis and sample [rad].

    The last eight describe the sensors themselves. When any of them is set, a MuJoCo run
    estimates the robot's state from those sensors (:mod:`robust_ismpc.sim.state_estimation`)
    and the CoM, its velocity and the soles carry the estimate's own errors; the stand-ins for the
    position errors (``com_pos_noise_m``, ``position_noise_m``) then serve the reduced model
    alone, which has no joints, and ``com_vel_noise_mps`` is added to the estimate
    (:meth:`for_estimated_state`).
    """

    name: str = "ideal"
    com_pos_noise_m: float = 0.0
    com_pos_bias_m: float = 0.0
    com_vel_noise_mps: float = 0.0
    contact_force_noise: float = 0.0
    position_noise_m: float = 0.0
    latency_s: float = 0.0
    joint_pos_resolution_rad: float = 0.0
    joint_vel_noise_radps: float = 0.0
    gyro_noise_radps: float = 0.0
    gyro_bias_radps: float = 0.0
    accel_noise_mps2: float = 0.0
    accel_bias_mps2: float = 0.0
    imu_tilt_error_rad: float = 0.0
    imu_orientation_noise_rad: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ParameterError(f"SensingParams.name must be a non-empty string, got {self.name!r}")
        check_nonnegative("SensingParams", com_pos_noise_m=self.com_pos_noise_m, com_pos_bias_m=self.com_pos_bias_m,
                          com_vel_noise_mps=self.com_vel_noise_mps, contact_force_noise=self.contact_force_noise,
                          position_noise_m=self.position_noise_m, latency_s=self.latency_s,
                          **{name: getattr(self, name) for name in SENSOR_FIELDS})

    @property
    def is_ideal(self) -> bool:
        """True when the controller reads the true state."""
        return not self.models_sensors and all(
            v == 0 for v in (self.com_pos_noise_m, self.com_pos_bias_m, self.com_vel_noise_mps,
                             self.contact_force_noise, self.position_noise_m, self.latency_s))

    @property
    def models_sensors(self) -> bool:
        """True when the encoders or the IMU are imperfect: a robot with joints then estimates its
        state from them."""
        return any(getattr(self, name) != 0 for name in SENSOR_FIELDS)

    def for_estimated_state(self) -> SensingParams:
        """The signal model left when the state is estimated from the sensors: the stand-ins for
        the estimate's position errors (CoM, soles, CoP) removed; the CoM bias (a mass-model
        error), the foot force-torque noise, the latency and the CoM velocity noise kept. The
        simulated robot is rigid and its soles do not roll: the estimate's velocity error there
        (3-5 mm/s on G1) is far below a real robot's, whose joints flex and have backlash, and the
        velocity noise stands for that remainder."""
        return replace(self, com_pos_noise_m=0.0, position_noise_m=0.0)

    def estimator_params(self, base: EstimatorParams) -> EstimatorParams:
        """The estimator a controller reading these sensors uses: ``base`` (the model's own
        mismatch) with the sensors' noise, the larger of the two per signal.

        Parameters
        ----------
        base : EstimatorParams
            The estimator for exact signals (the LIP's: none; a MuJoCo robot's:
            :data:`~robust_ismpc.runs.mujoco.ROBOT_ESTIMATOR`).
        """
        if self.is_ideal:
            return base
        return replace(
            base,
            com_pos_noise_m=max(base.com_pos_noise_m, self.com_pos_noise_m),
            com_vel_noise_mps=max(base.com_vel_noise_mps, self.com_vel_noise_mps),
            sensor_vel_noise_mps=self.com_vel_noise_mps,
            sensor_contact_acc_noise_mps2=math.sqrt(2.0) * self.contact_force_noise * GRAVITY_MPS2,  # force and moment
        )

    def as_dict(self) -> dict:
        """The model as plain values (``summary.json``)."""
        return asdict(self)


#: The sensor models a run can name. ``realistic``: a base-velocity estimate from an IMU and
#: leg kinematics is good to a few cm/s (3 cm/s here), the CoM computed from a mass model is off
#: by about 1 cm, foot force-torque sensors read to about 2 % of the weight, encoders and
#: kinematics place the feet to a few mm, and sensing, estimation and communication add about
#: one control period of delay (10 ms). Its sensors: 14-bit joint encoders, joint velocities to
#: 0.02 rad/s, and a MEMS IMU (gyroscope 0.005 rad/s noise and 0.002 rad/s bias, accelerometer
#: 0.03 m/s² noise and 0.05 m/s² bias, attitude to 0.3° of tilt).
SENSING_PRESETS: dict[str, SensingParams] = {
    "ideal": SensingParams(),
    "realistic": SensingParams(name="realistic", com_pos_noise_m=0.002, com_pos_bias_m=0.01, com_vel_noise_mps=0.03,
                               contact_force_noise=0.02, position_noise_m=0.002, latency_s=0.01,
                               joint_pos_resolution_rad=2.0 * math.pi / 2**14, joint_vel_noise_radps=0.02,
                               gyro_noise_radps=0.005, gyro_bias_radps=0.002, accel_noise_mps2=0.03,
                               accel_bias_mps2=0.05, imu_tilt_error_rad=0.005, imu_orientation_noise_rad=0.001),
}


def robot_sensing(name: str, robot_sensors: tuple[tuple[str, float], ...] = ()) -> SensingParams:
    """The preset called ``name`` with a robot's own sensors (its robot file's ``[sensors]``
    table, :attr:`~robust_ismpc.robots.spec.RobotSpec.sensors`) in place of the preset's.
    ``ideal`` stays the truth whatever the robot's sensors.

    Raises
    ------
    ParameterError
        No preset has that name, or a sensor value is invalid.
    """
    preset = sensing_preset(name)
    if preset.is_ideal or not robot_sensors:
        return preset
    unknown = [key for key, _ in robot_sensors if key not in SENSOR_FIELDS]
    if unknown:
        raise ParameterError(f"unknown sensor {unknown[0]!r}; use one of: {', '.join(SENSOR_FIELDS)}")
    values: dict[str, Any] = dict(robot_sensors)
    return replace(preset, **values)


def sensing_preset(name: str) -> SensingParams:
    """The preset called ``name``.

    Raises
    ------
    ParameterError
        No preset has that name (the message lists them).
    """
    if name not in SENSING_PRESETS:
        raise ParameterError(f"unknown sensing {name!r}; use one of: {', '.join(SENSING_PRESETS)}")
    return SENSING_PRESETS[name]


class Sensors:
    """Turns the true measurement of each tick into the one the controller reads.

    Parameters
    ----------
    params : SensingParams
    period_s : float
        Control period [s]; ``params.latency_s`` must be a whole number of them.
    eta : float
        LIP natural frequency sqrt(g / h) [1/s] of the CoM height the external moment is
        expressed with.
    seed : int
        Seed of the noise and of the bias direction.
    """

    def __init__(self, params: SensingParams, period_s: float, eta: float, seed: int = 0) -> None:
        if not isinstance(params, SensingParams):
            raise ParameterError(f"sensing must be SensingParams, got {type(params).__name__}")
        ticks = params.latency_s / period_s
        if abs(ticks - round(ticks)) > 1e-6:
            raise ParameterError(
                f"sensing latency ({params.latency_s} s) must be a whole number of control periods ({period_s} s)"
            )
        self.params = params
        self.latency_ticks = int(round(ticks))
        self._acc_noise_mps2 = params.contact_force_noise * GRAVITY_MPS2  # σ F / m
        self._rng = np.random.default_rng(seed)
        angle = self._rng.uniform(0.0, 2.0 * math.pi)
        self.com_bias_m = params.com_pos_bias_m * np.array([math.cos(angle), math.sin(angle)])
        self._bias_moment_acc_mps2 = -eta**2 * self.com_bias_m
        self._queue: deque[Measurement] = deque()

    def read(self, truth: Measurement) -> Measurement:
        """The measurement the controller gets at this tick, from the true one (shapes as in
        :class:`~robust_ismpc.core.reference.Measurement`).

        Until ``latency_s`` has passed since the first tick it is the first tick's reading.
        """
        if self.params.is_ideal:
            return truth
        sensed = self._corrupt(truth)
        self._queue.append(sensed)
        if len(self._queue) > self.latency_ticks + 1:
            self._queue.popleft()
        return self._queue[0]

    def _noise(self, sigma: float, size: int = 2) -> np.ndarray:
        return sigma * self._rng.standard_normal(size) if sigma > 0 else np.zeros(size)

    def _corrupt(self, m: Measurement) -> Measurement:
        p = self.params
        com = np.array(m.com_pos_m, float)
        com[:2] += self.com_bias_m + self._noise(p.com_pos_noise_m)
        vel = np.array(m.com_vel_mps, float)
        vel[:2] += self._noise(p.com_vel_noise_mps)

        def noisy(v: np.ndarray | None, sigma: float) -> np.ndarray | None:
            return None if v is None else np.asarray(v, float) + self._noise(sigma, np.size(v))

        return replace(
            m, com_pos_m=com, com_vel_mps=vel,
            zmp_m=noisy(m.zmp_m, p.position_noise_m),
            left_sole_m=noisy(m.left_sole_m, p.position_noise_m),
            right_sole_m=noisy(m.right_sole_m, p.position_noise_m),
            contact_acc_mps2=noisy(m.contact_acc_mps2, self._acc_noise_mps2),
            external_moment_acc_mps2=(None if m.external_moment_acc_mps2 is None else
                                      np.asarray(m.external_moment_acc_mps2, float) + self._bias_moment_acc_mps2
                                      + self._noise(self._acc_noise_mps2)),
        )


__all__ = ["SENSING_PRESETS", "SENSOR_FIELDS", "SensingParams", "Sensors", "robot_sensing", "sensing_preset"]
