"""A long multibody ``mechsolve simulate`` printed Matplotlib's UserWarning ("Creating
legend with loc='best' can be slow with large amounts of data"): its legends searched the
run's samples for a free corner. They now stand beside the axes, placed at once, and
inside the saved figure.

Whether the search is slow enough to warn depends on the machine, so the search itself is
watched: Matplotlib's ``Legend._find_best_position`` is wrapped to count its calls and to
warn as Matplotlib does when it is slow; the run must never call it and print nothing on
stderr.
"""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import matplotlib
import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main

matplotlib.use("Agg")
from matplotlib.legend import Legend  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def best_searches(monkeypatch):
    calls = []
    real = Legend._find_best_position

    def slow(self, *args, **kwargs):
        calls.append(self)
        warnings.warn(
            'Creating legend with loc="best" can be slow with large amounts of data.',
            UserWarning,
            stacklevel=2,
        )
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Legend, "_find_best_position", slow)
    return calls


def _long_nfourbar(tmp_path) -> Path:
    """mechanisms/nfourbar-1.yaml over 10 s at 1 ms: 10001 rows (its file: 401)."""
    text = (ROOT / "mechanisms" / "nfourbar-1.yaml").read_text()
    old = "duration: 10 s, step: 0.025 s"
    assert old in text
    f = tmp_path / "nfourbar-long.yaml"
    f.write_text(text.replace(old, "duration: 10 s, step: 0.001 s"))
    return f


def test_long_multibody_simulate_prints_no_warning(tmp_path, best_searches):
    out = tmp_path / "out"
    r = CliRunner().invoke(main, ["simulate", str(_long_nfourbar(tmp_path)), "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert (out / "simulation-energy.png").exists() and (out / "simulation-motion.png").exists()
    assert not best_searches
    assert "Warning" not in r.stderr and "loc=" not in r.stderr, r.stderr
    rows = (out / "simulation.csv").read_text().count("\n") - 1
    assert rows >= 10001


def test_link_angle_legend_beside_the_axes_inside_the_figure(tmp_path, best_searches, monkeypatch):
    """The motion figure of a run placed by its poses (one angle curve per link, with a
    legend): beside the axes, on the right, and wholly inside the saved figure."""
    import matplotlib.figure

    from mechsolve import api
    from mechsolve.analyses.dynamics import simulate
    from mechsolve.analyses.dynamics.multibody_plots import write_multibody_plots

    mech = api.load(ROOT / "mechanisms" / "nfourbar-1.yaml")
    res = simulate(mech)
    assert res.multibody is not None
    res.trajectory = dataclasses.replace(res.trajectory, u=None)
    seen = []
    real = matplotlib.figure.Figure.savefig

    def keep(fig, *args, **kwargs):
        real(fig, *args, **kwargs)
        renderer = fig.canvas.get_renderer()
        for ax in fig.axes:
            leg = ax.get_legend()
            if leg is not None:
                box = leg.get_window_extent(renderer)
                fb = fig.bbox
                axb = ax.get_window_extent(renderer)
                seen.append((box.x0 >= axb.x1, box.x1 <= fb.x1 + 0.5, box.y0 >= fb.y0 - 0.5))

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep)
    paths = write_multibody_plots(res, tmp_path)
    assert [p.name for p in paths] == ["simulation-motion.png", "simulation-energy.png"]
    assert len(seen) == 3  # the link angles, the energies, the violations
    assert all(all(s) for s in seen), seen
    assert not best_searches
