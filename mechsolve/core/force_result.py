"""What the force analysis gives: reactions, the driver's effort, energies and the power
balance over the positions (see :mod:`.forces`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np


@dataclass
class FrictionResult:
    """What friction changes at every position.

    Attributes
    ----------
    friction
        Per joint: the friction's magnitude, a force (N, a slider) or a moment (N m, a
        pin), Coulomb and viscous parts together.
    loss
        Per joint: the power friction dissipates, ``t_j |slip_j|`` (W, >= 0).
    ideal_effort
        The driving effort the same motion and loads need without friction.
    locked
        The self-locking positions (no finite driving effort).
    iterations
        The largest number of Newton steps a position took.
    """

    friction: dict[str, np.ndarray] = field(default_factory=dict)
    loss: dict[str, np.ndarray] = field(default_factory=dict)
    ideal_effort: np.ndarray | None = None
    locked: np.ndarray | None = None
    iterations: int = 0

    @property
    def power(self) -> np.ndarray:
        """The power lost in all the joints (W)."""
        return sum(self.loss.values())  # type: ignore[return-value]


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
    # the joints' friction (None: ideal joints), see mechsolve.core.friction
    friction: FrictionResult | None = None
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
    def power_friction(self) -> np.ndarray | float:
        """The power lost in the joints' friction (W); 0 with ideal joints."""
        return 0.0 if self.friction is None else self.friction.power

    @property
    def residual(self) -> np.ndarray:
        """Power balance: P_driver - dT/dt - dV/dt + P_loads - P_friction (W), zero to
        rounding."""
        return (
            self.power_input
            - self.kinetic_rate
            - self.potential_rate
            + self.power_loads
            - self.power_friction
        )
