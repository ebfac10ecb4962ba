"""Shaking force and moment on the frame.

:func:`shaking` gives the load the moving links transmit to the frame over a sweep
(:mod:`.frame`).
"""

from __future__ import annotations

from mechsolve.analyses.shaking.frame import Shaking, frame_load, inertia_only, shaking

__all__ = ["Shaking", "frame_load", "inertia_only", "shaking"]
