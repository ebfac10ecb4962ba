"""The vectors of a polygon and the intersection of two direction lines (see
:mod:`mechsolve.analyses.polygons`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mechsolve.base.errors import SolverError


def _k_cross(w: float, r: np.ndarray) -> np.ndarray:
    """``w k × r``: the vector ``r`` turned by 90° counter-clockwise, times ``w``."""
    return np.array([-w * r[1], w * r[0]])


def _intersect(p1, d1, p2, d2, what: str) -> tuple[float, float]:
    """``(s, t)`` with ``p1 + s d1 = p2 + t d2``: where two direction lines cross."""
    m = np.array([[d1[0], -d2[0]], [d1[1], -d2[1]]], float)
    scale = float(np.linalg.norm(d1) * np.linalg.norm(d2))
    det = float(np.linalg.det(m))
    if scale == 0 or abs(det) <= 1e-10 * scale:
        raise SolverError(
            f"{what}: the two direction lines are parallel (a dead-centre or toggle "
            "position): the polygon does not close here; pick another position"
        )
    s, t = np.linalg.solve(m, np.asarray(p2, float) - np.asarray(p1, float))
    return float(s), float(t)


@dataclass
class Arrow:
    """One vector of a polygon, drawn from node ``tail`` to node ``head``.

    ``kind``: ``absolute`` (from the pole), ``relative`` (rotation about another point of
    the link), ``normal`` / ``tangential`` (components of a relative acceleration),
    ``coriolis`` or ``sliding`` (relative motion along a guide). ``along``: the signed
    value along the guide for sliding vectors (positive in the guide line's direction)."""

    name: str
    tail: str
    head: str
    vec: np.ndarray
    kind: str
    note: str = ""
    along: float | None = None

    @property
    def value(self) -> float:
        return float(np.hypot(*self.vec))
