"""The machine around a mechanism, for forward dynamics: the motor's law, the flywheel,
and how to simulate (``motor:``, ``flywheel:``, ``simulate:`` in a file).

The motor drives the driver joint: a torque (a force for a linear driver) as a law of the
driver's speed ``omega`` (``v``) and of time, both taken along the driver's direction of
motion (a motor of a clockwise crank has a positive speed and drives with a positive
torque): ``M0 - nu * omega`` (``stall`` and
``slope``), a table of (speed, torque) points (linear interpolation, constant beyond the
ends), or an expression of ``omega`` and ``t``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

INTEGRATORS = ("rk4", "RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")


@dataclass
class Motor:
    """``torque(omega, t)``: the motor's torque (N m) or force (N) on the driver."""

    kind: str  # "linear", "table" or "law"
    stall: float = 0.0
    slope: float = 0.0
    speeds: np.ndarray | None = None
    torques: np.ndarray | None = None
    expr: object = None
    text: str = ""

    def torque(self, omega, t=0.0):
        omega = np.asarray(omega, float)
        if self.kind == "linear":
            return self.stall - self.slope * omega
        if self.kind == "table":
            return np.interp(omega, self.speeds, self.torques)
        t = np.broadcast_to(np.asarray(t, float), omega.shape)
        val = self.expr.evaluate_at({"omega": omega, "v": omega, "t": t})
        return np.broadcast_to(np.asarray(val, float), omega.shape)

    def describe(self, linear: bool = False, units: bool = True) -> str:
        """The law in words with its units (SI): ``M = 50 N*m - 1.25 N*m*s * omega``; a
        force ``F`` of the speed ``v`` for a ``linear`` (sliding) driver; an expression
        as written (with the units it is read in unless ``units`` is false)."""
        if self.kind == "linear":
            if linear:
                return f"F = {self.stall:.6g} N - {self.slope:.6g} N*s/m * v"
            return f"M = {self.stall:.6g} N*m - {self.slope:.6g} N*m*s * omega"
        if self.kind == "table":
            return f"table of {len(self.speeds)} (speed, torque) points"
        if not units:
            return f"{'F' if linear else 'M'} = {self.text}"
        if linear:
            return f"F = {self.text} (in N, of v in m/s and t in s)"
        return f"M = {self.text} (in N*m, of omega in rad/s and t in s)"


@dataclass
class Flywheel:
    """An added moment of inertia (kg m^2) on a link, about the link's centre of mass
    (a flywheel is balanced: its centre is on the link's axis of rotation)."""

    link: str
    inertia: float


@dataclass
class Simulation:
    """How to integrate the equation of motion."""

    duration: float
    step: float | None = None  # rk4: the fixed step; adaptive: the output step
    method: str = "rk4"
    rtol: float = 1e-8
    atol: float = 1e-10
    speed0: float = 0.0  # the driver's speed at the start (rad/s or m/s)
    revolutions: float | None = None  # stop after this many turns of the driver
    steady: float | None = None  # stop when a revolution's mean speed changes by this fraction
    formulation: str | None = None  # "reduced", "multibody"; None: chosen by the file
    tolerance: float | None = None  # multibody: the largest constraint violation (m)
    rates: dict = field(default_factory=dict)  # multibody: joint -> initial rate
    pose: dict = field(default_factory=dict)  # multibody: joint -> (value, kind, path)
    speed0_given: bool = False  # 'from' was in the file
    stop: Any = None  # multibody: 'stop when', an Expression (a condition)
    singular: str = "pass"  # multibody: at a singular position: pass, stop, keep branch
    where: tuple = field(default_factory=tuple)
