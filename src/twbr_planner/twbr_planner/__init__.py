"""Artificial-potential-field planner (issue 5 fills this package)."""
