"""The Newton groups' batched sweep, sixth pass: a refinement's last, tiny steps turn the
cosines and sines by ``C - S D`` and ``S + C D`` (where the fifth-order series round to
``cos D = 1`` and ``sin D = D`` exactly), and the triad's coarse positions get their
rates from the elimination without its conditioning bound. Checked against ``cos`` and
``sin`` evaluated again, the series worked out in full, and the triad's rates from
``F_theta`` solved by LAPACK."""

from __future__ import annotations

import numpy as np

from mechsolve.core.sweep import Analysis
from mechsolve.groups.base import Drive
from mechsolve.groups.generic import NewtonGroup
from mechsolve.groups.newton_batched import _rotate
from mechsolve_bench import _triad_mech


def _series(C, S, D):
    d2 = D * D
    cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0))
    sd = D * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0)))
    return C * cd - S * sd, S * cd + C * sd


def test_the_series_of_a_step_below_1e_8_is_one_and_the_step():
    """For |D| <= 1e-8, 1 - D^2 (1/2 - D^2/24) rounds to 1.0 and D (1 - D^2 (1/6 - ...))
    to D, bit for bit (D^2 / 2 <= 5e-17 is below 5.55e-17, half the spacing of the
    floats under 1); at 1.1e-8 the cosine's series no longer rounds to 1."""
    rng = np.random.default_rng(3)
    D = np.concatenate([rng.uniform(-1e-8, 1e-8, 200_000), [0.0, -0.0, 1e-8, -1e-8]])
    d2 = D * D
    assert np.all(1.0 - d2 * (0.5 - d2 * (1.0 / 24.0)) == 1.0)
    sd = D * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0)))
    assert np.array_equal(sd.view(np.int64), D.view(np.int64))
    d = np.array([1.1e-8])
    assert (1.0 - d * d * (0.5 - d * d / 24.0))[0] < 1.0


def test_turning_by_tiny_steps_is_the_series_and_cos_sin():
    """Steps from 1e-16 to 1e-8 (the tiny path) and up to 1e-4 (the series): the turned
    cosines and sines are those of the series bit for bit, and cos and sin of the new
    angles to a few units of the last place."""
    rng = np.random.default_rng(4)
    th = rng.uniform(-7, 7, (2, 5000))
    for top in (1e-8, 1e-4):
        D = rng.uniform(-1, 1, th.shape) * 10.0 ** rng.uniform(-16, np.log10(top), th.shape)
        C, S = np.cos(th), np.sin(th)
        want = _series(C, S, D)
        _rotate(C, S, D, th + D)
        assert np.array_equal(C.view(np.int64), want[0].view(np.int64))
        assert np.array_equal(S.view(np.int64), want[1].view(np.int64))
        np.testing.assert_allclose(C, np.cos(th + D), rtol=0, atol=1e-15)
        np.testing.assert_allclose(S, np.sin(th + D), rtol=0, atol=1e-15)


def test_the_triads_coarse_rates_are_f_theta_solved():
    """At 36 poses of the triad's sweep, the rates the coarse pass takes (the
    elimination alone) are ``-F_theta^-1 dK/du`` solved by LAPACK, to 1e-12 relative,
    and the ones :meth:`_angle_rates` gives bit for bit."""
    an = Analysis(_triad_mech(360), "auto")
    u0 = an.start_value()
    u, _ = an.sweep_values(u0)
    sol = an.solve(u)
    g = next(g for g in an.plan if isinstance(g, NewtonGroup))
    idx = np.arange(0, 360, 10)
    st = sol.state.take(idx)
    ones = Drive(u[idx], np.ones(len(idx)), np.zeros(len(idx)))
    g._coarse_rates(st, ones)
    got = st.w[g.bodies].copy()
    st.w[g.bodies] = 0.0
    g._elim_cache = None
    g._angle_rates(st, ones, 1, frames=False)
    assert np.array_equal(got.view(np.int64), st.w[g.bodies].view(np.int64))
    red = g.red
    J = red.jacobian(st.c[g.bodies].T, st.s[g.bodies].T)
    rhs = -red.known(st, 1)[0]
    want = np.linalg.solve(J, rhs[..., None])[..., 0]
    np.testing.assert_allclose(got.T, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())


def test_the_fourbar_step_takes_its_residual_from_the_jacobians_products():
    """The four-bar's loop b e(th3) - c e(th4) + K = 0: the residual summed from the
    Jacobian's products is the loop's residual written out (bit for bit: the same
    products, negated exactly) and the step solves the 2 x 2 system (LAPACK, 1e-12)."""
    from mechsolve.groups.newton_batched import _newton_step2

    b, c = 0.1056, 0.059
    rows = [((-b, -0.0, 0.0), (c, -0.0, 0.0)), ((0.0, -b, 0.0), (0.0, c, 0.0))]
    rng = np.random.default_rng(6)
    t = rng.uniform(-4, 4, (2, 400))
    k0, k1 = rng.uniform(-0.1, 0.1, 400), rng.uniform(-0.1, 0.1, 400)
    r, dq, step = _newton_step2(rows, False, t, k0, k1)
    f0 = k0 + -b * np.cos(t[0])
    f0 += c * np.cos(t[1])
    f1 = k1 + -b * np.sin(t[0])
    f1 += c * np.sin(t[1])
    want = np.maximum(np.abs(f0), np.abs(f1))
    assert np.array_equal(r.view(np.int64), want.view(np.int64))
    J = np.empty((400, 2, 2))
    J[:, 0, 0], J[:, 0, 1] = b * np.sin(t[0]), -c * np.sin(t[1])
    J[:, 1, 0], J[:, 1, 1] = -b * np.cos(t[0]), c * np.cos(t[1])
    x = np.linalg.solve(J, -np.stack([f0, f1], axis=1)[..., None])[..., 0]
    np.testing.assert_allclose(dq.T, x, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(step, np.abs(x).max(axis=1), rtol=1e-9, atol=1e-12)


def test_a_crank_alone_is_placed_at_its_driver_angle():
    """The four-bar's crank under ``split-newton`` (a group of its own, its angle fixed
    by the driver): at every position its angle is the driver's value (the joint's
    relative angle to the ground, start 10 deg), its cosine and sine those of it, its
    frame at the pivot O2 (0, 0); the same rows the general placing writes."""
    import mechsolve as ms
    from mechsolve_bench import fourbar_yaml

    an = Analysis(ms.loads(fourbar_yaml(720)), "split-newton")
    g = an.plan[0]
    assert isinstance(g, NewtonGroup) and g.red.sub.nb == 0
    u0 = an.start_value()
    u, _ = an.sweep_values(u0)
    st = an.solve(u).state
    b = g.bodies[0]
    np.testing.assert_allclose(st.th[b], u, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(st.c[b], np.cos(st.th[b]))
    np.testing.assert_array_equal(st.s[b], np.sin(st.th[b]))
    assert not st.x[b].any() and not st.y[b].any()
    rows = st.block[:5, b].copy()
    assert g._crank_alone(st, Drive(u, np.ones(len(u)), np.zeros(len(u)))) is not None
    st.block[:5, b] = np.nan
    K, Px, Py = g.red.known(st)
    thp = g.red.fixed_angles(g.red.with_driver(K, u))
    g._put_angles(st, g.red.join(thp[:, :0], thp), Px, Py)
    assert np.array_equal(st.block[:5, b].view(np.int64), rows.view(np.int64))


def test_an_entry_without_its_zero_products_is_the_full_expression():
    """``m2 C - m1 S + m3`` with a zero coefficient's product left out gives the full
    expression's values bit for bit (zeros' signs included, at angles whose cosine or
    sine is exactly zero too), for the coefficients of a four-bar's entries and others."""
    from mechsolve.groups.newton_rates import _entry

    rng = np.random.default_rng(8)
    th = rng.uniform(-7, 7, 5000)
    C = np.concatenate([np.cos(th), [0.0, -0.0, 1.0, -1.0]])
    S = np.concatenate([np.sin(th), [0.0, 0.0, -0.0, 0.0]])
    for m1 in (-0.1056, 0.059, 0.0, -0.0):
        for m2 in (-0.1056, 0.0, -0.0, 0.3):
            for m3 in (0.0, -0.0, 1.0):
                want = m2 * C - m1 * S + m3
                got = _entry(m1, m2, m3, C, S)
                assert np.array_equal(want.view(np.int64), got.view(np.int64)), (m1, m2, m3)
