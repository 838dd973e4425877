"""Estimation: the MPC's start state and the disturbance, from the robot's measurements."""
