import logging
import os
import sys

import pytest

sys.path.insert(0, os.path.dirname(__file__))
os.environ.setdefault("MUJOCO_GL", "egl")


@pytest.fixture
def quiet_logs():
    """Silence the controller's warnings (infeasible QPs are expected in these tests)."""
    logging.disable(logging.WARNING)
    yield
    logging.disable(logging.NOTSET)
