"""Whole-body control in MuJoCo: IK, inverse-dynamics torque control, and the actuator map."""
