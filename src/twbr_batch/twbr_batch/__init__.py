"""Headless twbr at scale, without ROS: the batch engine, Monte Carlo studies, the closed loop and gain tuning."""
