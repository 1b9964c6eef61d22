"""Slow NumPy oracles of the compiled kernels, for the tests."""
