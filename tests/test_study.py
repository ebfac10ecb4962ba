"""mechsolve sweep's study: parameters, designs, and the table checked against the
crank-rocker's closed forms and against separate runs of each design's own file."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.analyses.study.designs import make_study
from mechsolve.analyses.study.execute import execute
from mechsolve.analyses.study.params import parse_keypath
from mechsolve.base.errors import InputError
from mechsolve.model.source import load_file

DATA = Path(__file__).parent / "data"
FOURBAR = DATA / "study_fourbar.yaml"
B, C = 105.6, 59.0  # coupler and rocker of the test file (mm)


def closed_form(a: float, d: float) -> dict[str, float]:
    """Crank-rocker figures from the triangle O2-B-O4 at the two limit positions (crank
    and coupler in line: |O2B| = b + a and b - a), written from the textbook, degrees."""
    b, c = B, C

    def acos_deg(x):
        return math.degrees(math.acos(x))

    # the rocker's angle at O4 between O4->O2 and O4->B at each limit position
    ext = acos_deg((c * c + d * d - (b + a) ** 2) / (2 * c * d))
    fold = acos_deg((c * c + d * d - (b - a) ** 2) / (2 * c * d))
    swing = ext - fold
    # crank angles at the limits: the line O2->B makes alpha with O2->O4
    al_ext = acos_deg((d * d + (a + b) ** 2 - c * c) / (2 * d * (a + b)))
    al_fold = acos_deg((d * d + (b - a) ** 2 - c * c) / (2 * d * (b - a)))
    phi = abs(al_fold - al_ext)
    k = (180 + phi) / (180 - phi)
    # transmission angle (coupler-rocker) extremes at crank angles 0 and 180 deg,
    # folded into [0, 90]
    mus = [acos_deg((b * b + c * c - (d - a) ** 2) / (2 * b * c))]
    mus.append(acos_deg((b * b + c * c - (d + a) ** 2) / (2 * b * c)))
    mu = min(min(m, 180 - m) for m in mus)
    return {"swing": swing, "K": k, "mu": mu}


def study_of(path=FOURBAR, options=(), **kw):
    return make_study(load_file(path), list(options), **kw)


def test_keypath_parsing():
    assert parse_keypath("links.crank.points.A[0]") == ("links", "crank", "points", "A", 0)
    assert parse_keypath("ground.O4[1]") == ("ground", "O4", 1)
    assert parse_keypath("links.jib.mass") == ("links", "jib", "mass")


def test_values_lists_ranges_units():
    st = study_of(
        options=[
            "links.crank.points.A[0]=20..30 mm:5",
            "ground.O4[0]=8.0, 8.75 cm",
        ]
    )
    a, d = st.params
    assert a.values == pytest.approx([20, 22.5, 25, 27.5, 30]) and a.unit == "mm"
    assert d.values == pytest.approx([8.0, 8.75]) and d.unit == "cm"
    assert d.nominal == pytest.approx(8.75)  # the file's 87.5 mm in the parameter's unit
    assert len(st) == 10 and st.design == "grid"
    # a bare number has the file's unit (mm)
    st = study_of(options=["links.crank.points.A[0]=20, 30"])
    assert st.params[0].unit == "mm"
    assert st.values(2) == [30, 80]  # the file's d values stay: (20, 80), (20, 87.5), (30, 80)
    mech = st.mechanism(2)
    assert mech.links[0].points["A"][0] == pytest.approx(0.030)


def test_one_at_a_time_and_random_designs():
    st = study_of(options=["ground.O4[0]=85, 90"], design="one-at-a-time")
    # the file's two parameters and the option's: 3 + 2 (A) ... one parameter varies per design
    assert all(len(d) == 1 for d in st.designs)
    assert len(st) == 3 + 2
    st = study_of(
        options=[
            "links.crank.points.A[0]=uniform(20, 30 mm)",
            "links.coupler.mass=normal(0.2, 0.01)",
        ],
        design="latin-hypercube",
        samples=40,
        seed=3,
    )
    a = np.array([st.values(k)[0] for k in range(len(st))])
    # Latin hypercube: one sample in each of the 40 equal strata of [20, 30]
    strata = np.floor((a - 20) / 10 * 40).astype(int)
    assert sorted(strata) == list(range(40))
    again = study_of(
        options=[
            "links.crank.points.A[0]=uniform(20, 30 mm)",
            "links.coupler.mass=normal(0.2, 0.01)",
        ],
        design="latin-hypercube",
        samples=40,
        seed=3,
    )
    assert again.designs == st.designs  # the same seed, the same designs


def test_grid_table_against_closed_form_and_separate_runs(tmp_path):
    st = study_of()  # the file's study: a = 20, 25, 30 mm x d = 80, 87.5 mm
    out = execute(st, jobs=1)
    assert not out.interrupted and len(out.rows) == 6
    text = FOURBAR.read_text()
    for row in out.rows:
        a = row["links.crank.points.A[0] [mm]"]
        d = row["ground.O4[0] [mm]"]
        cf = closed_form(a, d)
        assert row["status"] == "ok"
        assert row["rocker.swing [deg]"] == pytest.approx(cf["swing"], abs=1e-6)
        assert row["rocker.time_ratio [-]"] == pytest.approx(cf["K"], rel=1e-7)
        assert row["min(transmission_angle.B) [deg]"] == pytest.approx(cf["mu"], abs=1e-6)
        # the requirements' verdicts from the closed form
        assert row["req.transmission.pass [-]"] is (cf["mu"] >= 25)
        assert row["req.swing.pass [-]"] is (cf["swing"] >= 55)
        # a separate run of the design's own file, written here by editing the text
        own = text.replace("A: [26.5, 0]", f"A: [{a!r}, 0]").replace(
            "O4: [87.5, 0]", f"O4: [{d!r}, 0]"
        )
        path = tmp_path / "design.yaml"
        path.write_text(own)
        res = ms.run(path)
        lp = res.limit_positions()[0]
        assert row["rocker.swing [deg]"] == pytest.approx(math.degrees(lp.swing), rel=1e-12)
        e = res.driving_effort
        assert row["max(abs(input.torque)) (samples) [N*m]"] == pytest.approx(
            np.nanmax(np.abs(e)), rel=1e-12
        )
        assert row["cycle.work [J]"] == pytest.approx(res.work(), rel=1e-12, abs=1e-15)
        assert row["max(O4.F) (samples) [N]"] == pytest.approx(
            np.nanmax(res.reaction("O4")["F"]), rel=1e-12
        )


def test_invalid_design_is_a_row(tmp_path):
    st = study_of(options=["links.coupler.mass=0.2, -1 kg"], design="one-at-a-time")
    out = execute(st, jobs=1)
    bad = [r for r in out.rows if r["status"] != "ok"]
    assert len(bad) == 1 and bad[0]["links.coupler.mass [kg]"] == -1
    assert bad[0]["status"].startswith("invalid:")
    assert "links.coupler.mass" in bad[0]["status"]
    assert "study_fourbar.yaml:15" in bad[0]["status"]  # the line of the key in the file


def test_design_that_cannot_assemble_is_a_row():
    st = study_of(options=["ground.O4[0]=300"])  # |AO4| > b + c: the loop cannot close
    st.designs = st.designs[:1]
    out = execute(st, jobs=1)
    row = out.rows[0]
    assert row["status"].startswith("not assemblable") and row["assembles [-]"] is False


@pytest.mark.parametrize(
    "option, words",
    [
        (
            "links.cranck.points.A[0]=20..30 mm:3",
            ["no 'cranck'", "did you mean links.crank.points.A[0]"],
        ),
        ("links.crank.points.A[0]=20..30 mm:0", ["0 values", "count of 1 or more"]),
        ("links.crank.points.A[0]=20..30 mm", ["needs a count"]),
        ("links.crank.points.A[0]=20 kg, 30 kg", ["a length"]),
        ("links.coupler.mass=2 m", ["a mass"]),
        ("ground.O4=1, 2", ["not a single number", "ground.O4[0]"]),
        ("ground.O4[0]", ["KEYPATH=VALUES"]),
        ("links.crank.points.A[0]=normal(25 mm, 0 mm)", ["standard deviation must be positive"]),
    ],
)
def test_bad_parameters(option, words):
    with pytest.raises(InputError) as exc:
        study_of(options=[option])
    for w in words:
        assert w in str(exc.value)


def test_bad_study_section_names_its_line(tmp_path):
    text = FOURBAR.read_text().replace("ground.O4[0]: 80, 87.5 mm", "ground.O5[0]: 80, 87.5 mm")
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(InputError) as exc:
        study_of(path)
    msg = str(exc.value)
    assert "bad.yaml:" in msg and "study.parameters" in msg and "did you mean ground.O4[0]" in msg


def test_distribution_in_a_grid_is_refused():
    with pytest.raises(InputError, match="distribution"):
        study_of(options=["links.coupler.mass=uniform(0.1, 0.3 kg)"], design="grid")
