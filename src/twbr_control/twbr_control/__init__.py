"""Cascaded PID balance/velocity controller with a PI yaw-rate loop (issue 4 fills this package)."""
