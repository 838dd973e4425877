"""The IS-MPC core: parameters, LIP, footsteps, the QP and its feasibility maths (numpy, scipy, daqp)."""
