from __future__ import annotations

import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MECH = ROOT / "mechanisms"
# the example mechanisms (mechanisms/ also holds a cam design, which has no links)
MECHANISMS = sorted(p.name for p in MECH.glob("*.yaml") if "\nlinks:" in p.read_text())
DATA = Path(__file__).resolve().parent / "data"


def ref(name: str) -> dict:
    return json.loads((DATA / name).read_text())


@pytest.fixture
def data():
    return ref


# -- the fast tier: `python -m pytest -m "not slow"` ------------------------------------
# The tests that take longest on the project's 2-core machine are marked `slow`, either
# with `@pytest.mark.slow` in their file or listed in tests/slow_tests.txt (a whole module,
# a test, or one parametrisation, as pytest names them): the edit-test loop runs the rest,
# CI runs everything. The list is kept apart so that marking a test never edits its file;
# tests/test_issue29_tiers.py checks that every entry still names a test.
SLOW_LIST = Path(__file__).resolve().parent / "slow_tests.txt"


def slow_entries() -> list[str]:
    """The node ids of tests/slow_tests.txt: a comment line starts with ``#``, a note
    after an id with two spaces and ``#`` (an id may hold a ``#`` of its own)."""
    out = []
    for line in SLOW_LIST.read_text(encoding="utf-8").splitlines():
        line = line.split("  #", 1)[0].strip()
        if line and not line.startswith("#"):
            out.append(line)
    return out


def pytest_collection_modifyitems(config, items):
    slow = set(slow_entries())
    for item in items:
        nodeid = item.nodeid
        module = nodeid.split("::", 1)[0]
        if nodeid in slow or module in slow or nodeid.split("[", 1)[0] in slow:
            item.add_marker(pytest.mark.slow)


def nfourbar_crank_angle(n: int, t):
    """The N-four-bar's crank angle (rad) at times ``t``, in closed form: every window is
    a parallelogram, so it moves as one pendulum with I = (N + 1) m l^2 / 3 + N m l^2 and
    M_g = g m l ((N + 1) / 2 + N), starting upright at -1 rad/s (B0 along +x at 1 m/s);
    m = 1 kg, l = 1 m, g = 9.81 m/s^2, integrated to 1e-13."""
    import math

    from scipy.integrate import solve_ivp

    inertia, mg = (n + 1) / 3 + n, 9.81 * ((n + 1) / 2 + n)
    sol = solve_ivp(
        lambda _, y: [y[1], -mg / inertia * math.cos(y[0])],
        (0, float(t[-1])),
        [math.pi / 2, -1.0],
        t_eval=t,
        rtol=1e-13,
        atol=1e-13,
        method="DOP853",
    )
    return sol.y[0]
