"""The cam's geometry, below every layer that uses it: the follower's motion laws
(:mod:`.laws`), the motion program (:mod:`.program`), the profile by inversion
(:mod:`.profile`), the reading of a cam's follower, program and base values (:mod:`.read`)
and the curves a cam contact uses (:mod:`.curves`). ``mechsolve cam`` designs a cam alone
with them; the cam contact joint (:mod:`mechsolve.joints.cam_contact`) builds a cam inside
a linkage from them.
"""
