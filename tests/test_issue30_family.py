"""A design family: one parsed file and the designs' values, solved as one batch without
parsing each design (mechsolve.analyses.study.family), against designs parsed one by one, the
four-bar's closed form, the parser's refusals and the study's rows before it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mechsolve.analyses.batch import _split, solve_designs
from mechsolve.analyses.study import execute as ex
from mechsolve.analyses.study import family as fam_mod
from mechsolve.analyses.study.designs import make_study
from mechsolve.analyses.study.family import DesignFamily, design_family, solve_family
from mechsolve.base.errors import InputError
from mechsolve.model.parse import from_source
from mechsolve.model.source import load_text

FOURBAR = """
name: family four-bar
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [87.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [26.5, 0]}, mass: 0.05 kg, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [105.6, 0], P: {length: 60, angle: 30}},
            mass: 0.2 kg, uniform_bar: [A, B]}
  rocker: {points: {O4: [0, 0], B: [59, 0]}, mass: 0.11 kg, uniform_bar: [O4, B]}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, speed: 1 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 10 deg}
gravity: 9.81 m/s^2
loads:
  pull: {force: [0, -2 N], at: P, when: P.vx > 0}
"""

KINEMATIC = FOURBAR.split("gravity:")[0].replace(", mass: 0.05 kg, uniform_bar: [O2, A]", "")
KINEMATIC = KINEMATIC.replace(",\n            mass: 0.2 kg, uniform_bar: [A, B]", "")
KINEMATIC = KINEMATIC.replace(", mass: 0.11 kg, uniform_bar: [O4, B]", "")


def _parsed(text: str, values: dict[str, list], units: dict[str, str]) -> list:
    """Each design written into the file's text and parsed through the public API."""
    import yaml

    n = len(next(iter(values.values())))
    out = []
    for k in range(n):
        data = yaml.safe_load(text)
        for key, vals in values.items():
            node = data
            parts = key.replace("[", ".").replace("]", "").split(".")
            for part in parts[:-1]:
                node = node[int(part)] if part.isdigit() else node[part]
            node[int(parts[-1])] = f"{float(vals[k]):.12g} {units[key]}"
        try:
            out.append(from_source(load_text(yaml.safe_dump(data, sort_keys=False), "family.yaml")))
        except InputError as exc:
            out.append(exc)
    return out


VALUES = {
    "links.crank.points.A[0]": [2.0, 2.25, 2.5, 2.65, 3.0, -0.0 + 2.4],
    "links.coupler.points.B[0]": [100.0, 104.0, 106.0, 108.0, 110.0, 105.6],
    "ground.O4[1]": [0.0, -0.0, 3.0, -2.5, 1.0, 0.5],
}
UNITS = {"links.crank.points.A[0]": "cm", "links.coupler.points.B[0]": "mm", "ground.O4[1]": "mm"}


def test_family_numbers_and_results_are_those_of_designs_parsed_one_by_one():
    base = from_source(load_text(FOURBAR, "family.yaml"))
    fam = design_family(base, VALUES, UNITS)
    parsed = _parsed(FOURBAR, VALUES, UNITS)
    fam.prepare()
    assert fam.why_not is None and not fam.invalid
    # the stacked numbers: the same bits as the parser's (cm converted as it converts,
    # a -0.0 kept, the bars' centres and inertias by its formulas)
    X = np.array([_split(m)[1] for m in parsed])
    assert np.array_equal(X.view(np.int64), fam.rows.view(np.int64))
    for k, m in enumerate(parsed):
        got = fam.mechanism(k)
        assert got.ground == m.ground and got.links == m.links and got.joints == m.joints
    for forces in (None, False):
        acc = None if forces is None else False
        b1 = solve_family(fam, forces=forces, acceleration=acc)
        b2 = solve_designs(parsed, forces=forces, acceleration=acc)
        assert list(b1.batched) == list(b2.batched) and b1.batched.all()
        for k in range(len(parsed)):
            r1, r2 = b1.results(k), b2.results(k)
            assert np.array_equal(r1.solution.state.block, r2.solution.state.block)
            assert np.array_equal(r1.solution.indicator, r2.solution.indicator)
            if forces is None:
                assert np.array_equal(r1.forces.effort, r2.forces.effort)
                for j, r in r1.forces.reactions.items():
                    for c, v in r.items():
                        assert np.array_equal(v, r2.forces.reactions[j][c])


def test_family_against_the_vector_loop_per_design():
    """The rocker's angle and rate of each design by the vector loop and Freudenstein's
    rate equation, written here."""
    base = from_source(load_text(KINEMATIC, "kin.yaml"))
    a = np.array([20.0, 23.0, 26.5, 28.0])  # mm
    c = np.array([100.0, 104.0, 106.0, 110.0])
    fam = design_family(base, {"links.crank.points.A[0]": a, "links.coupler.points.B[0]": c})
    batch = solve_family(fam, acceleration=False)
    assert batch.batched.all()
    b, d = 0.059, 0.0875
    for k in range(len(a)):
        r = batch.results(k)
        th2 = r.link("crank").angle
        A = np.array([a[k] / 1e3 * np.cos(th2), a[k] / 1e3 * np.sin(th2)])
        O4 = np.array([d, 0.0])[:, None]
        e = O4 - A
        L = np.hypot(*e)
        # B left of A -> O4: the intersection of the circles about A (coupler) and O4
        cc = c[k] / 1e3
        x = (cc**2 - b**2 + L**2) / (2 * L)
        h = np.sqrt(cc**2 - x**2)
        u = e / L
        B = A + x * u + h * np.array([-u[1], u[0]])
        th4 = np.arctan2(B[1] - O4[1], B[0] - O4[0])
        th3 = np.arctan2(B[1] - A[1], B[0] - A[0])
        w4 = a[k] / 1e3 * np.sin(th2 - th3) / (b * np.sin(th4 - th3))  # omega2 = 1 rad/s
        got = r.link("rocker")
        assert np.max(np.abs(np.angle(np.exp(1j * (got.angle - th4))))) < 1e-12
        assert np.max(np.abs(got.omega - w4)) < 1e-11


def test_refused_design_has_the_parsers_message_and_row():
    base = from_source(load_text(FOURBAR, "family.yaml"))
    values = {"links.rocker.points.B[0]": [59.0, 0.0, 1e-12, 61.0], "ground.O4[0]": [87.5] * 4}
    units = {"links.rocker.points.B[0]": "mm", "ground.O4[0]": "mm"}
    fam = design_family(base, values, units)
    batch = solve_family(fam)
    parsed = _parsed(FOURBAR, values, units)
    # 1e-12 mm against a link of that size is not a coincidence for the parser either
    assert sorted(fam.invalid) == [k for k, m in enumerate(parsed) if isinstance(m, InputError)]
    assert sorted(fam.invalid) == [1]
    for k in (1,):
        assert isinstance(parsed[k], InputError)
        # the same message (the line is the base file's, not the re-dumped text's)
        assert str(fam.invalid[k]).split(": ", 1)[1] == str(parsed[k]).split(": ", 1)[1]
        assert str(fam.invalid[k]).startswith("family.yaml:9: ")
        with pytest.raises(InputError, match="coincide"):
            batch.results(k)
    assert batch.batched[[0, 3]].all()
    # around the parser's coincidence test (distance <= 1e-9 x the link's largest point,
    # here P at 60 mm: B within 6e-8 mm of A): the family refuses exactly what it refuses
    near = [5.9e-8, 6e-8, 6.0000001e-8, 6.1e-8, 2.3e-7, 2.5e-7, 1.0]
    values = {"links.coupler.points.B[0]": near}
    fam = design_family(base, values, {"links.coupler.points.B[0]": "mm"})
    fam.prepare()
    parsed = _parsed(FOURBAR, values, {"links.coupler.points.B[0]": "mm"})
    refused = [k for k, m in enumerate(parsed) if isinstance(m, InputError)]
    assert 0 < len(refused) < len(near)
    assert sorted(fam.invalid) == refused
    # a value out of the parser's range: refused with its message
    fam = design_family(base, {"ground.O4[0]": [87.5, 1e30, 90.0]})
    fam.prepare()
    assert list(fam.invalid) == [1] and "too large" in str(fam.invalid[1])


def _rows(study, monkeypatch=None, old=False):
    if old:
        monkeypatch.setattr(ex, "study_family", lambda study, indices: None)
    out = ex.execute(study, jobs=1).rows
    if old:
        monkeypatch.undo()
    return out


def _same_rows(r1, r2):
    assert len(r1) == len(r2)
    for a, b in zip(r1, r2):
        assert list(a) == list(b)
        for key in a:
            x, y = a[key], b[key]
            if isinstance(x, float) and isinstance(y, float):
                assert np.float64(x).view(np.int64) == np.float64(y).view(np.int64) or (
                    math.isnan(x) and math.isnan(y)
                ), key
            else:
                assert x == y, key


@pytest.mark.parametrize(
    "opts",
    [
        # forces, a refused design (a zero-length rocker), cm against the file's mm
        [
            "links.crank.points.A[0]=2.2, 2.65 cm",
            "links.rocker.points.B[0]=0, 59, 62 mm",
            "ground.O4[1]=-0, 2 mm",
        ],
        # a parameter the family does not take: a polar point's angle (deg) feeds its
        # coordinates: every design parsed, as before
        ["links.coupler.points.P.angle=20, 30 deg", "links.crank.points.A[0]=22, 26 mm"],
    ],
)
def test_study_rows_identical_to_before(opts, monkeypatch):
    study = make_study(load_text(FOURBAR, "family.yaml"), opts)
    fam = ex.study_family(study, list(range(len(study))))
    assert (fam is None) == ("angle" in opts[0])
    new = _rows(study)
    old = _rows(study, monkeypatch, old=True)
    _same_rows(new, old)
    if fam is not None:
        assert any(r["status"].startswith("invalid:") for r in new)


def test_study_without_forces_and_one_at_a_time(monkeypatch):
    study = make_study(
        load_text(KINEMATIC, "kin.yaml"),
        ["links.crank.points.A[0]=20, 24, 28 mm", "ground.O4[0]=86, 88 mm"],
        design="one-at-a-time",
    )
    fam = ex.study_family(study, list(range(len(study))))
    assert fam is not None and fam.given is not None
    _same_rows(_rows(study), _rows(study, monkeypatch, old=True))


def test_family_parses_no_design_when_none_is_suspect(monkeypatch):
    calls = []
    real = DesignFamily.parse

    def counted(self, k):
        calls.append(k)
        return real(self, k)

    monkeypatch.setattr(DesignFamily, "parse", counted)
    base = from_source(load_text(FOURBAR, "family.yaml"))
    fam = design_family(base, {"links.crank.points.A[0]": [20.0, 22.0, 24.0]})
    b = solve_family(fam)
    assert b.batched.all() and calls == []
    # a point another is placed from: every design parsed
    fam = design_family(base, {"links.coupler.points.B[0]": [100.0, 104.0]})
    assert fam_mod._unsupported(fam) is None
    text = FOURBAR.replace("P: {length: 60, angle: 30}", "P: {length: 60, angle: 30, from: B}")
    base = from_source(load_text(text, "f.yaml"))
    fam = design_family(base, {"links.coupler.points.B[0]": [1e2]})
    fam.prepare()
    assert "placed from B" in fam.why_not
