"""Cascaded PID balance/velocity controller with a PI yaw-rate loop: cores (pid, cascade, state_sync) and the node."""
