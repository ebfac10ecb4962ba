"""The constraint system's analytic derivatives against finite differences.

Finite differences appear only here, to check Phi_q and gamma; the solver never uses them.
"""

from __future__ import annotations

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.base.state import State
from mechsolve.system.constraints import ConstraintSystem

from conftest import MECH


def set_q(st, q, qd=None, qdd=None):
    nb = st.nb
    for i in range(nb):
        st.x[i], st.y[i] = q[3 * i], q[3 * i + 1]
        st.set_angle(i, np.array([q[3 * i + 2]]))
        if qd is not None:
            st.vx[i], st.vy[i], st.w[i] = qd[3 * i : 3 * i + 3]
        if qdd is not None:
            st.ax[i], st.ay[i], st.al[i] = qdd[3 * i : 3 * i + 3]


# a hydraulic cylinder (barrel pinned at P, rod pinned to a lever at Q) lifting a lever
LINEAR = """
ground: {P: [0, 0], O: [1, 0]}
links:
  barrel: {points: {P: [0, 0], E: [0.5, 0.1]}}
  rod: {points: {R: [0, 0], Q: [0.3, 0]}}
  lever: {points: {O: [0, 0], Q: [0.4, 0], T: [1.2, 0.1]}}
joints:
  P: [ground, barrel]
  O: [ground, lever]
  Q: [rod, lever]
  piston: {slider: [barrel, rod], point: R, line: {through: [0, 0], angle: 0}}
assembly:
  sketch: {Q: [0.9, 0.4]}
driver: {joint: piston, speed: 0.1 m/s, start: 0.6 m}
sweep: {range: 0.2 m, step: 0.05 m}
"""


@pytest.mark.parametrize("source", ["shaper.yaml", "crane.yaml", "slider-crank.yaml", LINEAR])
def test_jacobian_and_gamma(source):
    mech = ms.load(MECH / source) if source.endswith(".yaml") else ms.loads(source)
    sysm = ConstraintSystem(mech)
    nb = sysm.nb
    rng = np.random.default_rng(1)
    q, qd, qdd = (rng.normal(size=3 * nb) for _ in range(3))
    u, ud, udd = 0.3, 0.7, -0.2
    st = State(nb, 1)
    set_q(st, q, qd, qdd)
    J = sysm.jacobian(st)[0]
    h = 1e-6
    Jfd = np.zeros_like(J)
    for k in range(3 * nb):
        e = np.zeros(3 * nb)
        e[k] = h
        s1, s2 = State(nb, 1), State(nb, 1)
        set_q(s1, q + e)
        set_q(s2, q - e)
        Jfd[:, k] = (sysm.residual(s1, u) - sysm.residual(s2, u))[:, 0] / (2 * h)
    np.testing.assert_allclose(J, Jfd, atol=1e-8)

    # along q(t) = q + qd t + qdd t^2/2, u(t) = u + ud t + udd t^2/2:
    # d2/dt2 Phi = Phi_q qdd - gamma, and d/dt Phi = Phi_q qd - nu
    def phi(t):
        s = State(nb, 1)
        set_q(s, q + qd * t + 0.5 * qdd * t * t)
        return sysm.residual(s, u + ud * t + 0.5 * udd * t * t)[:, 0]

    h = 1e-4
    d1 = (phi(h) - phi(-h)) / (2 * h)
    d2 = (phi(h) - 2 * phi(0) + phi(-h)) / h**2
    nu = sysm.nu(st, ud)[:, 0]
    gamma = sysm.gamma(st, udd)[:, 0]
    np.testing.assert_allclose(J @ qd - nu, d1, atol=1e-7)
    np.testing.assert_allclose(J @ qdd - gamma, d2, atol=1e-5)


def test_linear_driver_cylinder_kinematics():
    """A hydraulic cylinder lifting a lever, against the triangle P-O-Q in closed form."""
    res = ms.solve(ms.loads(LINEAR))
    assert res.ok.all()
    piston = res.slider("piston")
    np.testing.assert_allclose(piston.s, 0.6 + 0.1 * res.t, atol=1e-12)
    np.testing.assert_allclose(piston.v, 0.1, atol=1e-12)
    np.testing.assert_allclose(piston.a, 0.0, atol=1e-12)
    # |PQ| = s + 0.3 (rod end Q beyond the piston), |OQ| = 0.4, |PO| = 1: law of cosines
    L, r, d = 0.6 + 0.1 * res.t + 0.3, 0.4, 1.0
    cos_o = (r * r + d * d - L * L) / (2 * r * d)  # angle at O between O->P and O->Q
    phi = np.pi - np.arccos(cos_o)  # lever angle from +x, Q above the ground line
    lever = res.link("lever")
    np.testing.assert_allclose(lever.angle, phi, atol=1e-10)
    # the lever's rate from dL/dt = 0.1: L dL = r d sin(angle at O) d(angle at O), and
    # the lever angle is pi minus the angle at O
    dphi = -0.1 * L / (r * d * np.sin(np.arccos(cos_o)))
    np.testing.assert_allclose(lever.omega, dphi, rtol=1e-9)
