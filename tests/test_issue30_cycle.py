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
from scipy.integrate import solve_ivp
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
    assert fw.motor_torque == pytest.approx(M, rel=1e-9)
    assert fw.energy_max == pytest.approx(dE, rel=1e-9)  # 81.18 J
    assert fw.J_mean == pytest.approx(Jm, rel=1e-9)
    assert fw.J_flywheel == pytest.approx(JF, rel=1e-9)  # 3.29 kg m^2
    assert fw.phi[-1] - fw.phi[0] == pytest.approx(6 * math.pi)


def test_never_repeating_machine_is_refused():
    from mechsolve.analyses.dynamics import cycle
    from mechsolve.base.errors import InputError

    mech = api.load(MECH / "gear-train.yaml")
    saved = cycle.MAX_CYCLE_TURNS
    cycle.MAX_CYCLE_TURNS = 2  # the gear train needs 3
    try:
        with pytest.raises(InputError, match="within 2 turns of the driver") as err:
            size_flywheel(mech, 1 / 40, check=False)
        assert "gear-train.yaml:43: driver" in str(err.value)  # where the file says it
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
    assert fw.motor_torque == pytest.approx(M, rel=1e-9)  # -16733.60 N*mm
    assert fw.energy_max == pytest.approx(dE, rel=1e-9)  # 66.83009 J
    assert fw.J_mean == pytest.approx(Jm, rel=1e-9)  # 0.006645617 kg m^2
    assert fw.J_flywheel == pytest.approx(JF, rel=1e-9)  # 0.1016952 kg m^2


def _gear_train_motor(tmp_path, formulation: str) -> Path:
    """gear-train.yaml with a motor, started at its speed: the ram's strokes over half a
    turn of the wheel, simulated on the reduced or the multibody path."""
    text = (MECH / "gear-train.yaml").read_text()
    text += (
        "motor: {stall: 40 N m, slope: 0.1 N m s}\n"
        "simulate: {duration: 0.36 s, step: 0.003 s, method: rk4, from: 300 rpm, "
        f"formulation: {formulation}}}\n"
    )
    path = tmp_path / f"gt_{formulation}.yaml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("formulation", ["reduced", "multibody"])
def test_gear_train_simulation_cuts_over_the_wheels_stroke(tmp_path, formulation):
    """stroke(B.x) means the ram's stroke over the cycle, 360 to 480 mm (the wheel's
    crank 60 mm, the rod 260 mm, the guide through the wheel's centre): the cutting force
    acts exactly while the ram moves back between 372 and 468 mm (over one pinion turn
    the ram reached only part of its stroke: it cut from 394.6 to 469.5 mm)."""
    from mechsolve.analyses.dynamics import simulate

    res = simulate(api.load(_gear_train_motor(tmp_path, formulation)))
    cols = {c.name: c.values for c in res.columns()}
    bx, vx = cols["B.x"], cols["B.vx"]
    active = res.forces.active["cutting"]
    stroke = (bx - 0.360) / 0.120
    clear = (np.abs(stroke - 0.1) > 1e-6) & (np.abs(stroke - 0.9) > 1e-6) & (np.abs(vx) > 1e-9)
    expected = (vx < 0) & (stroke > 0.1) & (stroke < 0.9)
    assert np.array_equal(active[clear], expected[clear])
    assert expected[clear].any() and (~expected[clear]).any()
    assert bx[active].min() < 0.380 and bx[active].max() > 0.460  # the whole working stroke


# -- item 7: the reduced path's adaptive integrator across the load's switches --------------
def _engine_ode(t_end: float, ts: np.ndarray) -> np.ndarray:
    """The slider-crank engine of mechanisms/slider-crank.yaml under a motor
    M = 200 N m - 1 N m s * omega from rest, by its equation of motion in closed form
    (velocity and acceleration of every centre of mass by the chain rule), the gas on
    between the outer dead centre and 0.3 of the stroke back, integrated from switch to
    switch (terminal events, a smooth equation between them): omega (rad/s) at ``ts``."""
    r, l, e = 0.05, 0.2, 0.01
    m1, m2, m3, J1, J2 = 2.4, 0.9, 0.6, 0.004, 0.0045
    smin, smax = math.sqrt((l - r) ** 2 - e**2), math.sqrt((l + r) ** 2 - e**2)

    def slider(th):
        return r * math.cos(th) + math.sqrt(l * l - (e - r * math.sin(th)) ** 2)

    on = math.asin(e / (l + r))  # the outer dead centre: the piston turns back
    off = brentq(lambda th: (slider(th) - smin) / (smax - smin) - 0.3, 0.5, 3.0, xtol=1e-15)

    def effort(th, w, al, gas):
        A = r * np.array([np.cos(th), np.sin(th)])
        phi = np.arcsin((e - r * np.sin(th)) / l)
        dphi1 = -r * np.cos(th) / (l * np.cos(phi))
        dphi = dphi1 * w
        ddphi = (r * np.sin(th) * w**2 - r * np.cos(th) * al + l * np.sin(phi) * dphi**2) / (
            l * np.cos(phi)
        )
        aA = -r * w**2 * A / r + r * al * np.array([-np.sin(th), np.cos(th)])
        u = np.array([np.cos(phi), np.sin(phi)])
        n = np.array([-np.sin(phi), np.cos(phi)])
        aC = aA + l * ddphi * n - l * dphi**2 * u
        aG = aA + 0.06 * ddphi * n - 0.06 * dphi**2 * u
        dA = r * np.array([-np.sin(th), np.cos(th)])
        dC, dG = dA + l * dphi1 * n, dA + 0.06 * dphi1 * n
        g = np.array([0.0, G])
        q = m1 * (-0.1 * aA + g) @ (-0.1 * dA) + J1 * al + m2 * (aG + g) @ dG
        q += J2 * ddphi * dphi1 + m3 * (aC + g) @ dC
        return q + (1500 * dC[0] if gas else 0.0)

    def rhs(t, y, gas):
        q0 = effort(y[0], y[1], 0.0, gas)
        return [y[1], (200 - y[1] - q0) / (effort(y[0], y[1], 1.0, gas) - q0)]

    def crossing(a):
        f = lambda t, y, gas: math.sin((y[0] - a) / 2)  # noqa: E731
        f.terminal = True
        return f

    out = {}
    t0, y0 = 0.0, np.array([0.0, 0.0])
    while t0 < t_end:
        gas = on < (y0[0] + 1e-9) % (2 * math.pi) < off
        events = [crossing(on), crossing(off)]
        s = solve_ivp(rhs, (t0, t_end), y0, args=(gas,), method="DOP853", rtol=1e-13,
                      atol=1e-15, events=events, dense_output=True)  # fmt: skip
        for i, t in enumerate(ts):
            if t0 <= t <= s.t[-1] and i not in out:
                out[i] = s.sol(t)[1]
        if s.status != 1:
            break
        t0, y0 = s.t[-1], s.y[:, -1].copy()
        y0[0] += 1e-12  # past the switch
    return np.array([out[i] for i in range(len(ts))])


def test_reduced_adaptive_simulation_meets_its_tolerance_across_switches(tmp_path):
    from mechsolve.analyses.dynamics import simulate

    path = tmp_path / "engine.yaml"
    path.write_text(
        (MECH / "slider-crank.yaml").read_text() + "motor: {stall: 200 N m, slope: 1 N m s}\n"
        "simulate: {duration: 0.3 s, step: 0.01 s, method: DOP853, rtol: 1e-12, "
        "atol: 1e-14, from: rest, formulation: reduced}\n"
    )
    res = simulate(api.load(path))
    tr = res.trajectory
    exact = _engine_ode(0.3, tr.t)
    # ten turns and twenty switches of the gas: omega at 0.3 s was 2.2e-8 off (a step
    # across a switch); the table of the equation of motion is good to about 1e-11
    assert tr.t[-1] == pytest.approx(0.3)
    rel = np.abs(tr.omega[1:] - exact[1:]) / np.abs(exact[1:])
    assert rel.max() < 3e-10


def test_fluctuation_over_the_machines_cycle():
    """A speed that fluctuates once per three turns of the driver, omega = w (1 + a
    sin(phi / 3)): over the cycle delta = (max - min) / mean = 2 a (to O(a^2)); the last
    revolution alone sees only part of it."""
    from mechsolve.analyses.dynamics import Trajectory, steady_fluctuation

    w, a = 10.0, 0.01
    phi = np.linspace(0.0, 12 * math.pi, 200001)
    omega = w * (1 + a * np.sin(phi / 3))
    # time along the motion: dt = dphi / omega (exact for this closed form, by quadrature)
    t = np.r_[0.0, np.cumsum(np.diff(phi) * 0.5 * (1 / omega[1:] + 1 / omega[:-1]))]
    tr = Trajectory(t, phi, omega, np.zeros_like(t), np.ones_like(t))
    mean, delta = steady_fluctuation(tr, 3)
    assert delta == pytest.approx(2 * a * w / mean, rel=1e-6)
    assert mean == pytest.approx(w * math.sqrt(1 - a * a), rel=1e-6)  # 2 pi / the period
    assert steady_fluctuation(tr, 1)[1] < 0.9 * delta
