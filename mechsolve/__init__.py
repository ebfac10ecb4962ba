"""mechsolve: a declarative solver for planar mechanisms.

Describe a linkage in YAML (or build a :class:`~mechsolve.model.Mechanism` in code), then::

    import mechsolve as ms
    res = ms.run("mechanisms/crane.yaml")
    res.point("K").x, res.point("K").vx      # arrays over the sweep
    res.to_csv("crane.csv")

The package's folders are the pipeline's layers, and data flows one way: base -> model
(the file) -> system (the constraint equations) -> groups -> core (the sweep, states and
forces) -> results -> writers -> analyses, reached through :mod:`mechsolve.api` -> report
-> cli (see CONTRIBUTING.md).
"""

from __future__ import annotations

from typing import Any

__version__ = "0.1.0"

_API = {
    "load": "api",
    "loads": "api",
    "solve": "api",
    "run": "api",
    "check": "api",
    "stream": "api",
    "solve_designs": "analyses.batch",
    "design_family": "analyses.study.family",
    "solve_family": "analyses.study.family",
    "Mechanism": "model",
    "Link": "model",
    "PinJoint": "model",
    "SliderJoint": "model",
    "Driver": "model",
    "Limit": "model",
    "Sweep": "model",
    "Assembly": "model",
    "Outputs": "model",
    "SolverOptions": "model",
    "PointForce": "model",
    "Torque": "model",
    "Spring": "model",
    "Damper": "model",
    "Results": "results.results",
    "MechsolveError": "base.errors",
    "InputError": "base.errors",
    "AssemblyError": "base.errors",
    "SolverError": "base.errors",
}

__all__ = sorted(_API)


def __getattr__(name: str) -> Any:
    # imported lazily so that `mechsolve --help` starts without numpy
    if name in _API:
        import importlib

        mod = importlib.import_module(f".{_API[name]}", __name__)
        value = getattr(mod, name)
        globals()[name] = value  # found directly from now on (no import machinery per call)
        return value
    raise AttributeError(f"module 'mechsolve' has no attribute {name!r}")
