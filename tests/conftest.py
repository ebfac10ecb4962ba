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
