"""Experiments built from runs: the paper's scenarios, push sweeps, soaks, benchmarks, robot checks."""
