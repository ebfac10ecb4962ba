"""Issue 30 (API input): a model edited in code after it was loaded or solved is checked
again, the arguments of ``solve`` are checked as the command line checks them, and the
Results' accessors answer a user's mistake with an InputError, not an internal exception."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.model import validate as validate_module

from conftest import MECH

FOURBAR = MECH / "fourbar.yaml"


# -- 1. a loaded or once-solved model edited in code is validated again ----------------


def _negative_mass(m):
    m.links[1].mass = -1.0


def _negative_step(m):
    m.sweep.step = -0.1


def _zero_step(m):
    m.sweep.step = 0.0


def _misspelt_link(m):
    m.joints[1].b = "couplr"


def _unknown_driver_joint(m):
    m.driver = dataclasses.replace(m.driver, joint="Z")


def _point_far_away(m):
    m.links[0].points["A"] = (1e9, 0.0)


EDITS = [
    (_negative_mass, r"mass: mass must be zero or positive, got -1"),
    (_negative_step, r"step: the step must be positive"),
    (_zero_step, r"step: the step must be positive"),
    (_misspelt_link, r"couplr"),
    (_unknown_driver_joint, r"the driver names the joint 'Z', which does not exist"),
    (_point_far_away, r"points\.A"),
]


@pytest.mark.parametrize("solved_first", [False, True])
@pytest.mark.parametrize(("edit", "message"), EDITS, ids=[e[0].__name__ for e in EDITS])
def test_an_edited_model_is_validated_again(edit, message, solved_first):
    """The file reader refuses each of these edits; made in code on a loaded model (or on
    one solved before, whose analysis is kept) they give the same InputError naming the
    key, not a silent result (a negative mass flips the driving torque's sign, a negative
    step gives one position) or a ZeroDivisionError / KeyError."""
    m = ms.load(FOURBAR)
    if solved_first:
        ms.solve(m)
    edit(m)
    with pytest.raises(ms.InputError, match=message):
        ms.solve(m)
    with pytest.raises(ms.InputError, match=message):
        ms.check(m)


def test_stream_validates_an_edited_model(tmp_path):
    m = ms.load(FOURBAR)
    m.sweep.step = 0.0
    with pytest.raises(ms.InputError, match="step must be positive"):
        ms.stream(m, tmp_path / "out.csv")


def test_a_valid_edit_is_solved_and_an_unchanged_model_not_checked_again(monkeypatch):
    """A valid edit gives the new sweep: 10 degree steps over a turn are 36 intervals;
    solving the same content again does not run the checks again (they cost about as much
    as building the analysis)."""
    calls = []
    real = validate_module.validate
    monkeypatch.setattr(validate_module, "validate", lambda m: (calls.append(1), real(m)))
    m = ms.load(FOURBAR)
    n0 = len(calls)
    ms.solve(m)
    ms.solve(m)
    assert len(calls) == n0  # loaded (validated) and unchanged: not checked again
    m.sweep.step = math.radians(10)
    res = ms.solve(m)
    assert len(res) == 37 and len(calls) == n0 + 1
    np.testing.assert_allclose(np.diff(res.u), math.radians(10), rtol=1e-12)
    ms.solve(m)
    assert len(calls) == n0 + 1


# -- 2. solve's step and method are checked as the command line checks them -----------


@pytest.mark.parametrize(
    "step", [-math.radians(2), 0.0, float("inf"), float("nan"), -0.0, True, [1.0]]
)
def test_solve_refuses_a_step_that_is_not_positive(step):
    """The CLI's --step refuses these (exit 2); solve gave one position (negative,
    infinite), a ZeroDivisionError (0) or a message about 'nan positions'."""
    m = ms.load(FOURBAR)
    with pytest.raises(ms.InputError, match=r"step=.*(positive|number)"):
        ms.solve(m, step=step)


@pytest.mark.parametrize(
    ("text", "step_deg"), [("2 deg", 2.0), ("3", 3.0), ("0.5 s", math.degrees(0.5))]
)
def test_solve_takes_a_step_as_the_command_line_writes_it(text, step_deg):
    """A text step is read as --step reads it: an angle (degrees when bare), or a time at
    the driver's 1 rad/s (0.5 s is 0.5 rad); the sweep is then 360 deg / step intervals."""
    res = ms.solve(ms.load(FOURBAR), step=text)
    d = np.diff(res.u)
    np.testing.assert_allclose(d[:-1], math.radians(step_deg), rtol=1e-12)
    assert len(res) == math.ceil(360 / step_deg - 1e-9) + 1


def test_solve_refuses_a_text_step_of_the_wrong_kind():
    with pytest.raises(ms.InputError, match=r"step='2 mm'.*an angle"):
        ms.solve(ms.load(FOURBAR), step="2 mm")
    with pytest.raises(ms.InputError, match=r"step='-2 deg'.*positive"):
        ms.solve(ms.load(FOURBAR), step="-2 deg")


@pytest.mark.parametrize("method", ["foo", "Newton", 3])
def test_solve_and_check_refuse_an_unknown_method(method):
    m = ms.load(FOURBAR)
    with pytest.raises(ms.InputError, match=r"method=.*'auto', 'newton', 'split-newton'"):
        ms.solve(m, method=method)
    with pytest.raises(ms.InputError, match=r"method=.*'auto', 'newton', 'split-newton'"):
        ms.check(m, method=method)


def test_a_model_built_with_an_unknown_solver_method_is_refused():
    m = ms.load(FOURBAR)
    m.solver.method = "foo"
    with pytest.raises(ms.InputError, match=r"solver\.method.*'foo'"):
        ms.solve(m)


def test_stream_refuses_a_negative_step(tmp_path):
    with pytest.raises(ms.InputError, match=r"step=.*positive"):
        ms.stream(ms.load(FOURBAR), tmp_path / "s.csv", step=-0.1)


# -- 3. a motion law swept over driver positions takes the step override --------------

ACCELERATE = FOURBAR.read_text().replace(
    "driver: {joint: O2, speed: 1 rad/s, start: 0 deg}",
    "driver: {joint: O2, start: 20 deg, motion: {accelerate: 4 rad/s^2, from: 1.5 rad/s}}",
)
LAW_IN_TIME = FOURBAR.read_text().replace(
    "driver: {joint: O2, speed: 1 rad/s, start: 0 deg}",
    'driver: {joint: O2, motion: {law: "0.3 + 2 * t + 0.5 * sin(3 * t)"}}',
)


def _accelerating(sweep: str):
    text = ACCELERATE.replace("sweep: {range: 360 deg, step: 2 deg}", sweep)
    assert "accelerate" in text and sweep in text
    return text


@pytest.mark.parametrize("step", [math.radians(1), "1 deg"])
def test_a_law_swept_over_positions_takes_the_step(step):
    """Constant acceleration from 1.5 rad/s at 4 rad/s^2 over 90 deg: 1 deg steps are 91
    positions (not the file's 19), each at the time the closed form gives,
    t = (sqrt(w0^2 + 2 a (u - u0)) - w0) / a."""
    m = ms.loads(_accelerating("sweep: {range: 90 deg, step: 5 deg}"))
    assert len(ms.solve(m)) == 19
    res = ms.solve(m, step=step)
    assert len(res) == 91
    du = res.u - math.radians(20)
    np.testing.assert_allclose(du, np.radians(np.arange(91.0)), atol=1e-12)
    t = (np.sqrt(1.5**2 + 2 * 4 * du) - 1.5) / 4
    np.testing.assert_allclose(res.t, t, atol=1e-12)
    np.testing.assert_allclose(res.link("crank").omega, 1.5 + 4 * t, rtol=1e-10)


def test_the_cli_takes_the_step_of_a_law_swept_over_positions(tmp_path):
    from click.testing import CliRunner

    from mechsolve.cli.main import main

    path = tmp_path / "acc.yaml"
    path.write_text(_accelerating("sweep: {range: 90 deg, step: 5 deg}"), encoding="utf-8")
    out = tmp_path / "out"
    r = CliRunner().invoke(
        main, ["run", str(path), "--step", "1 deg", "-o", str(out), "--no-plots", "-q"]
    )
    assert r.exit_code == 0, r.output
    rows = (out / "results.csv").read_text(encoding="utf-8").strip().splitlines()
    assert len(rows) == 1 + 91


def test_a_law_in_time_refuses_a_negative_time_step():
    """In time (duration 2 s) a step of -0.05 s gave one position; 0.1 s gives 21."""
    m = ms.loads(
        LAW_IN_TIME.replace(
            "sweep: {range: 360 deg, step: 2 deg}", "sweep: {duration: 2 s, time_step: 0.05 s}"
        )
    )
    assert len(ms.solve(m)) == 41
    res = ms.solve(m, step=0.1)
    np.testing.assert_allclose(res.t, np.arange(21) * 0.1, atol=1e-12)
    t = res.t
    np.testing.assert_allclose(res.u, 0.3 + 2 * t + 0.5 * np.sin(3 * t), atol=1e-12)
    with pytest.raises(ms.InputError, match=r"step=.*positive"):
        ms.solve(m, step=-0.05)


# -- 4. reaction() returns the caller's own arrays -------------------------------------


def _column(path, header):
    import csv

    with open(path, encoding="utf-8", newline="") as fh:
        rows = list(csv.reader(fh))
    j = rows[0].index(header)
    return np.array([float(r[j]) if r[j] else np.nan for r in rows[1:]])


def test_editing_a_reaction_in_place_leaves_the_results_alone(tmp_path):
    """A user converting to mN (``Fx *= 1000``) changed the CSV and the summary written
    afterwards. The CSV's reactions must still balance the crank (a uniform bar O2-A of
    0.05 kg, gravity along y only, no load on it): Newton along x,
    O2.Fx - A.Fx = m a_Gx with a_G = a_A / 2."""
    res = ms.run(FOURBAR)
    r = res.reaction("A")
    peak = float(np.nanmax(r["F"]))
    r["Fx"] *= 1000
    r["F"][:] = 0.0
    res.reaction("O2")["Fx"][:] = np.nan
    path = res.to_csv(tmp_path / "r.csv")
    fa = _column(path, "A(crank->coupler).Fx [N]")
    fo = _column(path, "O2(ground->crank).Fx [N]")
    ax = _column(path, "A.ax [m/s^2]")
    np.testing.assert_allclose(fo - fa, 0.05 * ax / 2, atol=1e-12)
    assert float(np.nanmax(res.reaction("A")["F"])) == peak
    line = next(ln for ln in res.summary().splitlines() if "peak reactions" in ln)
    assert f"A {peak:.4g} N" in line


# -- 5. a user's mistake through the Results is an InputError -------------------------

NO_MASS = "\n".join(
    ln
    for ln in FOURBAR.read_text().splitlines()
    if not ln.strip().startswith(("mass:", "uniform_bar:", "gravity:"))
).split("\nloads:")[0]


@pytest.mark.parametrize(
    ("ask", "message"),
    [
        (lambda r: r.reaction("Q"), r"no joint named 'Q'"),
        (lambda r: r.point("Z"), r"no point named 'Z'"),
        (lambda r: r.link("crank2"), r"no link named 'crank2'"),
        (lambda r: r.slider("s"), r"no slider named 's'"),
        (lambda r: r.relative("crank", "Z"), r"no link named 'Z'"),
    ],
)
def test_an_unknown_name_is_an_input_error_and_still_a_key_error(ask, message):
    res = ms.run(FOURBAR)
    with pytest.raises(ms.InputError, match=message):
        ask(res)
    with pytest.raises(KeyError):  # callers that catch KeyError keep working
        ask(res)


def test_reaction_at_checks_its_arguments():
    """``near`` outside the sweep was an IndexError and a scalar x a TypeError. A scalar
    is a driver value like any other: the reaction there equals the sampled one when it
    is a sample's driver value."""
    res = ms.run(FOURBAR)
    with pytest.raises(ms.InputError, match=r"near=1000.*0 \.\. 180"):
        res.reaction_at("A", np.array([0.1]), 1000)
    with pytest.raises(ms.InputError, match=r"no joint named 'Q'"):
        res.reaction_at("Q", np.array([0.1]), 0)
    k = 17
    one = res.reaction_at("A", float(res.u[k]), k)
    assert one["Fx"].shape == (1,)
    np.testing.assert_allclose(one["Fx"][0], res.reaction("A")["Fx"][k], rtol=1e-9, atol=1e-12)


def test_to_csv_takes_units_as_the_command_line_writes_them(tmp_path):
    """``units`` may be what --units takes; a length in mm is the SI column times 1000."""
    res = ms.run(FOURBAR)
    si = res.to_csv(tmp_path / "si.csv")
    mm = res.to_csv(tmp_path / "mm.csv", units="length=mm")
    np.testing.assert_allclose(
        _column(mm, "A.x [mm]"), 1000 * _column(si, "A.x [m]"), rtol=1e-9, atol=1e-9
    )
    with pytest.raises(ms.InputError, match=r"units='mm'.*KEY=UNIT"):
        res.to_csv(tmp_path / "bad.csv", units="mm")
    with pytest.raises(ms.InputError, match=r"units=3"):
        res.to_csv(tmp_path / "bad.csv", units=3)
    assert not (tmp_path / "bad.csv").exists()


@pytest.mark.parametrize("entry", ["solve", "check"])
def test_solve_given_a_path_says_to_load_it(entry):
    with pytest.raises(ms.InputError, match=r"ms\.load\(path\)"):
        getattr(ms, entry)(str(FOURBAR))


def test_a_model_without_force_analysis_says_so():
    """Without masses or loads no force analysis runs (the command line prints no torque,
    no work): every force figure gives the one InputError, also still a KeyError where
    driving_effort's KeyError was; with forces=True the figures are there and are zero
    (no mass, no load, no friction: no force anywhere)."""
    m = ms.loads(NO_MASS)
    assert not m.needs_forces
    res = ms.solve(m)
    asks = [
        lambda: res.work(),
        lambda: res.mean_effort(),
        lambda: res.efficiency,
        lambda: res.driving_effort,
        lambda: res.reaction("A"),
        lambda: res.reaction_at("A", np.array([0.1]), 0),
    ]
    for ask in asks:
        with pytest.raises(ms.InputError, match="no force analysis was run"):
            ask()
    with pytest.raises(KeyError):
        _ = res.driving_effort
    forced = ms.solve(m, forces=True)
    assert forced.work() == 0.0
    np.testing.assert_array_equal(forced.driving_effort, 0.0)
    np.testing.assert_array_equal(forced.reaction_at("A", np.array([0.1]), 0)["F"], 0.0)
