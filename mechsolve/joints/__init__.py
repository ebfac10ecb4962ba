"""The joint kinds: one class per kind, each in its own module, holding everything the kind
knows (the joint contract, :class:`~mechsolve.joints.base.Joint`).

A kind is read from the file (its keys and its reader), checked, counted by Grübler's
formula, turned into equations with their Jacobian, velocity and acceleration terms
(:class:`~mechsolve.joints.base.Constraint`), read out as named reaction components,
described in the report and drawn. The rest of mechsolve asks the joint; it never tests a
joint's kind. The kinds are listed in :mod:`mechsolve.joints.registry`.

Imports the base layer only: the model holds joints, the system assembles their equations.
"""
