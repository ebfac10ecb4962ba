"""``mechsolve bench --case synthesis`` runs (quick: one seed, a small budget) and says
what it measured: the objective reached, the designs evaluated, and the peer's status."""

from __future__ import annotations

import re

from click.testing import CliRunner

from mechsolve.cli.commands.bench import bench


def test_synthesis_case_runs():
    r = CliRunner().invoke(bench, ["--case", "synthesis", "--quick"])
    assert r.exit_code == 0, r.output
    assert "== synthesis: path generation, 18 points on a closed curve" in r.output
    m = re.search(
        r"sum of squares (\S+) m\^2; (\d+) generations, (\d+) designs evaluated", r.output
    )
    assert m, r.output
    assert 0 < float(m.group(1)) < 1  # the curve spans about 1 m: a result, not a stand-in
    assert int(m.group(3)) >= int(m.group(2)) > 0
    assert "peer pyslvs:" in r.output


def test_the_case_is_offered_and_its_files_are_packaged():
    from importlib import resources

    import click

    opt = next(o for o in bench.params if o.name == "cases")
    assert isinstance(opt.type, click.Choice) and "synthesis" in opt.type.choices
    data = resources.files("mechsolve_bench") / "data"
    text = (data / "path-18-points.yaml").read_text(encoding="utf-8")
    assert "mechanism: fourbar-free.yaml" in text
    assert "links:" in (data / "fourbar-free.yaml").read_text(encoding="utf-8")
