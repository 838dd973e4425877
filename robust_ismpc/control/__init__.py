"""Controllers: nominal IS-MPC, its robustness modules, step timing adaptation, starting a walk."""
