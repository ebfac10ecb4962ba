"""A batch of designs places its links with per-design local vectors (one per column):
the frames, the rotated vectors and the dyad's rates against hand rotations, and the
placing done without full-size temporaries beyond the vector's own components."""

from __future__ import annotations

import math
import tracemalloc

import numpy as np
import pytest

from mechsolve.base.state import State
from mechsolve.groups.base import set_pose_from_vectors

N = 20000


def _batch_vectors(rng, along_x: bool):
    """Local points s0 = 0 and sm (2, N) of a link per column, and a global angle."""
    L = rng.uniform(0.02, 0.2, N)
    phi = np.zeros(N) if along_x else rng.uniform(-math.pi, math.pi, N)
    sm = np.array([L * np.cos(phi), L * np.sin(phi)])
    th = rng.uniform(-math.pi, math.pi, N)
    return L, phi, sm, th


@pytest.mark.parametrize("along_x", [True, False])
def test_frames_of_a_batch_against_hand_rotations(along_x: bool) -> None:
    """The frame that maps sm - s0 onto g = L (cos t, sin t) has the angle t - phi and
    its origin where s0 (off the origin here) lands on P."""
    rng = np.random.default_rng(7)
    L, phi, sm, th = _batch_vectors(rng, along_x)
    s0 = np.array([0.01, -0.02])
    sm = sm + s0[:, None]
    gx, gy = L * np.cos(th), L * np.sin(th)
    px, py = rng.uniform(-1, 1, N), rng.uniform(-1, 1, N)
    st = State(1, N)
    set_pose_from_vectors(st, 0, s0, sm, px, py, gx, gy)
    ang = th - phi
    err = np.angle(np.exp(1j * (st.th[0] - ang)))
    assert np.max(np.abs(err)) < 1e-12
    assert np.allclose(st.c[0], np.cos(ang), rtol=0, atol=1e-13)
    assert np.allclose(st.s[0], np.sin(ang), rtol=0, atol=1e-13)
    ox = px - (np.cos(ang) * s0[0] - np.sin(ang) * s0[1])
    oy = py - (np.sin(ang) * s0[0] + np.cos(ang) * s0[1])
    assert np.allclose(st.x[0], ox, rtol=0, atol=1e-14)
    assert np.allclose(st.y[0], oy, rtol=0, atol=1e-14)


@pytest.mark.parametrize("along_x", [True, False])
def test_rotated_batch_vectors_against_hand_rotations(along_x: bool) -> None:
    rng = np.random.default_rng(11)
    _, _, s, th = _batch_vectors(rng, along_x)
    st = State(1, N)
    st.set_angle(0, th)
    rx, ry = st.rotated(0, s)
    assert np.allclose(rx, np.cos(th) * s[0] - np.sin(th) * s[1], rtol=0, atol=1e-15)
    assert np.allclose(ry, np.sin(th) * s[0] + np.cos(th) * s[1], rtol=0, atol=1e-15)


def test_placing_a_batch_of_frames_makes_no_full_size_temporaries() -> None:
    """Placing a link whose frames lie along its segment in every design (lengths that
    differ per design) writes its cosine and sine into the state: at most the vector's
    components and its squared length are alive at once, not the general formula's
    products and sums beside them (six arrays of the batch's size)."""
    rng = np.random.default_rng(3)
    L, _, sm, th = _batch_vectors(rng, True)
    gx, gy = L * np.cos(th), L * np.sin(th)
    px = py = np.zeros(N)
    st = State(1, N)
    s0 = np.zeros(2)
    set_pose_from_vectors(st, 0, s0, sm, px, py, gx, gy)  # (numpy's first-call work)
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        set_pose_from_vectors(st, 0, s0, sm, px, py, gx, gy)
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    assert peak <= 4.5 * 8 * N, f"{peak / (8 * N):.1f} arrays of the batch's size"
    assert np.allclose(st.th[0], th, rtol=0, atol=1e-12)
