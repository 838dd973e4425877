"""Runs: a closed-loop run as data, executed on the LIP or in MuJoCo, recorded and summarised."""
