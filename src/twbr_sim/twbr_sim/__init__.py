"""Simulated TWBR: dynamics, motors, IMU, world, and the sim_node / world_node adapters."""
