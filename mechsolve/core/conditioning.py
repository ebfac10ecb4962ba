"""Conditioning of the constraint Jacobian, group by group.

Phi_q is block lower-triangular in the order of the structural groups, so it is singular
exactly where one of its diagonal blocks (a group's own Jacobian) is singular. The
reciprocal condition number of each group's equations (see :func:`jacobian_rcond`; for a
Newton group its block, equilibrated so that it does not depend on units) measures how
close a position is to a singular (toggle, dead-centre) configuration: 1 is perfectly
conditioned, 0 singular. The smallest over the groups is reported per position.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from mechsolve.base.state import State

if TYPE_CHECKING:
    from mechsolve.groups import Group

# How near a singular position the computed rates and forces are still right.
#
# Next to a singular position (a toggle, a bifurcation) the pose carries the rounding
# of its closure amplified by 1/s (s the sine of the loop's transmission angle, or the
# reciprocal condition of a Newton group's block), the rates solved from it eps/s^2 of
# their natural size and the accelerations and the forces eps/s^3. Measured on a
# parallelogram 0.01 to 1e-5 deg from its collinear position (s = 1.7e-4 to 1.7e-7):
# accelerations off by 2e-4 to 2e5 of omega^2, the driving torque by 4e-7 to 3e2 of its
# size; at s = 2e-3 both are good to about 1e-8 (at rcond 5e-4 the torque of a redundant
# parallelogram likewise). So within NEAR_SINGULAR_* of a singular position the rates
# and the driver's effort are taken as their limit along the motion wherever the motion
# is smooth through it (a bifurcation), from points d = 5e-3 rad away (which then lie
# outside that zone); where it is not (a limit position), the computed values are kept
# down to SINGULAR_*, below which they are rounding noise: left blank, as the
# reactions are. A pose whose rounding alone puts it 4e-8 off an exact bifurcation is
# thus singular, not a regular position with rates of 1e16.
SINGULAR_RCOND = 2.5e-7  # a block's reciprocal condition below this: singular
SINGULAR_INDICATOR = 1e-6  # sin of a loop's transmission angle below this: singular
NEAR_SINGULAR_RCOND = 2.5e-4  # below this: rates and effort by their limit where smooth
NEAR_SINGULAR_INDICATOR = 1e-3


def group_block(g: Group, st: State):
    """The group's square block of Phi_q, shape (N, m, n), and each constraint's Jacobian
    blocks (for reuse by the force solver)."""
    col = {b: k for k, b in enumerate(g.bodies)}
    m = sum(c.m for c in g.constraints)
    J = np.zeros((st.n, m, 3 * len(g.bodies)))
    blocks = []
    r0 = 0
    for c in g.constraints:
        jac = c.jacobian(st)
        blocks.append((c, r0, jac))
        for body, blk in jac.items():
            k = col.get(body)
            if k is not None:
                J[:, r0 : r0 + c.m, 3 * k : 3 * k + 3] = blk.transpose(2, 0, 1)
        r0 += c.m
    return J, blocks


def _equilibrated(J: np.ndarray):
    """Which matrices (N, m, n) are finite, and those scaled to unit column then unit row
    norms (None if none is finite)."""
    good = np.all(np.isfinite(J), axis=(1, 2))
    if not np.any(good):
        return good, None
    Jg = J[good]
    cs = np.linalg.norm(Jg, axis=1, keepdims=True)
    cs[cs == 0] = 1.0
    Js = Jg / cs
    rs = np.linalg.norm(Js, axis=2, keepdims=True)
    rs[rs == 0] = 1.0
    return good, Js / rs


def rcond(J: np.ndarray) -> np.ndarray:
    """Reciprocal 2-norm condition numbers of equilibrated matrices (N, m, n); 0 where the
    matrix has non-finite entries."""
    out = np.zeros(J.shape[0])
    good, A = _equilibrated(J)
    if A is None:
        return out
    sv = np.linalg.svd(A, compute_uv=False)
    out[good] = np.where(sv[:, 0] > 0, sv[:, -1] / sv[:, 0], 0.0)
    return out


def rcond_lower(J: np.ndarray) -> np.ndarray:
    """A lower bound of :func:`rcond` for square matrices (N, n, n), at the cost of one
    inverse: ``1 / (|A|_F |A^-1|_F)`` of the same equilibrated ``A``. As ``|A|_2 <=
    |A|_F <= sqrt(n) |A|_2``, it is between ``rcond / n`` and ``rcond``. NaN where the
    matrix is not finite or is exactly singular."""
    out = np.full(J.shape[0], np.nan)
    good, A = _equilibrated(J)
    if A is None:
        return out
    inv = _inverse(A)
    with np.errstate(divide="ignore", invalid="ignore"):
        out[good] = 1.0 / (
            np.sqrt(np.einsum("nij,nij->n", A, A)) * np.sqrt(np.einsum("nij,nij->n", inv, inv))
        )
    return out


def rcond_above(J: np.ndarray, threshold: float) -> np.ndarray:
    """:func:`rcond` of square matrices (N, n, n) where it is at most ``threshold``, and a
    lower bound above it (:func:`rcond_lower`): every comparison with a threshold at or
    below ``threshold`` reads the same, at the cost of one batched inverse, the singular
    values only where the bound cannot decide."""
    if J.ndim != 3 or J.shape[1] != J.shape[2]:
        return rcond(J)
    out = rcond_lower(J)
    cand = np.flatnonzero(~(out > threshold))
    if cand.size:
        out[cand] = rcond(J[cand])
    return out


def _inverse(A: np.ndarray) -> np.ndarray:
    try:
        return np.linalg.inv(A)
    except np.linalg.LinAlgError:  # some are exactly singular: those stay NaN
        out = np.full(A.shape, np.nan)
        d = np.linalg.det(A)
        ok = np.isfinite(d) & (d != 0)
        if np.any(ok):
            out[ok] = np.linalg.inv(A[ok])
        return out


def near_singular(g: Group, st: State, threshold: float) -> np.ndarray:
    """Where the reciprocal condition number of a group's block of Phi_q (:func:`rcond`)
    is at most ``threshold``, exactly as :func:`rcond` says, without its singular value
    decomposition at every position.

    A cheap lower bound of ``rcond`` is computed at every position: the group's own
    (:meth:`~mechsolve.groups.NewtonGroup.rcond_bound`, from the inverse its velocities
    use) or :func:`rcond_lower`. Only where the bound is at most ``threshold`` (or not
    finite) can the exact value be, and only there is it computed; a position the exact
    measure flags is never missed. Rectangular blocks (redundant constraints) get the
    exact measure everywhere.
    """
    bound = getattr(g, "rcond_bound", None)
    lower = bound(st) if bound is not None else None
    if lower is None:
        J, _ = group_block(g, st)
        if J.shape[1] != J.shape[2]:
            return rcond(J) <= threshold
        lower = rcond_lower(J)
    cand = np.flatnonzero(~(lower > threshold))
    out = np.zeros(st.n, bool)
    if cand.size:
        J = group_block(g, st if cand.size == st.n else st.take(cand))[0]
        if bound is not None and J.shape[1] == J.shape[2]:
            # the group's bound can be loose by a constant factor (the crane's whole-system
            # block: 1e-6 where rcond is 0.02): screen again with rcond_lower, one batched
            # inverse, before the singular values
            keep = ~(rcond_lower(J) > threshold)
            cand, J = cand[keep], J[keep]
        if cand.size:
            out[cand] = rcond(J) <= threshold
    return out


def jacobian_rcond(plan: list[Group], st: State, indicator: np.ndarray | None = None) -> np.ndarray:
    """The smallest reciprocal condition number over the groups at each position.

    A group solved in closed form is determined by a 2x2 system in its two unknown rates
    (the two links' angular velocities of a dyad, or an angular velocity and a sliding
    velocity); its unit columns make the group's transmission angle mu, so its reciprocal
    condition number is tan(mu / 2) = s / (1 + sqrt(1 - s^2)), s = sin mu being the
    group's indicator. A Newton group's is that of its (equilibrated) block of Phi_q.
    """
    out = np.ones(st.n)
    for gi, g in enumerate(plan):
        if g.n_modes == 2 and indicator is not None and gi < len(indicator):
            s = np.clip(indicator[gi], 0.0, 1.0)
            out = np.minimum(out, s / (1.0 + np.sqrt(1.0 - s * s)))
        elif g.kind == "Newton":
            J, _ = group_block(g, st)
            out = np.minimum(out, rcond(J))
    return out
