"""Simulators that make realistic data with known truth, in the formats real sensors give."""
