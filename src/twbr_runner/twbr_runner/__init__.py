"""Scenario runner, recorder, metrics and figures from bags, headless closed loop and gain tuning."""
