"""Issue 30 (cycle): the machine's cycle and switching loads in flywheel and simulate.

* A geared machine repeats only after several turns of its driver: the pinion of
  mechanisms/gear-train.yaml (20 teeth) turns three times per turn of the wheel (60), so
  the flywheel's energy method, and the stroke extremes that ``stroke(B.x)`` means in
  simulate, are taken over 1080 degrees of the pinion.
* The flywheel integrates the driving torque piecewise between the angles where a load
  switches (not by trapezoids across the jump) and takes the mean inertia over the period
  without counting its repeated end.
* The reduced path's adaptive integrator restarts at the switch angles, so that it meets
  its tolerance across a load that switches on and off.

The references are closed forms written here: each machine is a slider-crank (through a
gear pair for the gear train) whose positions are known in closed form, the driving
torque at a constant speed omega is T = 1/2 J'(theta) omega^2 + V'(theta) - Q(theta) (the
reduced inertia J, the potential V, the loads' generalised force Q), and its running
integral is taken by Gauss-Legendre quadrature between the load's switch angles.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from mechsolve import api
from mechsolve.analyses.flywheel import size_flywheel

MECH = Path(__file__).resolve().parents[1] / "mechanisms"
G = 9.81


class SliderCrank:
    """A crank of radius r about (ox, 0) at angle psi = ratio * theta (theta: the driver),
    a rod l to a slider on the line y = e; point masses and link inertias as the files
    give them. Positions in closed form, their theta-derivatives by 5-point stencils."""

    def __init__(self, *, r, l, e, ox, ratio, bodies, force, when):
        self.r, self.l, self.e, self.ox, self.ratio = r, l, e, ox, ratio
        self.bodies = bodies  # [(mass, com(theta) -> (x, y), inertia, angle(theta))]
        self.force, self.when = force, when
        self.smin = math.sqrt((l - r) ** 2 - e**2) + ox
        self.smax = math.sqrt((l + r) ** 2 - e**2) + ox

    def crank(self, th):
        psi = self.ratio * th
        return self.ox + self.r * np.cos(psi), self.r * np.sin(psi), psi

    def slider(self, th):
        ax, ay, _ = self.crank(th)
        return ax + np.sqrt(self.l**2 - (self.e - ay) ** 2)

    def rod_angle(self, th):
        ax, ay, _ = self.crank(th)
        return np.arctan2(self.e - ay, self.slider(th) - ax)

    @staticmethod
    def d(f, th, h=1e-3):
        return (f(th - 2 * h) - 8 * f(th - h) + 8 * f(th + h) - f(th + 2 * h)) / (12 * h)

    @staticmethod
    def dd(f, th, h=1e-3):
        return (-f(th - 2 * h) + 16 * f(th - h) - 30 * f(th) + 16 * f(th + h) - f(th + 2 * h)) / (
            12 * h * h
        )

    def inertia_terms(self, th):
        """J(theta), J'(theta) and V'(theta) (gravity along -y)."""
        J = np.zeros_like(th)
        dJ = np.zeros_like(th)
        dV = np.zeros_like(th)
        for m, com, inertia, angle in self.bodies:
            for k in (0, 1):

                def c(t, k=k, com=com):
                    return com(t)[k]

                v, a = self.d(c, th), self.dd(c, th)
                J += m * v * v
                dJ += 2 * m * v * a
                if k == 1:
                    dV += m * G * v
            if inertia:
                w, al = self.d(angle, th), self.dd(angle, th)
                J += inertia * w * w
                dJ += 2 * inertia * w * al
        return J, dJ, dV

    def stroke(self, th):
        return (self.slider(th) - self.smin) / (self.smax - self.smin)

    def acting(self, th):
        vx = self.d(self.slider, th)
        return self.when(vx, self.stroke(th))

    def torque(self, th, omega):
        th = np.asarray(th, float)
        J, dJ, dV = self.inertia_terms(th)
        Q = np.where(self.acting(th), self.force * self.d(self.slider, th), 0.0)
        return 0.5 * dJ * omega**2 + dV - Q

    def switches(self, span, lines):
        """Where the load switches over [0, span]: the roots of each function in
        ``lines`` (of theta), bracketed on a fine grid."""
        x = np.linspace(0.0, span, 7201)
        out = []
        for f in lines:
            v = f(x)
            for i in np.flatnonzero(v[:-1] * v[1:] < 0):
                out.append(brentq(f, x[i], x[i + 1], xtol=1e-15))
        return sorted(out)

    def flywheel(self, span, omega, delta, lines):
        """(M, dE_max, J_mean, J_F): the energy method over the cycle ``span``."""
        brk = np.unique(np.r_[np.linspace(0.0, span, 40001), self.switches(span, lines)])
        xg, wg = np.polynomial.legendre.leggauss(8)
        a, b = brk[:-1], brk[1:]
        mid, half = 0.5 * (a + b), 0.5 * (b - a)
        pts = mid[:, None] + half[:, None] * xg[None, :]
        T = self.torque(pts.ravel(), omega).reshape(pts.shape)
        W = np.r_[0.0, np.cumsum(half * (T @ wg))]
        M = W[-1] / span
        ex = M * brk - W

        def refined(i):  # the running integral's extreme, where T = M
            best = ex[i]
            for lo, hi in ((brk[max(i - 1, 0)], brk[i]), (brk[i], brk[min(i + 1, len(brk) - 1)])):
                if hi <= lo:
                    continue
                f = lambda t: M - float(self.torque(np.array([t]), omega)[0])  # noqa: E731
                if f(lo) * f(hi) < 0:
                    t0 = brentq(f, lo, hi, xtol=1e-15)
                    h = 0.5 * (t0 - lo)
                    q = lo + h + h * xg
                    val = M * t0 - (W[np.searchsorted(brk, lo)] + h * self.torque(q, omega) @ wg)
                    best = max(best, val) if ex[i] == ex.max() else min(best, val)
            return best

        dE = refined(int(np.argmax(ex))) - refined(int(np.argmin(ex)))
        n = 20000
        Jm = float(np.mean(self.inertia_terms(np.arange(n) * span / n)[0]))
        return M, dE, Jm, dE / (omega**2 * delta) - Jm


def slider_crank_yaml() -> SliderCrank:
    """mechanisms/slider-crank.yaml: crank 50 mm (its centre of mass 5 mm behind O), rod
    200 mm (centre of mass 60 mm from A), piston on a line 10 mm above O; the gas (1500 N
    back) acts while the piston moves back beyond 0.3 of its stroke."""
    s = SliderCrank(
        r=0.05, l=0.2, e=0.01, ox=0.0, ratio=1.0, bodies=[], force=-1500.0,
        when=lambda vx, st: (vx < 0) & (st > 0.3),
    )  # fmt: skip

    def rod_at(frac):
        def com(t):
            ax, ay, _ = s.crank(t)
            return ax + frac * (s.slider(t) - ax), ay + frac * (s.e - ay)

        return com

    s.bodies = [
        (2.4, lambda t: (-0.1 * s.crank(t)[0], -0.1 * s.crank(t)[1]), 0.004, lambda t: t),
        (0.9, rod_at(0.06 / 0.2), 0.0045, s.rod_angle),
        (0.6, lambda t: (s.slider(t), s.e + 0 * t), 0.0, None),
    ]
    return s


def gear_train_yaml() -> SliderCrank:
    """mechanisms/gear-train.yaml: the pinion (20 teeth) drives the wheel (60) the other
    way, a third as fast; the wheel is a crank of 60 mm about (160, 0) mm, the rod 260 mm
    (a uniform bar, 1.5 kg), the ram 12 kg on y = 0; the cutting force (1200 N along +x)
    acts while the ram moves back between 0.1 and 0.9 of its stroke."""
    s = SliderCrank(
        r=0.06, l=0.26, e=0.0, ox=0.16, ratio=-1.0 / 3.0, bodies=[], force=1200.0,
        when=lambda vx, st: (vx < 0) & (st > 0.1) & (st < 0.9),
    )  # fmt: skip
    s.bodies = [
        (0.8, lambda t: (0 * t, 0 * t), 0.0006, lambda t: t),
        (6.0, lambda t: (0.16 + 0 * t, 0 * t), 0.045, lambda t: -t / 3),
        (
            1.5,
            lambda t: (0.5 * (s.crank(t)[0] + s.slider(t)), 0.5 * s.crank(t)[1]),
            1.5 * 0.26**2 / 12,
            s.rod_angle,
        ),
        (12.0, lambda t: (s.slider(t), 0 * t), 0.0, None),
    ]
    return s


# -- item 2: the cycle of a geared machine -------------------------------------------
def test_gear_train_cycle_is_three_pinion_turns():
    from mechsolve.analyses.dynamics.cycle import machine_cycle
    from mechsolve.core.sweep import Analysis

    cyc = machine_cycle(Analysis(api.load(MECH / "gear-train.yaml")))
    assert cyc.turns == 3  # 60 / 20 teeth
    assert cyc.sweep.u[-1] - cyc.sweep.u[0] == pytest.approx(6 * math.pi, abs=1e-12)
    cyc = machine_cycle(Analysis(api.load(MECH / "slider-crank.yaml")))
    assert cyc.turns == 1


def test_gear_train_flywheel_over_the_wheels_turn():
    gt = gear_train_yaml()
    omega = 300 * math.pi / 30
    lines = [
        lambda t: gt.d(gt.slider, t),  # the ram's dead centres
        lambda t: gt.stroke(t) - 0.1,
        lambda t: gt.stroke(t) - 0.9,
    ]
    M, dE, Jm, JF = gt.flywheel(6 * math.pi, omega, 1 / 40, lines)
    # the motor's torque is the cutting work per cycle over the cycle's 6 pi: the force
    # acts over 0.8 of the 120 mm stroke once per turn of the wheel
    assert M == pytest.approx(1200 * 0.8 * 0.120 / (6 * math.pi), rel=1e-9)
    fw = size_flywheel(api.load(MECH / "gear-train.yaml"), 1 / 40, check=False)
    assert fw.motor_torque == pytest.approx(M, rel=1e-6)
    assert fw.energy_max == pytest.approx(dE, rel=1e-6)  # 81.18 J
    assert fw.J_mean == pytest.approx(Jm, rel=1e-7)
    assert fw.J_flywheel == pytest.approx(JF, rel=1e-6)  # 3.29 kg m^2
    assert fw.phi[-1] - fw.phi[0] == pytest.approx(6 * math.pi)


def test_never_repeating_machine_is_refused():
    from mechsolve.analyses.dynamics import cycle
    from mechsolve.base.errors import InputError

    mech = api.load(MECH / "gear-train.yaml")
    saved = cycle.MAX_CYCLE_TURNS
    cycle.MAX_CYCLE_TURNS = 2  # the gear train needs 3
    try:
        with pytest.raises(InputError, match="within 2 turns of the driver"):
            size_flywheel(mech, 1 / 40, check=False)
    finally:
        cycle.MAX_CYCLE_TURNS = saved


# -- item 6: piecewise integration between the switch angles -----------------------------
def test_slider_crank_flywheel_across_the_gas_switch():
    sc = slider_crank_yaml()
    omega = 1500 * math.pi / 30
    lines = [lambda t: sc.d(sc.slider, t), lambda t: sc.stroke(t) - 0.3]
    M, dE, Jm, JF = sc.flywheel(2 * math.pi, omega, 1 / 40, lines)
    # the gas's work per turn: 1500 N over 0.7 of the stroke
    assert M == pytest.approx(-1500 * 0.7 * (sc.smax - sc.smin) / (2 * math.pi), rel=1e-9)
    fw = size_flywheel(api.load(MECH / "slider-crank.yaml"), 1 / 40, omega_mean=omega,
                       check=False)  # fmt: skip
    assert fw.motor_torque == pytest.approx(M, rel=1e-6)  # -16733.60 N*mm
    assert fw.energy_max == pytest.approx(dE, rel=1e-6)  # 66.83009 J
    assert fw.J_mean == pytest.approx(Jm, rel=1e-7)  # 0.006645617 kg m^2
    assert fw.J_flywheel == pytest.approx(JF, rel=1e-6)  # 0.1016952 kg m^2
