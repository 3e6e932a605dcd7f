"""Artificial-potential-field planner: the core (apf) and the node (planner_node)."""
