"""Graphical velocity and acceleration polygons (the textbook's 图解法) at one position.

The polygons are built as a textbook builds them: the Assur groups are taken in solving
order, and each group's unknown point is found from one vector equation written two ways,
each with one unknown magnitude along a known direction; the point is the intersection
of the two direction lines. For the groups mechsolve recognises:

* driver link (crank): ``v_A = v_O + ω × OA``, ``a_A = a_O + a^n_AO + a^t_AO``;
* RRR (links 1 and 2 pinned to known points P and Q, joined at M):
  ``v_M = v_P + v_MP (⟂ PM) = v_Q + v_MQ (⟂ QM)`` and
  ``a_M = a_P + a^n_MP + a^t_MP (⟂ PM) = a_Q + a^n_MQ + a^t_MQ (⟂ QM)``;
* RRP (a rod pinned at P, its block at M sliding on a known guide K):
  ``v_M = v_P + v_MP (⟂ PM) = v_MK + v_rel (∥ guide)`` and
  ``a_M = a_P + a^n_MP + a^t_MP = a_MK + a^k + a^r (∥ guide)``;
* RPR (a block pinned at a known point A slides on a bar pinned at a known point Q): the
  bar's point A4 coincident with the block's A3 satisfies ``v_A3 = v_A4 + v_A3A4`` with
  ``v_A4 ⟂ QA`` and ``v_A3A4 ∥ guide``, and
  ``a_A3 = a_A4^n + a_A4^t + a^k + a^r`` with ``a^k = 2 ω4 × v_A3A4``;
* PRP (two blocks on known guides pinned together at M): ``v_M = v_MK1 + v_rel1 =
  v_MK2 + v_rel2`` with a Coriolis term on each side.

The images of the other points of a link follow from two of its points (the velocity
image is similar to the link, turned by 90°). Only the positions come from mechsolve's
position solution, as the drawing of the mechanism does in the textbook; velocities and
accelerations come from the construction alone and are then compared with mechsolve's
analytic solution (:func:`mechsolve.analyses.instants.solve_instants`).

Positions are counted as the course designs count them: position 1 at the file's driver
start, ``per_turn`` (12) positions per turn of the crank in its direction of motion.
"""

from mechsolve.analyses.polygons.construction import (
    Arrow,
    Polygon,
    PolygonResult,
    build_polygons,
    resolve_at,
    round_scale,
)
from mechsolve.analyses.polygons.drawing import draw_polygons

__all__ = [
    "Arrow",
    "Polygon",
    "PolygonResult",
    "build_polygons",
    "draw_polygons",
    "resolve_at",
    "round_scale",
]
