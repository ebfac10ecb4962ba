"""Forward dynamics of a one-degree-of-freedom machine driven by a motor
(``mechsolve simulate``).

The equation of motion comes from the force analysis itself. At a state (phi, omega,
epsilon) of the driver, the driver effort that the kinetostatic analysis returns
(:func:`mechsolve.core.evaluate.forces`: inertia of every body, gravity, springs, dampers,
conditional loads) is, by Lagrange's equation of the reduced system,

    E(phi, omega, epsilon) = J(phi) epsilon + 1/2 J'(phi) omega^2 - Q(phi, omega, t)

which is linear in epsilon: ``J(phi) = E(phi, omega, 1) - E(phi, omega, 0)``. The motor
supplies ``M(omega, t)``, so the driver's acceleration is

    epsilon = (M(omega, t) - E(phi, omega, 0)) / J(phi).

Nothing is reduced by hand: a model that the sweep can analyse can be simulated, with the
same loads. ``J'(phi) = 2 dT/dt`` at omega = 1, epsilon = 0.

The kinematics at a new angle is solved next to a reference sweep over the machine's
cycle (which fixes the branches; a crank's configuration repeats every turn, a geared
machine's after several: :mod:`.cycle`), and the integration is
RK4 with a fixed step (Mathcad's ``rkfixed``) or scipy's ``solve_ivp``. Along the computed
motion the states and every joint force follow from :mod:`mechsolve.core.evaluate`.

The package: :mod:`.model` (the reduced model: the equation of motion from the force
analysis), :mod:`.tables` (its tabulation over a turn for the integrator),
:mod:`.integrators` (RK4 and scipy's methods, where a run stops), :mod:`.results` (the
states and forces along the motion, the summary) and :mod:`._run` (:func:`simulate`).
"""

from mechsolve.analyses.dynamics._run import check_size, simulate
from mechsolve.analyses.dynamics.constants import MAX_STEPS, TABLE_MAX, TABLE_MIN
from mechsolve.analyses.dynamics.cycle import _repeats
from mechsolve.analyses.dynamics.integrators import (
    Trajectory,
    _acceleration,
    _with_flywheel,
    integrate,
)
from mechsolve.analyses.dynamics.model import ReducedModel, drive_torque
from mechsolve.analyses.dynamics.results import SimulationResults, steady_fluctuation
from mechsolve.analyses.dynamics.tables import _harmonics, _spectral_samples, _Table

__all__ = [
    "MAX_STEPS",
    "TABLE_MAX",
    "TABLE_MIN",
    "ReducedModel",
    "SimulationResults",
    "Trajectory",
    "_Table",
    "_acceleration",
    "_harmonics",
    "_repeats",
    "_spectral_samples",
    "_with_flywheel",
    "check_size",
    "drive_torque",
    "integrate",
    "simulate",
    "steady_fluctuation",
]
