"""The system layer: the constraint equations of a mechanism's joints and drivers, and its
structure (Grübler's count, the structural groups).

Imports the model and the base.
"""
