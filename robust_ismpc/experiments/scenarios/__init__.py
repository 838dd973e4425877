"""The paper's three experiments (§IV) as named scenarios: data in one place, run side by side.

A :class:`Scenario` states an experiment in the paper's terms: the robot, the walk command, the
duration, the disturbances *as on the paper's robot* (a 0.67 kg bag on a 5.4 kg NAO, a 0.265 kg
ball, 45 N and 85 N on HRP-4) and which robustness modules the robust side uses.
:func:`realise` turns it into what one seed runs: disturbances scaled to the simulated robot, a
small seeded variation of their time and magnitude, the two
:class:`~robust_ismpc.runs.spec.RunSpec` (nominal and robust) and the MuJoCo scene items (the bag,
the ball). :func:`run_scenario` runs both controllers on the identical disturbances and
:func:`comparison_metrics` condenses the pair into the ``comparison.json`` content.

Scaling rules: a mass (bag, ball) is multiplied by ``m_robot / m_paper_robot`` (the measured
mass of the MuJoCo model over the paper robot's mass); a force keeps the paper's dimensionless
load ``F h / (m g l)`` (CoM height h, half sole length l; :class:`ScaledForce`). Lengths (rope,
attachment) are chosen for the simulated robot's size.

Only :func:`realise` (robot mass, torso geometry) and :func:`run_scenario` need MuJoCo; they
import it lazily, so listing and validating scenarios does not.

Modules:

- :mod:`.catalogue`: the scenario data classes and the three built-in scenarios.
- :mod:`.realise`: one seed of a scenario on a robot (run specs, scene items, MuJoCo geometry).
- :mod:`.compare`: the nominal and robust runs side by side, comparison metrics, expected outcome.
"""

from __future__ import annotations

from .catalogue import (
    HRP4_DART,
    SCENARIOS,
    BagSpec,
    BallSpec,
    PaperRobot,
    ScaledForce,
    Scenario,
    Variation,
    get_scenario,
    scenario_names,
)
from .compare import (
    DEVIATION_MIN_M,
    DEVIATION_RATIO,
    ScenarioResult,
    comparison_metrics,
    disturbance_events,
    expected_outcome,
    path_deviation,
    run_scenario,
)
from .realise import (
    GRAVITY_MPS2,
    SIZE_FACTOR,
    ScenarioRun,
    on_robot,
    pendulum_swing_time,
    realise,
    right_arm_end,
)

__all__ = [
    "DEVIATION_MIN_M",
    "DEVIATION_RATIO",
    "GRAVITY_MPS2",
    "HRP4_DART",
    "SCENARIOS",
    "SIZE_FACTOR",
    "BagSpec",
    "BallSpec",
    "PaperRobot",
    "ScaledForce",
    "Scenario",
    "ScenarioResult",
    "ScenarioRun",
    "Variation",
    "comparison_metrics",
    "disturbance_events",
    "expected_outcome",
    "get_scenario",
    "on_robot",
    "path_deviation",
    "pendulum_swing_time",
    "realise",
    "right_arm_end",
    "run_scenario",
    "scenario_names",
]
