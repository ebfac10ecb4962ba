"""The fast paths against the slow generic ones and against closed forms.

The closed-form Assur groups (``method: auto``), Newton-Raphson per group
(``split-newton``) and on the whole system (``newton``, batched and sequential) must give
the same sweep; the benchmark's hand-written references (``mechsolve_bench.references``,
written independently of the solver) must agree with the fast path to the accuracy the
benchmark reports: positions within 1e-12 relative, velocities and accelerations within
1e-10, forces within 1e-9. No timings here: ``mechsolve bench`` measures those.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.core.sweep import Analysis
from mechsolve_bench import _crane_mech, chain_yaml, fourbar_yaml, wrap
from mechsolve_bench import references as R

from conftest import MECH

FILES = ["crane.yaml", "shaper.yaml", "sixbar.yaml", "fourbar.yaml", "slider-crank.yaml"]


def _rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b))) / (float(np.max(np.abs(b))) or 1.0)


def _kinematics(res):
    """Every reported point's and link's quantities, as (name, array) pairs."""
    out = []
    for p in res.point_names():
        k = res.point(p)
        out += [(f"{p}.x", k.x), (f"{p}.y", k.y), (f"{p}.vx", k.vx), (f"{p}.vy", k.vy)]
        out += [(f"{p}.ax", k.ax), (f"{p}.ay", k.ay)]
    for lk in res.link_names():
        q = res.link(lk)
        out += [(f"{lk}.w", q.omega), (f"{lk}.alpha", q.alpha)]
        out += [(f"{lk}.angle", q.angle)]
    return out


@pytest.mark.parametrize("name", FILES)
@pytest.mark.parametrize("method", ["split-newton", "newton"])
def test_generic_paths_agree_with_the_closed_forms(name, method):
    mech = ms.load(MECH / name)
    fast = ms.solve(mech)
    slow = ms.solve(mech, method=method)
    np.testing.assert_array_equal(fast.ok, slow.ok)
    assert set(fast.methods()) <= {"closed form", ""}
    ok = fast.ok
    pairs = list(zip(_kinematics(fast), _kinematics(slow)))
    # each quantity against the largest of its kind (a coordinate that stays at zero,
    # like a slider's vy, is compared with the other velocities' size)
    scale: dict[str, float] = {}
    for (label, a), _ in pairs:
        kind = label.split(".")[-1].rstrip("xy") or "position"
        scale[kind] = max(scale.get(kind, 0.0), float(np.max(np.abs(a[ok]))))
    for (label, a), (_, b) in pairs:
        kind = label.split(".")[-1].rstrip("xy") or "position"
        assert np.max(np.abs(b[ok] - a[ok])) <= 1e-9 * scale[kind], label
    if fast.forces is not None:
        f, s = fast.forces, slow.forces
        both = f.ok & s.ok
        assert _rel(s.effort[both], f.effort[both]) < 1e-8
        big = max(float(np.max(np.abs(c[both]))) for r in f.reactions.values() for c in r.values())
        for joint, comps in f.reactions.items():
            for comp, arr in comps.items():
                err = np.max(np.abs(s.reactions[joint][comp][both] - arr[both]))
                assert err <= 1e-8 * big, (joint, comp)


@pytest.mark.parametrize("batched", [True, False])
def test_newton_batched_and_sequential_agree_with_closed_form(batched):
    mech = ms.loads(fourbar_yaml(180))
    an = Analysis(mech, "newton")
    for g in an.plan:
        g.batched = batched
    u, _ = an.sweep_values(0.0)
    sol = an.solve(u, start=an.assemble(0.0))
    th3, th4, w3, w4, al3, al4 = R.fourbar_textbook(u)
    st = sol.state
    assert np.max(np.abs(wrap(st.th[1] - th3))) < 1e-12
    assert np.max(np.abs(wrap(st.th[2] - th4))) < 1e-12
    assert _rel(st.w[1], w3) < 1e-10 and _rel(st.w[2], w4) < 1e-10
    assert _rel(st.al[1], al3) < 1e-10 and _rel(st.al[2], al4) < 1e-10


def test_fourbar_against_the_benchmark_references():
    n = 3600
    res = ms.solve(ms.loads(fourbar_yaml(n)), forces=False)
    th2 = np.linspace(0, 2 * np.pi, n, endpoint=False)
    st = res.solution.state
    for want in (R.fourbar_textbook(th2), R.fourbar_vector(th2)):
        th3, th4, w3, w4, al3, al4 = want
        assert np.max(np.abs(wrap(st.th[1] - th3))) < 1e-12
        assert np.max(np.abs(wrap(st.th[2] - th4))) < 1e-12
        assert max(_rel(st.w[1], w3), _rel(st.w[2], w4)) < 1e-10
        assert max(_rel(st.al[1], al3), _rel(st.al[2], al4)) < 1e-10


def test_fourbar_forces_against_the_benchmark_free_bodies():
    n = 3600
    res = ms.solve(ms.loads(fourbar_yaml(n, masses=True)))
    Td, FO2, FA, FB, FO4 = R.fourbar_forces(np.linspace(0, 2 * np.pi, n, endpoint=False))
    assert _rel(res.driving_effort, Td) < 1e-9
    for joint, F in (("O2", FO2), ("A", FA), ("B", FB), ("O4", FO4)):
        r = res.reaction(joint)
        assert max(_rel(r["Fx"], F.real), _rel(r["Fy"], F.imag)) < 1e-9, joint


def test_crane_against_the_benchmark_references():
    n = 3600
    th1 = np.linspace(0, 2 * np.pi, n, endpoint=False)
    kin = ms.solve(_crane_mech(n, masses=False), forces=False)
    w = kin.mechanism.driver.speed
    want = R.crane_kinematics(th1, w)
    K = kin.point("K")
    assert max(_rel(K.x, want["K"].real), _rel(K.y, want["K"].imag)) < 1e-12
    assert max(_rel(K.vx, want["vK"].real), _rel(K.vy, want["vK"].imag)) < 1e-10
    assert max(_rel(K.ax, want["aK"].real), _rel(K.ay, want["aK"].imag)) < 1e-10
    res = ms.solve(_crane_mech(n, masses=True))
    Td, RO1, RO3, RO4 = R.crane_forces(th1, w)
    assert _rel(res.driving_effort, Td) < 1e-9
    for joint, F in (("O1", RO1), ("O3", RO3), ("O4", RO4)):
        r = res.reaction(joint)
        assert max(_rel(r["Fx"], F.real), _rel(r["Fy"], F.imag)) < 1e-9, joint


@pytest.mark.parametrize("loops", [1, 4, 25])
def test_chain_of_loops_closes_everywhere(loops):
    """The growth benchmark's chain: every loop closed, and the split-newton path agrees."""
    mech = ms.loads(chain_yaml(loops, 72))
    res = ms.solve(mech, forces=False)
    assert res.ok.all()
    assert np.nanmax(res.solution.residual) < 1e-12 * 4 * loops
    an = res.analysis
    assert len(an.plan) == loops + 1  # the driver link, then one RRR per loop
    slow = ms.solve(mech, method="split-newton", forces=False)
    last = an.system.nb - 1
    np.testing.assert_allclose(
        np.unwrap(slow.solution.state.th[last]), np.unwrap(res.solution.state.th[last]), atol=1e-9
    )


def test_lazy_start_equals_a_separate_assembly():
    """The start branches chosen inside the sweep are those of the separate assembly."""
    for name in FILES:
        mech = ms.load(MECH / name)
        an = Analysis(mech)
        u, _ = an.sweep_values(an.start_value())
        lazy = an.solve(u)
        sep = an.solve(u, start=an.assemble(float(u[0])))
        assert lazy.start.modes == sep.start.modes, name
        np.testing.assert_allclose(lazy.state.x, sep.state.x, atol=1e-12, equal_nan=True)
        assert math.isclose(lazy.start.u0, sep.start.u0)


def test_split_newton_from_the_file_and_the_command_line(tmp_path):
    from click.testing import CliRunner

    from mechsolve.cli.main import main

    text = fourbar_yaml(90).replace("outputs:", "solver: {method: split-newton}\noutputs:")
    mech = ms.loads(text)
    assert mech.solver.method == "split-newton"
    res = ms.solve(mech)
    assert all(m.startswith("newton") for m in res.methods())
    f = tmp_path / "fb.yaml"
    f.write_text(fourbar_yaml(90))
    out = CliRunner().invoke(
        main, ["run", str(f), "--method", "split-newton", "--no-plots", "-o", str(tmp_path)]
    )
    assert out.exit_code == 0, out.output
