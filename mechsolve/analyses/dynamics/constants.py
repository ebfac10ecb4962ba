"""The settings of the forward dynamics (see :mod:`mechsolve.analyses.dynamics`)."""

from __future__ import annotations

import math

NEAR_SINGULAR = 1e-6  # sin of a loop's transmission angle below this: solved beside it
# the exact path (every stage solved): within this indicator of a singular position, the
# equation of motion is its limit from points BESIDE_STEP and twice that away
NEAR_EXACT, BESIDE_STEP = 3e-4, 1e-3
SWITCH_GRID = math.radians(0.05)  # where a switching load's switches are looked for first
TABLE_MIN, TABLE_MAX = 360, 61440  # intervals of the integrator's table over a turn
TABLE_FLOOR = 1e-13  # the tables' tolerance for a column, at least this of the largest's
SPLINE_FLOOR = 1e-8  # splines through unconverged samples: good to this of the largest
MAX_STEPS = 200_000  # integrator steps (and output rows) allowed unless asked for more
# memory per value of the results along a motion (its states, forces, CSV and plots): the
# peak resident memory of seed 004 over 11 001 rows of 84 columns is 87-130 bytes a value
BYTES_PER_VALUE = 100
# at rest (stalled): the driver stays this close (rad, or m) to its last position over this
# part of the run at its end
REST_BAND, REST_SPAN = math.radians(0.01), 0.05
REST_BAND_LINEAR = 1e-4  # m: the band for a linear driver
