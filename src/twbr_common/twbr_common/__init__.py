"""Helpers shared by the twbr packages."""
