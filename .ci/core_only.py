"""CI: the core works with only its declared dependencies (numpy, scipy, daqp) installed.

Run from outside the repository, in a virtual environment where ``pip install .`` (no extras)
installed robust-ismpc: walks g1's reduced model with the robust controller, reads a robot file,
and checks that no optional package was needed.
"""

import importlib.util
import sys

OPTIONAL = ("mujoco", "mink", "matplotlib", "qpsolvers", "ray", "imageio")

missing_optional = [name for name in OPTIONAL if importlib.util.find_spec(name) is None]
assert missing_optional == list(OPTIONAL), f"this environment has optional packages: {set(OPTIONAL) - set(missing_optional)}"

import robust_ismpc.control.robust  # noqa: E402,F401
import robust_ismpc.core.mpc  # noqa: E402,F401
import robust_ismpc.estimation.estimator  # noqa: E402,F401
from robust_ismpc.core.planner import WalkCommand  # noqa: E402
from robust_ismpc.robots import read_robot_file, robot_file_path  # noqa: E402
from robust_ismpc.runs.forces import ForceWindow  # noqa: E402
from robust_ismpc.runs.run import run  # noqa: E402
from robust_ismpc.runs.spec import RunSpec  # noqa: E402

robot_file = read_robot_file(robot_file_path("g1"))
spec = RunSpec(robot="g1", sim="lip", modules=("observer", "restriction", "timing"), command=WalkCommand(0.2),
               duration_s=6.0, forces=(ForceWindow(40.0, 0.0, 3.0, 3.1),))
summary = run(spec).summary
assert not summary["fell"], summary["failure"]
assert summary["distance_m"] > 0.5, summary["distance_m"]  # 0.2 m/s after the first steps start
loaded = sorted(name for name in OPTIONAL if name in sys.modules)
assert not loaded, f"imported optional packages: {loaded}"
print(f"core only: {robot_file.table['name']} file read; robust LIP walk of {summary['duration_s']} s, "
      f"{summary['distance_m']:.2f} m, no fall; numpy, scipy and daqp only")
