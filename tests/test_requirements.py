"""Requirements in a mechanism file: figures against closed forms, pass and fail, units,
clear errors, exit code 5 and the JUnit report."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from click.testing import CliRunner

import mechsolve as ms
from mechsolve.base.errors import InputError
from mechsolve.cli.main import main
from mechsolve.results.requirements import check_requirements, evaluate_figure

from closed_form import fourbar
from conftest import MECH

A, B, C, D = 26.5e-3, 105.6e-3, 59e-3, 87.5e-3  # fourbar.yaml (m)
FOURBAR = (MECH / "fourbar.yaml").read_text()


def with_requirements(text: str, reqs: dict[str, str]) -> str:
    lines = "\n".join(f"  {k}: {v}" for k, v in reqs.items())
    return text + f"\nrequirements:\n{lines}\n"


def closed_form_figures():
    """Crank-rocker figures from the triangle at the limit positions (crank and coupler
    in line: |O2B| = b - a and b + a) and the transmission angle's extremes (the crank
    along the frame line): the textbook formulas, not mechsolve's."""
    folded, extended = B - A, B + A
    # rocker angle at O4 between the frame (O4 -> O2) and O4B, by the law of cosines
    psi1 = math.acos((D * D + C * C - folded**2) / (2 * D * C))
    psi2 = math.acos((D * D + C * C - extended**2) / (2 * D * C))
    swing = abs(psi1 - psi2)
    # crank angles at the limits: O2B's angle at O2 from the frame line
    al1 = math.acos((folded**2 + D * D - C * C) / (2 * folded * D))
    al2 = math.acos((extended**2 + D * D - C * C) / (2 * extended * D))
    theta = abs(al1 - al2)  # crank angle between the limit positions, less 180 deg
    K = (math.pi + theta) / (math.pi - theta)
    mu1 = math.acos((B * B + C * C - (D - A) ** 2) / (2 * B * C))
    mu2 = math.acos((B * B + C * C - (D + A) ** 2) / (2 * B * C))
    mu_min = min(mu1, math.pi - mu2)
    return swing, K, mu_min


def test_figures_against_the_closed_forms():
    mech = ms.loads(FOURBAR)
    res = ms.solve(mech)
    swing, K, mu_min = closed_form_figures()
    assert evaluate_figure("rocker.swing", mech, res) == pytest.approx(swing, abs=1e-9)
    assert evaluate_figure("time_ratio(rocker)", mech, res) == pytest.approx(K, abs=1e-7)
    # the exact minimum between the 2 deg samples, not the smallest sample
    assert evaluate_figure("min(transmission_angle.B)", mech, res) == pytest.approx(
        mu_min, abs=1e-9
    )
    # the rocker's angle between samples (31 deg: the sweep has 30 and 32), cubic
    th3, th4, *_ = fourbar(A, B, C, D, np.radians([0.0, 31.0]), 1.0, +1)
    th3x, th4x, *_ = fourbar(A, B, C, D, np.radians([0.0, 31.0]), 1.0, -1)
    start = evaluate_figure("at(rocker.angle, 0 deg)", mech, res)
    want = th4 if abs((th4[0] - start + math.pi) % (2 * math.pi) - math.pi) < 1e-6 else th4x
    got = evaluate_figure("at(rocker.angle, 31 deg)", mech, res)
    assert (got - want[1] + math.pi) % (2 * math.pi) - math.pi == pytest.approx(0, abs=2e-6)
    # mean, rms against the CSV's own column (sample statistics, as documented); range
    # from the extremes located between the samples (against the closed form in
    # test_issue23_requirements), so at least the samples' spread
    col = next(c for c in res.columns() if c.name == "P.y")
    assert col.unit == "m"
    y = np.asarray(col.values)
    assert np.ptp(y) < evaluate_figure("range(P.y)", mech, res) < np.ptp(y) * 1.001
    assert evaluate_figure("mean(P.y)", mech, res) == pytest.approx(y.mean(), rel=1e-12)
    assert evaluate_figure("rms(P.y)", mech, res) == pytest.approx(
        math.sqrt((y * y).mean()), rel=1e-12
    )


def test_pass_and_fail_with_units():
    swing, K, mu_min = closed_form_figures()
    lo, hi = math.degrees(mu_min) - 0.01, math.degrees(mu_min) + 0.01
    text = with_requirements(
        FOURBAR,
        {
            "transmission ok": f"min(transmission_angle.B) >= {lo} deg",
            "transmission too strict": f"min(transmission_angle.B) >= {hi} deg",
            "swing": f"{math.degrees(swing) - 0.001} deg <= rocker.swing",
            "quick return": f"time_ratio(rocker) >= {K + 1e-4}",
            "torque in N m": "max(abs(input.torque)) <= 0.5 N m",
            "closes": "full turn",
        },
    )
    mech = ms.loads(text)
    v = {x.name: x for x in check_requirements(mech, ms.solve(mech))}
    assert v["transmission ok"].passed and not v["transmission too strict"].passed
    assert v["swing"].passed and not v["quick return"].passed
    assert v["closes"].passed
    assert v["transmission ok"].unit == "deg"
    # the closed form's minimum is with the crank along the frame line, at 0 deg
    want = f"= {math.degrees(mu_min):.6g} deg (at driver angle 0°) >= {lo:.6g} deg: pass"
    assert want in v["transmission ok"].message
    msg = v["torque in N m"].message
    assert v["torque in N m"].unit == "N m" and "N m (at driver angle " in msg
    assert msg.endswith("<= 0.5 N m: pass")


def test_a_crank_that_cannot_turn_fails_full_turn(tmp_path):
    """With a 50 mm crank the four-bar is not Grashof (50 + 105.6 > 59 + 87.5): it cannot
    close over the whole turn; the run completes, says which requirement failed, exit 5.
    (The driving torque grows without bound towards the toggles where it stops closing,
    so a torque limit fails too: the passing requirement is on a position.)"""
    text = with_requirements(
        FOURBAR.replace("A: [26.5, 0]", "A: [50, 0]"),
        {"closes": "full turn", "small": "max(abs(P.y)) <= 1 m"},
    )
    f = tmp_path / "long.yaml"
    f.write_text(text)
    junit = tmp_path / "req.xml"
    r = CliRunner().invoke(
        main, ["run", str(f), "-o", str(tmp_path / "o"), "--no-plots", "--junit", str(junit)]
    )
    assert r.exit_code == 5, r.output
    assert "requirements: 1 of 2 pass, 1 FAIL" in r.output
    assert "FAIL  closes" in r.output and "PASS  small" in r.output
    suites = ET.parse(junit).getroot()
    assert suites.tag == "testsuites" and suites.get("failures") == "1"
    cases = {c.get("name"): c for c in suites.iter("testcase")}
    assert set(cases) == {"closes", "small"}
    fail = cases["closes"].find("failure")
    assert fail is not None and "assembles at" in fail.get("message")
    assert cases["small"].find("failure") is None


def test_exit_codes_zero_and_five_and_the_junit_values(tmp_path):
    ok = with_requirements(FOURBAR, {"swing": "rocker.swing >= 30 deg"})
    bad = with_requirements(FOURBAR, {"swing": "rocker.swing >= 70 deg"})
    for text, code in ((ok, 0), (bad, 5)):
        f = tmp_path / "m.yaml"
        f.write_text(text)
        x = tmp_path / "r.xml"
        r = CliRunner().invoke(
            main, ["run", str(f), "-o", str(tmp_path / "o"), "--no-plots", "--junit", str(x)]
        )
        assert r.exit_code == code, r.output
        case = next(ET.parse(x).getroot().iter("testcase"))
        if code:
            msg = case.find("failure").get("message")
            swing = math.degrees(closed_form_figures()[0])
            assert f"rocker.swing = {swing:.6g} deg >= 70 deg: FAIL" == msg


@pytest.mark.parametrize(
    ("req", "message"),
    [
        ("max(P.yy) <= 1 m", "no quantity 'P.yy' (did you mean P.y"),
        ("P.y <= 1 m", "reduce it to one number"),
        ("max(P.y)", "compares one figure with a limit"),
        ("1 m <= 2 m", "one side of the comparison must read the run"),
        ("max(P.y) <= 1 kg", "is a mass"),  # a limit of another kind (issue 23, 1.3)
        ("mean(P.y, P.x) <= 1 m", "takes 1 argument"),
    ],
)
def test_bad_requirements_name_the_line(tmp_path, req, message):
    f = tmp_path / "m.yaml"
    f.write_text(with_requirements(FOURBAR, {"bad one": req}))
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "o"), "--no-plots"])
    if not message:
        assert r.exit_code in (0, 5), r.output
        return
    assert r.exit_code == 2, r.output
    line = f.read_text().splitlines().index(f"  bad one: {req}") + 1
    assert f"m.yaml:{line}: requirements.bad one" in r.output and message in r.output
    assert "Traceback" not in r.output


def test_a_reduction_in_a_condition_is_refused():
    text = FOURBAR.replace("when: P.vx > 0", "when: P.vx > mean(P.vx)")
    with pytest.raises(InputError, match="belongs in 'requirements'"):
        ms.loads(text)
    # the element-wise max(a, b) is still a condition's function
    ms.loads(FOURBAR.replace("when: P.vx > 0", "when: max(P.vx, 0) > 0"))


def test_junit_without_requirements_is_an_input_error(tmp_path):
    r = CliRunner().invoke(
        main,
        ["run", str(MECH / "fourbar.yaml"), "-o", str(tmp_path), "--no-plots", "--junit", "x.xml"],
    )
    assert r.exit_code == 2 and "no 'requirements' section" in r.output


def test_exit_code_five_in_a_real_process(tmp_path):
    import subprocess
    import sys

    f = tmp_path / "m.yaml"
    f.write_text(with_requirements(FOURBAR, {"swing": "rocker.swing >= 70 deg"}))
    p = subprocess.run(
        [sys.executable, "-m", "mechsolve", "run", str(f), "-o", str(tmp_path / "o"), "-q"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode == 5, p.stderr
    assert "FAIL  swing" in p.stdout and (tmp_path / "o" / "results.csv").exists()


def test_a_figure_the_run_does_not_reach_fails_as_not_determined():
    """Over 30..90 deg of crank the rocker reaches neither limit position (they are at
    20.7 and 221.1 deg): its swing is not determined; the requirement fails and says so,
    while a misspelt name is still an input error."""
    part = FOURBAR.replace(
        "driver: {joint: O2, speed: 1 rad/s, start: 0 deg}",
        "driver: {joint: O2, speed: 1 rad/s, start: 30 deg}",
    ).replace("sweep: {range: 360 deg, step: 2 deg}", "sweep: {range: 60 deg, step: 2 deg}")
    mech = ms.loads(with_requirements(part, {"swing": "rocker.swing >= 10 deg"}))
    [v] = check_requirements(mech, ms.solve(mech))
    assert not v.passed and "not determined" in v.message
    bad = ms.loads(with_requirements(part, {"swing": "rockr.swing >= 10 deg"}))
    with pytest.raises(InputError, match="no quantity 'rockr.swing'"):
        check_requirements(bad, ms.solve(bad))
