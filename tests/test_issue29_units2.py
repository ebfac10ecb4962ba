"""Issue 29 item 2 for the commands beyond run and sweep: a file written in mm and deg gets
the tables and summaries of ``polygons``, ``shaking``, ``compare``, ``report``,
``simulate`` and ``flywheel`` in mm, deg, N*mm..., and ``--units SI`` the SI output.

Each test runs the command twice on the same mm/deg file, once as is and once with
``--units SI``, and checks every number of the output against the SI one multiplied by a
factor written out here by hand (1 mm = 1e-3 m, 1 deg = pi/180 rad, 1 N*mm = 1e-3 N*m),
not by mechsolve's unit table.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

from click.testing import CliRunner

from mechsolve.cli.main import main

MECH = Path(__file__).resolve().parent.parent / "mechanisms"

MM = 1e-3  # m
DEG = math.pi / 180  # rad
NMM = 1e-3  # N*m
# SI unit -> (the unit a mm/deg file shows, shown value per SI value), written out by hand
BY_HAND = {
    "m": ("mm", 1 / MM),
    "m/s": ("mm/s", 1 / MM),
    "m/s^2": ("mm/s^2", 1 / MM),
    "rad/s": ("deg/s", 1 / DEG),
    "rad/s^2": ("deg/s^2", 1 / DEG),
    "N*m": ("N*mm", 1 / NMM),
    "N": ("N", 1.0),
    "deg": ("deg", 1.0),
    "s": ("s", 1.0),
    "J": ("J", 1.0),
    "W": ("W", 1.0),
    "-": ("-", 1.0),
}
NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?"


def _invoke(*args: str) -> str:
    r = CliRunner().invoke(main, list(args))
    assert r.exit_code == 0, r.output
    return r.output


def _close(shown: float, si: float, factor: float, digits: int) -> None:
    """``shown`` is ``si * factor`` to the ``digits`` significant digits both are printed
    with (each rounded once: half a unit of the last digit of each)."""
    want = si * factor
    tol = 0.5 * 10 ** (1 - digits) * (abs(want) + abs(shown)) * 1.01 + 1e-300
    assert abs(shown - want) <= tol, (shown, si, factor)


# ---------------------------------------------------------------- polygons


def _polygons(tmp_path: Path, *extra: str) -> list[str]:
    out = tmp_path / ("si" if extra else "file")
    _invoke("polygons", str(MECH / "shaper.yaml"), "--at", "3", "-o", str(out), "-q", *extra)
    return (out / "polygons.txt").read_text(encoding="utf-8").splitlines()


def test_polygons_summary_in_the_files_units(tmp_path):
    mine, si = _polygons(tmp_path), _polygons(tmp_path, "--units", "SI")
    assert len(mine) == len(si)
    checked = 0
    unit_si = unit_mine = None
    for a, b in zip(mine, si):
        # a vector table's header names its unit: [mm/s] in the file's, [m/s] in SI
        hb = re.fullmatch(r"\s+\[mm\]\s+\[(\S+)\]", b)
        if hb:
            unit_si = hb[1]
            unit_mine = re.fullmatch(r"\s+\[mm\]\s+\[(\S+)\]", a)[1]
            assert unit_mine == BY_HAND[unit_si][0]
            continue
        row = re.fullmatch(rf"\s+(\S+)\s+(\S+ -> \S+)\s+({NUMBER})\s+({NUMBER})\s.*", b)
        if row:
            ra = re.fullmatch(rf"\s+(\S+)\s+(\S+ -> \S+)\s+({NUMBER})\s+({NUMBER})\s.*", a)
            assert ra[1] == row[1] and ra[3] == row[3]  # the same vector, drawn as long
            _close(float(ra[4]), float(row[4]), BY_HAND[unit_si][1], 4)
            checked += 1
            continue
        ang = re.fullmatch(rf"\s+([ωα]\d+) .* = ({NUMBER}) / ({NUMBER}) m = ({NUMBER}) (\S+).*", b)
        if ang:
            aa = re.fullmatch(
                rf"\s+([ωα]\d+) .* = ({NUMBER}) / ({NUMBER}) mm = ({NUMBER}) (\S+).*", a
            )
            assert aa, a
            lin = "m/s" if ang[1].startswith("ω") else "m/s^2"
            _close(float(aa[2]), float(ang[2]), BY_HAND[lin][1], 4)
            _close(float(aa[3]), float(ang[3]), 1 / MM, 4)
            assert aa[5] == BY_HAND[ang[5]][0]
            _close(float(aa[4]), float(ang[4]), BY_HAND[ang[5]][1], 4)
            checked += 1
            continue
        sc = re.fullmatch(
            rf"\s+scales: μl = ({NUMBER}) m/mm, μv = ({NUMBER}) \(m/s\)/mm, "
            rf"μa = ({NUMBER}) \(m/s\^2\)/mm",
            b,
        )
        if sc:
            sa = re.fullmatch(
                rf"\s+scales: μl = ({NUMBER}) mm/mm, μv = ({NUMBER}) \(mm/s\)/mm, "
                rf"μa = ({NUMBER}) \(mm/s\^2\)/mm",
                a,
            )
            assert sa, a
            for k in (1, 2, 3):
                _close(float(sa[k]), float(sc[k]), 1 / MM, 6)
            checked += 1
            continue
        if b.startswith("check against"):
            na = re.findall(rf"({NUMBER}) (\S+?)[ ,)]", a + " ")
            nb = re.findall(rf"({NUMBER}) (\S+?)[ ,)]", b + " ")
            assert len(na) == len(nb)
            for (va, ua), (vb, ub) in zip(na, nb):
                assert ua == BY_HAND[ub][0] if ub in BY_HAND else ua == ub
                f = BY_HAND[ub][1] if ub in BY_HAND else 1.0
                _close(float(va), float(vb), f, 2)
            checked += 1
            continue
        assert a == b  # the rest (names, equations) does not depend on the units
    assert checked >= 20
