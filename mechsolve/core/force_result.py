"""What the force analysis gives: reactions, the driver's effort, energies and the power
balance over the positions (see :mod:`.forces`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np


@dataclass
class ForceResult:
    """Reactions, driver effort, energies and the power balance over the positions.

    The energies and the power balance are computed when first read (a sweep that only
    wants reactions does not pay for them).
    """

    lam: np.ndarray  # (N, nc) Lagrange multipliers
    effort: np.ndarray  # (N,) driving torque (N m) or force (N) on the driven link
    reactions: dict[str, dict[str, np.ndarray]]
    active: dict[str, np.ndarray]  # per conditional load: where it acts
    power_loads: np.ndarray  # power of the applied loads (W)
    singular: list[tuple[int, str]] = field(default_factory=list)  # (position, group label)
    ok: np.ndarray | None = None
    load_power: dict[str, np.ndarray] = field(default_factory=dict)  # power of each load
    nonunique: dict[str, set[str]] = field(default_factory=dict)  # joint -> components
    stroke_extremes: list[tuple[float, float]] = field(default_factory=list)
    speed: np.ndarray | float = 0.0  # the driver's speed at each position (rad/s or m/s)
    # singular positions whose driver effort is its limit along the motion
    effort_by_limit: list[int] = field(default_factory=list)
    # positions next to a singular one (see mechsolve.core.conditioning), where the computed
    # effort carries rounding amplified by 1/s^3; and those of them whose effort is its
    # limit along the motion
    near_singular: dict[int, float] = field(default_factory=dict)  # position -> s
    effort_near_limit: list[int] = field(default_factory=list)
    # (kinetic, kinetic rate, potential, potential rate) on demand
    energy_terms: Callable[[], tuple] | None = field(default=None, repr=False)
    _energies: tuple | None = field(default=None, repr=False)

    def _terms(self) -> tuple:
        if self._energies is None:
            self._energies = self.energy_terms()
        return self._energies

    @property
    def kinetic(self) -> np.ndarray:
        """Kinetic energy T (J)."""
        return self._terms()[0]

    @property
    def kinetic_rate(self) -> np.ndarray:
        """dT/dt (W)."""
        return self._terms()[1]

    @property
    def potential(self) -> np.ndarray:
        """Potential energy V of gravity and unconditional springs (J)."""
        return self._terms()[2]

    @property
    def potential_rate(self) -> np.ndarray:
        """dV/dt (W)."""
        return self._terms()[3]

    @property
    def power_input(self) -> np.ndarray:
        """Power of the driver (W)."""
        return self.effort * self.speed

    @property
    def residual(self) -> np.ndarray:
        """Power balance: P_driver - dT/dt - dV/dt + P_loads (W), zero to rounding."""
        return self.power_input - self.kinetic_rate - self.potential_rate + self.power_loads
