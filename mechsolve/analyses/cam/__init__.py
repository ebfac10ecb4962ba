"""Cam design: motion laws, the profile by inversion, pressure angle, curvature and
undercutting, base size for an allowable pressure angle (``mechsolve cam FILE``).

Modules: :mod:`.laws` (follower motion laws, analytic), :mod:`.program` (a cycle of rise,
dwell and return segments), :mod:`.profile` (the inversion for every follower type),
:mod:`.design` (base size), :mod:`.model` (the cam file), :mod:`.writers` (CSV, DXF, plots).
"""
