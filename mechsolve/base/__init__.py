"""The base layer: numerics, units, the state of the bodies, errors, Newton's method and files
written atomically.

Imports nothing else of mechsolve.
"""
