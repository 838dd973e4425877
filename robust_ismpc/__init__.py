"""Robust IS-MPC: humanoid gait generation that stays balanced under pushes, forces and payloads.

The layers, from the bottom up (docs/architecture.md): ``core`` (the IS-MPC QP and its maths),
``estimation``, ``control`` (the per-cycle controllers), ``robots`` (robot files), ``sim``
(MuJoCo), ``runs`` (a run as data, on the LIP or in MuJoCo), ``plotting``, ``experiments``
(scenarios, sweeps, soaks, benchmarks) and ``cli`` (the ``ismpc`` command).
"""
