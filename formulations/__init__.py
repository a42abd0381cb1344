"""Optimisation problems over plain numpy arrays.

This package never imports :mod:`optroute` (``tests/test_boundary.py``
enforces it): a formulation takes arrays and returns a frozen result
dataclass carrying the solver's own status string.
"""
