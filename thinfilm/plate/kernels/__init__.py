"""Numba kernels: arrays and scalars in, arrays out; no set-up, no I/O."""
