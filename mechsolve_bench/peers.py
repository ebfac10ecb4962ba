"""Optional peer comparisons for the mechsolve benchmark.

The benchmark mechanism is a four-bar crank-rocker (SI units): ground pivots
``O2 = (0, 0)`` and ``O4 = (0.0875, 0)``, crank ``O2-A`` of 0.0265 m, coupler
``A-B`` of 0.1056 m, rocker ``O4-B`` of 0.059 m, the crank turning
counter-clockwise at 1 rad/s over one turn, on the "open" branch (``B`` on the
left of the directed line from ``A`` to ``O4``).

Two third-party packages solve it here, when they are installed:

* `pylinkage <https://github.com/HugoFara/pylinkage>`_ (kinematics only,
  ``Ground`` / ``Crank`` / ``RRRDyad`` / ``Linkage.step``);
* `exudyn <https://github.com/jgerstmayr/EXUDYN>`_ (multibody dynamics: 2D rigid
  bodies, revolute joints, crank driven by a prescribed-rotation coordinate
  constraint, generalized-alpha time integration).

exudyn also simulates seed 004's motor-driven start-up (:func:`exudyn_seed004`), the
machine built from a loaded mechsolve model (masses, inertias, joints, motor, damper,
gravity), so that ``mechsolve bench`` can time ``mechsolve simulate`` against it.

Both are imported lazily; every public function works (returns ``None``) when
its package is missing, and never raises: a failure inside a peer is returned
as ``{"name": ..., "error": "<message>"}``.
"""

from __future__ import annotations

import importlib
import importlib.util
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["available", "exudyn_fourbar", "exudyn_seed004", "pylinkage_fourbar"]

# --- the benchmark four-bar (SI units) ---------------------------------------------------------
_O2 = (0.0, 0.0)
_O4 = (0.0875, 0.0)
_CRANK = 0.0265
_COUPLER = 0.1056
_ROCKER = 0.059
_MASSES = (0.05, 0.2, 0.11)  # crank, coupler, rocker: uniform bars, centres at their middles
_GRAVITY = 9.81  # m/s^2, acting in -y
_OMEGA = 1.0  # crank speed, rad/s, counter-clockwise

_REPEATS = 3  # timings are the median of this many runs
_PEERS = ("pylinkage", "exudyn")

# seconds taken by the first import of a peer in this process (or in a fresh interpreter)
_IMPORT_SECONDS: dict[str, float] = {}


# --- imports and versions ----------------------------------------------------------------------


def _import(name: str) -> Any | None:
    """Import a peer package, recording how long the first import took.

    Parameters
    ----------
    name : str
        Top-level module name.

    Returns
    -------
    module or None
        The module, or ``None`` if it cannot be imported.
    """
    loaded_before = name in sys.modules
    start = time.perf_counter()
    try:
        module = importlib.import_module(name)
    except Exception:  # ImportError, or a broken installation
        return None
    if not loaded_before and name not in _IMPORT_SECONDS:
        _IMPORT_SECONDS[name] = time.perf_counter() - start
    return module


def _import_seconds(name: str) -> float:
    """Time to import a peer (numpy already loaded).

    The first import in this process is timed by :func:`_import`. If something
    else imported the package before this module did, the import is timed in a
    fresh interpreter instead.

    Parameters
    ----------
    name : str
        Top-level module name.

    Returns
    -------
    float
        Seconds, or NaN if the measurement failed.
    """
    if name not in _IMPORT_SECONDS:
        code = (
            "import time, numpy\n"
            "t = time.perf_counter()\n"
            f"import {name}\n"
            "print(time.perf_counter() - t)\n"
        )
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
        seconds = math.nan
        try:
            with tempfile.TemporaryDirectory() as cwd:
                proc = subprocess.run(
                    [sys.executable, "-c", code],
                    cwd=cwd,
                    env=env,
                    capture_output=True,
                    text=True,
                    timeout=120,
                    check=False,
                )
            if proc.returncode == 0:
                seconds = float(proc.stdout.strip().splitlines()[-1])
        except Exception:
            seconds = math.nan
        _IMPORT_SECONDS[name] = seconds
    return _IMPORT_SECONDS[name]


def _version(module: Any, name: str) -> str:
    """Version string of an imported package.

    Parameters
    ----------
    module : module
        The imported package.
    name : str
        Its distribution name.

    Returns
    -------
    str
        ``module.__version__``, else the installed distribution's version, else ``"unknown"``.
    """
    version = getattr(module, "__version__", None)
    if isinstance(version, str) and version:
        return version
    try:
        from importlib.metadata import version as dist_version

        return dist_version(name)
    except Exception:
        return "unknown"


def available() -> dict[str, str | None]:
    """Report which peers can be imported.

    Returns
    -------
    dict of str to str or None
        For ``"pylinkage"`` and ``"exudyn"``: the installed version string, or
        ``None`` if the package cannot be imported.
    """
    result: dict[str, str | None] = {}
    for name in _PEERS:
        module = _import(name)
        result[name] = None if module is None else _version(module, name)
    return result


# --- closed-form reference ---------------------------------------------------------------------


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """z component of the cross product of rows of two (N, 2) arrays."""
    return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]


def _perp(w: np.ndarray | float, r: np.ndarray) -> np.ndarray:
    """``w k x r`` for a scalar (or per-row) rate ``w`` and (N, 2) vectors ``r``."""
    w = np.asarray(w, dtype=float).reshape(-1, 1)
    return w * np.column_stack([-r[:, 1], r[:, 0]])


def _closed_form(theta: np.ndarray) -> dict[str, np.ndarray]:
    """Closed-form kinematics and inverse dynamics of the benchmark four-bar.

    Parameters
    ----------
    theta : numpy.ndarray
        Crank angles (rad), counter-clockwise from +x.

    Returns
    -------
    dict of str to numpy.ndarray
        ``A``, ``B`` (N, 2) joint positions on the open branch; ``w3``, ``w4``,
        ``al3``, ``al4`` coupler / rocker angular velocities and accelerations
        for the crank at ``_OMEGA`` (constant); ``vA``, ``vB`` joint velocities;
        ``torque`` the driving torque on the crank (counter-clockwise positive)
        from virtual power, ``T w2 = dKE/dt - P_gravity``.
    """
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    o4 = np.asarray(_O4, dtype=float)
    a_pos = np.column_stack([_CRANK * np.cos(theta), _CRANK * np.sin(theta)])
    d = o4 - a_pos
    dist = np.hypot(d[:, 0], d[:, 1])
    u = d / dist[:, None]
    left = np.column_stack([-u[:, 1], u[:, 0]])  # left normal of A -> O4: the open branch
    along = (_COUPLER**2 - _ROCKER**2 + dist**2) / (2.0 * dist)
    across = np.sqrt(_COUPLER**2 - along**2)
    b_pos = a_pos + along[:, None] * u + across[:, None] * left

    a = b_pos - a_pos  # A -> B
    b = b_pos - o4  # O4 -> B
    axb = _cross(a, b)
    v_a = _perp(_OMEGA, a_pos)
    acc_a = -(_OMEGA**2) * a_pos
    # loop closure vA + w3 k x a = w4 k x b, dotted with b and with a
    w3 = -np.sum(v_a * b, axis=1) / axb
    w4 = -np.sum(v_a * a, axis=1) / axb
    ab = np.sum(a * b, axis=1)
    al3 = (-(w4**2) * np.sum(b * b, axis=1) - np.sum(acc_a * b, axis=1) + w3**2 * ab) / axb
    al4 = (w3**2 * np.sum(a * a, axis=1) - np.sum(acc_a * a, axis=1) - w4**2 * ab) / axb
    v_b = _perp(w4, b)
    acc_b = _perp(al4, b) - (w4**2)[:, None] * b

    # centres of mass (middles of the bars): velocities and accelerations
    vel = (v_a / 2.0, (v_a + v_b) / 2.0, v_b / 2.0)
    acc = (acc_a / 2.0, (acc_a + acc_b) / 2.0, acc_b / 2.0)
    lengths = (_CRANK, _COUPLER, _ROCKER)
    inertia = [m * length**2 / 12.0 for m, length in zip(_MASSES, lengths)]
    d_kinetic = sum(m * np.sum(v * ac, axis=1) for m, v, ac in zip(_MASSES, vel, acc))
    d_kinetic = d_kinetic + inertia[1] * w3 * al3 + inertia[2] * w4 * al4  # crank: alpha = 0
    p_gravity = -_GRAVITY * sum(m * v[:, 1] for m, v in zip(_MASSES, vel))
    torque = (d_kinetic - p_gravity) / _OMEGA
    return {
        "A": a_pos,
        "B": b_pos,
        "vA": v_a,
        "vB": v_b,
        "w3": w3,
        "w4": w4,
        "al3": al3,
        "al4": al4,
        "torque": torque,
    }


def _position_checks(theta: np.ndarray, bx: np.ndarray, by: np.ndarray) -> tuple[str, bool]:
    """Check returned positions of ``B`` against the closed form.

    Parameters
    ----------
    theta : numpy.ndarray
        Crank angles (rad) the positions are reported at.
    bx, by : numpy.ndarray
        Positions of ``B``.

    Returns
    -------
    text : str
        Maximum errors, for the note.
    ok : bool
        Whether all checks pass to 1e-9 m and ``B`` is on the open branch.
    """
    ref = _closed_form(theta)
    a_pos = ref["A"]
    b_pos = np.column_stack([bx, by])
    o4 = np.asarray(_O4, dtype=float)
    e_ab = float(np.max(np.abs(np.hypot(*(b_pos - a_pos).T) - _COUPLER)))
    e_o4b = float(np.max(np.abs(np.hypot(*(b_pos - o4).T) - _ROCKER)))
    e_b = float(np.max(np.hypot(*(b_pos - ref["B"]).T)))
    open_branch = bool(np.all(_cross(o4 - a_pos, b_pos - a_pos) > 0.0))
    ok = open_branch and max(e_ab, e_o4b, e_b) <= 1e-9
    text = (
        f"max ||AB|-L3| {e_ab:.1e} m, max ||O4B|-L4| {e_o4b:.1e} m, "
        f"max |B-B_closed_form| {e_b:.1e} m, open branch {'yes' if open_branch else 'NO'}"
    )
    return text, ok


def _error(name: str, exc: BaseException) -> dict[str, Any]:
    """Result of a failed peer run."""
    return {"name": name, "error": f"{type(exc).__name__}: {exc}"}


def _check_n(n: int) -> int:
    """Validate the number of crank positions."""
    if isinstance(n, bool) or int(n) != n or n < 1:
        raise ValueError(f"n must be a positive integer, got {n!r}")
    return int(n)


def _median_time(run: Callable[[Any], Any], build: Callable[[], Any]) -> tuple[float, Any]:
    """Median wall time of ``run(build())`` over ``_REPEATS`` runs, building untimed.

    Parameters
    ----------
    run : callable
        Called with the built object; only this call is timed.
    build : callable
        Builds a fresh model for each run.

    Returns
    -------
    seconds : float
        Median of the timed calls.
    last : tuple
        ``(model, result)`` of the last run.
    """
    times = []
    last = None
    for _ in range(_REPEATS):
        model = build()
        start = time.perf_counter()
        result = run(model)
        times.append(time.perf_counter() - start)
        last = (model, result)
    return statistics.median(times), last


# --- pylinkage ---------------------------------------------------------------------------------


def pylinkage_fourbar(n: int) -> dict | None:
    """Solve the benchmark four-bar positions with pylinkage.

    The linkage is built from pylinkage's own components (``Ground``, ``Crank``,
    ``RRRDyad``, ``Linkage``) and simulated with ``Linkage.step``: each step the
    crank advances by ``angular_velocity * dt`` and ``B`` is found by
    circle-circle intersection, keeping the solution nearest to the previous one.

    Parameters
    ----------
    n : int
        Number of crank positions over one turn, ``theta = 2 pi k / n``.

    Returns
    -------
    dict or None
        ``None`` if pylinkage is not importable; otherwise ``name``, ``theta``
        (the crank angles of the returned positions, rad: pylinkage accumulates
        the angle step by step, so they are recovered from its crank positions
        and differ from the nominal grid only by round-off), ``Bx``, ``By`` (m),
        ``seconds`` (median of 3 simulations, building excluded),
        ``import_seconds`` and ``note``; or ``{"name", "error"}`` on failure.
    """
    pl = _import("pylinkage")
    if pl is None:
        return None
    name = f"pylinkage {_version(pl, 'pylinkage')}"
    try:
        n = _check_n(n)
        step = 2.0 * math.pi / n
        dt = step / _OMEGA

        def build() -> Any:
            ground2 = pl.Ground(_O2[0], _O2[1], name="O2")
            ground4 = pl.Ground(_O4[0], _O4[1], name="O4")
            # the first step advances the crank by one increment, so start one increment early
            crank = pl.Crank(
                anchor=ground2,
                radius=_CRANK,
                angular_velocity=_OMEGA,
                initial_angle=-step,
                name="A",
            )
            hint = _closed_form(np.array([-step]))["B"][0]  # selects the open branch
            dyad = pl.RRRDyad(
                crank.output,
                ground4,
                distance1=_COUPLER,
                distance2=_ROCKER,
                x=float(hint[0]),
                y=float(hint[1]),
                name="B",
            )
            linkage = pl.Linkage([ground2, ground4, crank, dyad], name="crank-rocker")
            if hasattr(linkage, "set_input_velocity"):
                linkage.set_input_velocity(crank, omega=_OMEGA)
            return linkage

        fast = hasattr(pl.Linkage, "step_fast_with_kinematics")
        if fast:  # the numba solver: positions, velocities and accelerations

            def simulate(linkage: Any) -> Any:
                return linkage.step_fast_with_kinematics(iterations=n, dt=dt)

        else:

            def simulate(linkage: Any) -> Any:
                return list(linkage.step(iterations=n, dt=dt))

        t0 = time.perf_counter()
        simulate(build())  # the first call compiles (numba, if present)
        first_seconds = time.perf_counter() - t0
        seconds, (_, out) = _median_time(simulate, build)
        frames = out[0] if fast else out
        velocity = np.asarray(out[1], dtype=float) if fast else None

        coords = np.asarray(frames, dtype=float)  # (n, 4 components, 2)
        a_pos, b_pos = coords[:, 2, :], coords[:, 3, :]
        nominal = step * np.arange(n)
        wrapped = np.angle(np.exp(1j * (np.arctan2(a_pos[:, 1], a_pos[:, 0]) - nominal)))
        theta = nominal + wrapped
        radius_err = float(np.max(np.abs(np.hypot(a_pos[:, 0], a_pos[:, 1]) - _CRANK)))
        checks, ok = _position_checks(theta, b_pos[:, 0], b_pos[:, 1])

        try:
            from pylinkage._numba_compat import HAS_NUMBA as has_numba
        except Exception:
            has_numba = importlib.util.find_spec("numba") is not None
        note = (
            ("numba present" if has_numba else "no numba: pure Python")
            + f"; first call {first_seconds:.2f} s"
            + (
                "; Linkage.step_fast_with_kinematics() (positions, velocities, accelerations)"
                if fast
                else "; Linkage.step() (Crank + RRRDyad, nearest-solution circle intersection)"
            )
            + f"; crank angle accumulated per step, max drift from nominal grid "
            f"{float(np.max(np.abs(wrapped))):.1e} rad, theta = actual crank angles"
            + f"; crank radius err {radius_err:.1e} m; checks: {checks}"
            + ("" if ok else "; CHECKS FAILED")
        )
        return {
            "name": name,
            "theta": theta,
            "Bx": b_pos[:, 0].copy(),
            "By": b_pos[:, 1].copy(),
            "vBx": None if velocity is None else velocity[:, 3, 0].copy(),
            "vBy": None if velocity is None else velocity[:, 3, 1].copy(),
            "seconds": seconds,
            "import_seconds": _import_seconds("pylinkage"),
            "note": note,
        }
    except Exception as exc:
        return _error(name, exc)


# --- exudyn ------------------------------------------------------------------------------------


def _set_setting(settings: Any, paths: tuple[str, ...], value: Any) -> None:
    """Set a simulation setting, trying current then older (deprecated) names.

    Parameters
    ----------
    settings : exudyn.SimulationSettings
        The settings structure.
    paths : tuple of str
        Dotted attribute paths, preferred first.
    value : object
        Value to set.
    """
    for path in paths:
        *parents, leaf = path.split(".")
        target = settings
        try:
            for part in parents:
                target = getattr(target, part)
            if hasattr(target, leaf):
                setattr(target, leaf, value)
                return
        except AttributeError:
            continue
    raise AttributeError(f"exudyn SimulationSettings has none of {paths}")


def _exudyn_model(exu: Any, n: int) -> dict[str, Any]:
    """Build the benchmark four-bar as an exudyn multibody system.

    Three ``ObjectRigidBody2D`` bars (node at the centre of mass, local x along
    the bar), four ``ObjectJointRevolute2D``, gravity as ``LoadMassProportional``,
    and a ``CoordinateConstraint`` prescribing the crank rotation
    ``phi2 = omega t`` through an offset user function; the initial state is the
    closed-form assembly at ``theta = 0`` with consistent velocities.

    Parameters
    ----------
    exu : module
        The imported ``exudyn`` package.
    n : int
        Number of output positions over one turn.

    Returns
    -------
    dict
        ``container``, ``mbs``, ``settings``, ``sensors`` (dict of sensor
        indices), ``h`` (time step, s) and ``steps`` (number of steps).
    """
    import exudyn.itemInterface as eii

    h = 2.0 * math.pi / (n * _OMEGA)
    steps = max(n - 1, 1)
    ref = _closed_form(np.array([0.0]))
    o2 = np.asarray(_O2, dtype=float)
    o4 = np.asarray(_O4, dtype=float)
    a0, b0 = ref["A"][0], ref["B"][0]
    va0, vb0 = ref["vA"][0], ref["vB"][0]
    zero = np.zeros(2)

    container = exu.SystemContainer()
    mbs = container.AddSystem()
    ground = mbs.AddObject(eii.ObjectGround())

    def bar(
        p: np.ndarray,
        q: np.ndarray,
        vp: np.ndarray,
        vq: np.ndarray,
        omega: float,
        mass: float,
        length: float,
    ) -> tuple[Any, Any, Any, Any]:
        centre = (p + q) / 2.0
        angle = math.atan2(q[1] - p[1], q[0] - p[0])
        vc = (vp + vq) / 2.0
        node = mbs.AddNode(
            eii.NodeRigidBody2D(
                referenceCoordinates=[centre[0], centre[1], angle],
                initialVelocities=[vc[0], vc[1], omega],
            )
        )
        body = mbs.AddObject(
            eii.ObjectRigidBody2D(mass=mass, inertia=mass * length**2 / 12.0, nodeNumber=node)
        )
        end_p = mbs.AddMarker(
            eii.MarkerBodyPosition(bodyNumber=body, localPosition=[-length / 2, 0, 0])
        )
        end_q = mbs.AddMarker(
            eii.MarkerBodyPosition(bodyNumber=body, localPosition=[length / 2, 0, 0])
        )
        mass_marker = mbs.AddMarker(eii.MarkerBodyMass(bodyNumber=body))
        mbs.AddLoad(
            eii.LoadMassProportional(markerNumber=mass_marker, loadVector=[0, -_GRAVITY, 0])
        )
        return node, body, end_p, end_q

    crank_node, _, crank_o2, crank_a = bar(o2, a0, zero, va0, _OMEGA, _MASSES[0], _CRANK)
    _, coupler, coupler_a, coupler_b = bar(a0, b0, va0, vb0, ref["w3"][0], _MASSES[1], _COUPLER)
    # the benchmark's load on the coupler: (1, -2) N at (0.05, 0.02) m from A in its frame
    load_marker = mbs.AddMarker(
        eii.MarkerBodyPosition(bodyNumber=coupler, localPosition=[0.05 - _COUPLER / 2, 0.02, 0])
    )
    mbs.AddLoad(eii.LoadForceVector(markerNumber=load_marker, loadVector=[1.0, -2.0, 0]))
    rocker_node, rocker, rocker_o4, rocker_b = bar(
        o4, b0, zero, vb0, ref["w4"][0], _MASSES[2], _ROCKER
    )

    ground_o2 = mbs.AddMarker(
        eii.MarkerBodyPosition(bodyNumber=ground, localPosition=[o2[0], o2[1], 0])
    )
    ground_o4 = mbs.AddMarker(
        eii.MarkerBodyPosition(bodyNumber=ground, localPosition=[o4[0], o4[1], 0])
    )
    for pair in (
        (ground_o2, crank_o2),
        (crank_a, coupler_a),
        (coupler_b, rocker_b),
        (ground_o4, rocker_o4),
    ):
        mbs.AddObject(eii.ObjectJointRevolute2D(markerNumbers=list(pair)))

    # prescribed crank rotation: phi2 - 0 = offset(t) = omega t (crank reference angle is 0)
    def offset(mbs: Any, t: float, item_number: int, l_offset: float) -> float:
        return _OMEGA * t

    def offset_t(mbs: Any, t: float, item_number: int, l_offset: float) -> float:
        return _OMEGA

    ground_node = mbs.AddNode(eii.NodePointGround())
    ground_coord = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=ground_node, coordinate=0))
    crank_coord = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=crank_node, coordinate=2))
    driver = mbs.AddObject(
        eii.CoordinateConstraint(
            markerNumbers=[ground_coord, crank_coord],
            offsetUserFunction=offset,
            offsetUserFunction_t=offset_t,
        )
    )

    ovt = exu.OutputVariableType

    def sensor(item: Any) -> Any:
        return mbs.AddSensor(item)

    sensors = {
        "theta": sensor(
            eii.SensorNode(
                nodeNumber=crank_node,
                outputVariableType=ovt.Rotation,
                storeInternal=True,
                writeToFile=False,
            )
        ),
        "B": sensor(
            eii.SensorBody(
                bodyNumber=rocker,
                localPosition=[_ROCKER / 2, 0, 0],
                outputVariableType=ovt.Position,
                storeInternal=True,
                writeToFile=False,
            )
        ),
        "w4": sensor(
            eii.SensorNode(
                nodeNumber=rocker_node,
                outputVariableType=ovt.AngularVelocity,
                storeInternal=True,
                writeToFile=False,
            )
        ),
        "al4": sensor(
            eii.SensorNode(
                nodeNumber=rocker_node,
                outputVariableType=ovt.AngularAcceleration,
                storeInternal=True,
                writeToFile=False,
            )
        ),
        "lambda": sensor(
            eii.SensorObject(
                objectNumber=driver,
                outputVariableType=ovt.Force,
                storeInternal=True,
                writeToFile=False,
            )
        ),
    }
    mbs.Assemble()

    settings = exu.SimulationSettings()
    integ = settings.timeIntegration
    integ.endTime = steps * h
    integ.numberOfSteps = steps
    integ.verboseMode = 0
    _set_setting(settings, ("timeIntegration.adaptiveStep",), False)
    # index-3 generalized-alpha (exudyn's default solver) with more numerical damping than the
    # default 0.9, so the start-up oscillation of the algorithmic accelerations dies out fast
    integ.generalizedAlpha.spectralRadius = 0.6
    integ.generalizedAlpha.computeInitialAccelerations = True
    integ.newton.useModifiedNewton = False  # full Newton: fewer iterations on this tiny system
    _set_setting(settings, ("solution.file.write", "solutionSettings.writeSolutionToFile"), False)
    _set_setting(
        settings, ("solution.sensors.writePeriod", "solutionSettings.sensorsWritePeriod"), h / 2
    )
    _set_setting(settings, ("show.computationTime", "displayComputationTime"), False)
    _set_setting(settings, ("show.statistics", "displayStatistics"), False)
    return {
        "container": container,
        "mbs": mbs,
        "settings": settings,
        "sensors": sensors,
        "h": h,
        "steps": steps,
    }


def exudyn_fourbar(n: int) -> dict | None:
    """Solve the benchmark four-bar as a driven multibody system with exudyn.

    Uniform bars of 0.05, 0.2 and 0.11 kg (inertia ``m l^2 / 12`` about their
    middles), gravity 9.81 m/s^2 in -y, crank rotation prescribed at 1 rad/s by
    a coordinate constraint; a dynamic simulation over one turn with ``n``
    output steps gives positions, velocities, accelerations and the Lagrange
    multiplier of the driving constraint (the driving torque).

    Parameters
    ----------
    n : int
        Number of crank positions over one turn, ``theta = 2 pi k / n``.

    Returns
    -------
    dict or None
        ``None`` if exudyn is not importable; otherwise ``name``, ``theta``
        (crank angles solved by exudyn, rad), ``Bx``, ``By`` (m),
        ``rocker_omega`` (rad/s, counter-clockwise positive), ``torque`` (N m on
        the crank, counter-clockwise positive), ``seconds`` (median of 3 solves,
        model building excluded), ``import_seconds`` and ``note`` (method and
        errors against the closed form and a virtual-power torque); or
        ``{"name", "error"}`` on failure.
    """
    exu = _import("exudyn")
    if exu is None:
        return None
    name = f"exudyn {_version(exu, 'exudyn')}"
    try:
        n = _check_n(n)

        def build() -> dict[str, Any]:
            return _exudyn_model(exu, n)

        def solve(model: dict[str, Any]) -> Any:
            return model["mbs"].SolveDynamic(model["settings"])

        seconds, (model, success) = _median_time(solve, build)
        if success is False:
            raise RuntimeError("exudyn SolveDynamic reported failure")
        mbs, sensors, h = model["mbs"], model["sensors"], model["h"]
        data = {key: np.asarray(mbs.GetSensorStoredData(idx)) for key, idx in sensors.items()}
        times = data["theta"][:, 0]
        if len(times) < n or not np.allclose(times[:n], h * np.arange(n), rtol=0, atol=1e-9 * h):
            raise RuntimeError(f"exudyn stored {len(times)} sensor rows, expected one per step")
        data = {key: value[:n] for key, value in data.items()}

        theta = data["theta"][:, -1].copy()  # rotation of the crank node (reference angle 0)
        bx, by = data["B"][:, 1].copy(), data["B"][:, 2].copy()
        rocker_omega = data["w4"][:, -1].copy()
        rocker_alpha = data["al4"][:, -1]
        # the Lagrange multiplier is the generalized force of the constraint on the crank
        # rotation coordinate with the opposite sign: the motor torque is -lambda
        torque = -data["lambda"][:, 1]

        ref = _closed_form(theta)
        checks, ok = _position_checks(theta, bx, by)
        e_theta = float(np.max(np.abs(theta - _OMEGA * times[:n])))
        e_w4 = float(np.max(np.abs(rocker_omega - ref["w4"])))
        e_al4 = float(np.max(np.abs(rocker_alpha - ref["al4"])))
        e_t = float(np.max(np.abs(torque - ref["torque"])))
        t_max = float(np.max(np.abs(ref["torque"])))
        note = (
            "2D rigid bars (NodeRigidBody2D/ObjectRigidBody2D), 4 JointRevolute2D, gravity; "
            "crank driven by CoordinateConstraint with offsetUserFunction (Python) = omega t; "
            f"SolveDynamic generalized-alpha index 3, rho_inf 0.6, full Newton, "
            f"{model['steps']} fixed steps; initial state from closed form at theta = 0; "
            "torque = -Lagrange multiplier of the driving constraint. "
            f"Checks vs closed form: crank angle err {e_theta:.1e} rad; {checks}; "
            f"rocker omega max err {e_w4:.1e} rad/s (max |omega4| "
            f"{float(np.max(np.abs(ref['w4']))):.3f}); rocker alpha max err {e_al4:.1e} rad/s^2 "
            f"(max |alpha4| {float(np.max(np.abs(ref['al4']))):.3f}, integrator start-up "
            f"transient); torque vs virtual power max err {e_t:.1e} N m (max |T| {t_max:.4f} N m, "
            f"rel {e_t / t_max:.1e})" + ("" if ok else "; POSITION CHECKS FAILED")
        )
        return {
            "name": name,
            "theta": theta,
            "Bx": bx,
            "By": by,
            "rocker_omega": rocker_omega,
            "torque": torque,
            "seconds": seconds,
            "import_seconds": _import_seconds("exudyn"),
            "note": note,
        }
    except Exception as exc:
        return _error(name, exc)


# --- exudyn: seed 004's motor-driven start-up --------------------------------------------------

_LOADS = ("native", "user functions")


def _start_pose(mech: Any) -> dict[str, tuple[float, np.ndarray]]:
    """Angle and origin of every link at the driver's start, from mechsolve's assembly.

    Parameters
    ----------
    mech : mechsolve.model.Mechanism
        The loaded model.

    Returns
    -------
    dict
        Link name to ``(theta, origin)``: a link point with local coordinates ``p`` is at
        ``origin + R(theta) p``.
    """
    from mechsolve import api

    res = api.solve(mech, forces=False)  # position 0 is the driver's start (assembly rules)
    pose = {}
    for lk in mech.links:
        theta = float(res.link(lk.name).angle[0])
        rot = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
        name, local = next(iter(lk.points.items()))
        if name in mech.ground:
            world = np.asarray(mech.ground[name], dtype=float)
        else:
            world = np.array([res.point(name).x[0], res.point(name).y[0]], dtype=float)
        pose[lk.name] = (theta, world - rot @ np.asarray(local, dtype=float))
    return pose


def _exudyn_machine(
    exu: Any,
    mech: Any,
    pose: dict[str, tuple[float, np.ndarray]],
    h: float,
    loads: str,
    spectral_radius: float,
) -> dict[str, Any]:
    """Build a motor-driven planar machine from a mechsolve model as an exudyn system.

    One ``ObjectRigidBody2D`` per link (node at the centre of mass, the link's mass and
    centroidal inertia), an ``ObjectJointRevolute2D`` per pin, an ``ObjectJointPrismatic2D``
    (rotation constrained) per slider on the ground, ``LoadMassProportional`` gravity on
    every body, at rest at the driver's start. The motor torque ``M(omega, t)`` acts on the
    driven link and a viscous damper on the slider:

    * ``loads="user functions"``: a ``LoadTorqueVector`` whose Python user function
      evaluates the model's motor law at the crank's angular velocity
      (``mbs.GetNodeOutput``), and a ``LoadForceVector`` user function ``-c v`` along the
      guide;
    * ``loads="native"`` (linear motor and a guide along x or y only): the same forces
      from exudyn's compiled elements, a constant torque ``M0`` plus
      ``ObjectConnectorCoordinateSpringDamper`` of damping ``nu0`` on the crank's rotation
      and of damping ``c`` on the slider's coordinate, no Python in the time loop.

    Parameters
    ----------
    exu : module
        The imported ``exudyn`` package.
    mech : mechsolve.model.Mechanism
        Model with a ``motor``, a ``simulate`` section starting from rest and only gravity
        and slider dampers as loads.
    pose : dict
        From :func:`_start_pose`.
    h : float
        Fixed time step, s.
    loads : str
        ``"native"`` or ``"user functions"``.
    spectral_radius : float
        Generalized-alpha's spectral radius at infinity.

    Returns
    -------
    dict
        ``mbs``, ``container``, ``settings``, ``sensor`` (crank angular velocity),
        ``sign`` (+1 if the crank's angle is the driver angle, -1 if reversed), ``steps``.

    Raises
    ------
    NotImplementedError
        For a model element this builder does not translate.
    """
    import exudyn.itemInterface as eii

    from mechsolve.model import Damper, PinJoint, SliderJoint

    sim, motor = mech.simulation, mech.motor
    if motor is None or sim is None:
        raise NotImplementedError("the model has no motor or no simulate section")
    if sim.speed0:
        raise NotImplementedError("only a start from rest is translated")
    if loads not in _LOADS:
        raise ValueError(f"loads must be one of {_LOADS}, got {loads!r}")
    links = {lk.name: lk for lk in mech.links}
    container = exu.SystemContainer()
    mbs = container.AddSystem()
    ground = mbs.AddObject(eii.ObjectGround())
    ground_node = mbs.AddNode(eii.NodePointGround())
    ground_coord = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=ground_node, coordinate=0))
    gx, gy = (float(g) for g in mech.gravity)
    bodies: dict[str, tuple[Any, Any]] = {}
    for lk in mech.links:
        if not lk.mass or lk.mass <= 0:
            raise NotImplementedError(f"link {lk.name!r} has no mass")
        theta, origin = pose[lk.name]
        rot = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
        com = origin + rot @ np.asarray(lk.com, dtype=float)
        node = mbs.AddNode(
            eii.NodeRigidBody2D(
                referenceCoordinates=[com[0], com[1], theta], initialVelocities=[0, 0, 0]
            )
        )
        body = mbs.AddObject(
            eii.ObjectRigidBody2D(mass=lk.mass, inertia=lk.inertia or 0.0, nodeNumber=node)
        )
        mass_marker = mbs.AddMarker(eii.MarkerBodyMass(bodyNumber=body))
        mbs.AddLoad(eii.LoadMassProportional(markerNumber=mass_marker, loadVector=[gx, gy, 0]))
        bodies[lk.name] = (body, node)

    def marker(link: str, point: str, kind: Any = eii.MarkerBodyPosition) -> Any:
        if link == "ground":
            x, y = mech.ground[point]
            return mbs.AddMarker(kind(bodyNumber=ground, localPosition=[x, y, 0]))
        lk = links[link]
        loc = np.asarray(lk.points[point], dtype=float) - np.asarray(lk.com, dtype=float)
        return mbs.AddMarker(kind(bodyNumber=bodies[link][0], localPosition=[loc[0], loc[1], 0]))

    sliders: dict[str, tuple[Any, str, float, float]] = {}
    for joint in mech.joints:
        if isinstance(joint, PinJoint):
            pair = [marker(joint.a, joint.point), marker(joint.b, joint.point)]
            mbs.AddObject(eii.ObjectJointRevolute2D(markerNumbers=pair))
        elif isinstance(joint, SliderJoint) and joint.guide == "ground":
            c, s = math.cos(joint.angle), math.sin(joint.angle)
            on_guide = mbs.AddMarker(
                eii.MarkerBodyRigid(
                    bodyNumber=ground, localPosition=[joint.origin[0], joint.origin[1], 0]
                )
            )
            block = marker(joint.block, joint.point, eii.MarkerBodyRigid)
            mbs.AddObject(
                eii.ObjectJointPrismatic2D(
                    markerNumbers=[on_guide, block],
                    axisMarker0=[c, s, 0],
                    normalMarker1=[-s, c, 0],
                    constrainRotation=True,
                )
            )
            sliders[joint.name] = (bodies[joint.block][1], joint.block, c, s)
        else:
            raise NotImplementedError(f"joint {joint.name!r} ({type(joint).__name__})")

    drive = next(j for j in mech.joints if j.name == mech.driver.joint)
    if not isinstance(drive, PinJoint) or "ground" not in (drive.a, drive.b):
        raise NotImplementedError("the motor must drive a pin to the ground")
    crank = drive.b if drive.a == "ground" else drive.a
    sign = 1.0 if drive.a == "ground" else -1.0
    crank_body, crank_node = bodies[crank]
    ovt = exu.OutputVariableType
    crank_marker = mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=crank_body))
    native = loads == "native"
    if native:
        if motor.kind != "linear":
            raise NotImplementedError("native loads: only a linear motor law M0 - nu0 omega")
        mbs.AddLoad(
            eii.LoadTorqueVector(markerNumber=crank_marker, loadVector=[0, 0, sign * motor.stall])
        )
        crank_coord = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=crank_node, coordinate=2))
        mbs.AddObject(
            eii.ObjectConnectorCoordinateSpringDamper(
                markerNumbers=[ground_coord, crank_coord], damping=motor.slope
            )
        )
    else:

        def motor_torque(mbs_: Any, t: float, load: Any) -> list[float]:
            omega = sign * mbs_.GetNodeOutput(crank_node, ovt.AngularVelocity)[2]
            return [0.0, 0.0, sign * float(motor.torque(omega, t))]

        mbs.AddLoad(
            eii.LoadTorqueVector(markerNumber=crank_marker, loadVectorUserFunction=motor_torque)
        )
    for load in mech.loads:
        if not (isinstance(load, Damper) and load.slider in sliders and load.when is None):
            raise NotImplementedError(f"load {load.name!r}: only dampers on a slider translate")
        node, block, c, s = sliders[load.slider]
        coef = float(load.coefficient)
        if native:
            axis = 0 if abs(s) < 1e-12 else 1 if abs(c) < 1e-12 else None
            if axis is None:
                raise NotImplementedError("native loads: a damped guide along x or y only")
            coord = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=node, coordinate=axis))
            mbs.AddObject(
                eii.ObjectConnectorCoordinateSpringDamper(
                    markerNumbers=[ground_coord, coord], damping=coef
                )
            )
        else:

            def drag(
                mbs_: Any,
                t: float,
                load: Any,
                node: Any = node,
                c: float = c,
                s: float = s,
                coef: float = coef,
            ) -> list[float]:
                v = mbs_.GetNodeOutput(node, ovt.Velocity)
                f = -coef * (v[0] * c + v[1] * s)
                return [f * c, f * s, 0.0]

            at = marker(block, next(iter(links[block].points)))
            mbs.AddLoad(eii.LoadForceVector(markerNumber=at, loadVectorUserFunction=drag))
    sensor = mbs.AddSensor(
        eii.SensorNode(
            nodeNumber=crank_node,
            outputVariableType=ovt.AngularVelocity,
            storeInternal=True,
            writeToFile=False,
        )
    )
    mbs.Assemble()

    steps = int(round(sim.duration / h))
    settings = exu.SimulationSettings()
    integ = settings.timeIntegration
    integ.endTime = steps * h
    integ.numberOfSteps = steps
    integ.verboseMode = 0
    _set_setting(settings, ("timeIntegration.adaptiveStep",), False)
    integ.generalizedAlpha.spectralRadius = spectral_radius
    integ.generalizedAlpha.computeInitialAccelerations = True
    integ.newton.useModifiedNewton = False  # full Newton: the modified one fails at 1.39 s
    _set_setting(settings, ("solution.file.write", "solutionSettings.writeSolutionToFile"), False)
    _set_setting(
        settings, ("solution.sensors.writePeriod", "solutionSettings.sensorsWritePeriod"), h / 2
    )
    _set_setting(settings, ("show.computationTime", "displayComputationTime"), False)
    _set_setting(settings, ("show.statistics", "displayStatistics"), False)
    return {
        "container": container,
        "mbs": mbs,
        "settings": settings,
        "sensor": sensor,
        "sign": sign,
        "steps": steps,
    }


def exudyn_seed004(
    mech: Any,
    h: float | None = None,
    loads: str = "native",
    spectral_radius: float = 0.6,
    repeats: int = _REPEATS,
) -> dict | None:
    """Simulate a motor-driven start-up (seed 004's machine) with exudyn.

    The machine is built from the loaded mechsolve model (see :func:`_exudyn_machine`)
    and integrated from rest over the model's duration with exudyn's implicit
    generalized-alpha solver (index 3, full Newton, fixed step). exudyn's explicit
    Runge-Kutta solvers (``RK44``) cannot be used: they accept no joints (only
    coordinate constraints to the ground), and a closed-loop linkage needs them.
    Generalized-alpha is second order, so at the same step its angular velocity is
    further from the exact solution than RK4's; exudyn's default spectral radius 0.9
    (and 1.0) lose Newton convergence near 1.39 s at h = 2 ms, hence 0.6.

    Parameters
    ----------
    mech : mechsolve.model.Mechanism
        The loaded model (e.g. ``motor-linkage.yaml``).
    h : float, optional
        Time step, s; the model's ``simulate.step`` by default.
    loads : {"native", "user functions"}
        How the motor torque and the slider's damper enter (see :func:`_exudyn_machine`).
    spectral_radius : float
        Generalized-alpha's spectral radius at infinity.
    repeats : int
        Timed solves; the time reported is their median (model building excluded).

    Returns
    -------
    dict or None
        ``None`` if exudyn is not importable; otherwise ``name``, ``t`` (s), ``omega``
        (the driver's angular velocity at every step, rad/s), ``max_omega``,
        ``t_max_omega``, ``seconds`` (median solve time), ``import_seconds``, ``h``,
        ``steps`` and ``note``; or ``{"name", "error"}`` on failure.
    """
    exu = _import("exudyn")
    if exu is None:
        return None
    name = f"exudyn {_version(exu, 'exudyn')}"
    try:
        step = float(mech.simulation.step if h is None else h)
        if not (step > 0 and math.isfinite(step)):
            raise ValueError(f"h must be a positive time step, got {h!r}")
        pose = _start_pose(mech)

        def build() -> dict[str, Any]:
            return _exudyn_machine(exu, mech, pose, step, loads, spectral_radius)

        def solve(model: dict[str, Any]) -> Any:
            return model["mbs"].SolveDynamic(model["settings"])

        times = []
        model = success = None
        for _ in range(max(1, int(repeats))):
            model = build()
            start = time.perf_counter()
            success = solve(model)
            times.append(time.perf_counter() - start)
        if success is False:
            raise RuntimeError("exudyn SolveDynamic reported failure")
        data = np.asarray(model["mbs"].GetSensorStoredData(model["sensor"]))
        t, omega = data[:, 0], model["sign"] * data[:, -1]
        steps = model["steps"]
        if len(t) != steps + 1 or not np.allclose(t, step * np.arange(steps + 1), atol=1e-9):
            raise RuntimeError(f"exudyn stored {len(t)} sensor rows, expected {steps + 1}")
        k = int(np.argmax(omega))
        how = (
            "motor and slider damper as compiled elements (constant torque + coordinate dampers)"
            if loads == "native"
            else "motor law and slider damper as Python load user functions"
        )
        note = (
            f"{len(mech.links)} RigidBody2D, JointRevolute2D per pin, JointPrismatic2D "
            f"(rotation constrained) for the slider, gravity; {how}; SolveDynamic "
            f"generalized-alpha index 3, rho_inf {spectral_radius:g}, full Newton, "
            f"{steps} steps of {step:g} s (explicit RK44 takes no joints)"
        )
        return {
            "name": name,
            "t": t.copy(),
            "omega": omega.copy(),
            "max_omega": float(omega[k]),
            "t_max_omega": float(t[k]),
            "seconds": statistics.median(times),
            "import_seconds": _import_seconds("exudyn"),
            "h": step,
            "steps": steps,
            "note": note,
        }
    except Exception as exc:
        return _error(name, exc)
