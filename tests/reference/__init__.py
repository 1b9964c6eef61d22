"""Slow, readable NumPy oracles of somite's compiled kernels (docs: each module's docstring)."""
