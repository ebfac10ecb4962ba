"""The analysis of a model kept between solves of the same model, made safe by a content
key and a copy per call.

Building an :class:`~mechsolve.core.sweep.Analysis` (the constraint system, the groups'
plan, the points, the scale) is some 45 us, about a tenth of a whole ``solve`` call of
the four-bar. Solving the same model again (an optimiser's loop, watch mode, a script)
builds the same analysis, so :func:`analysis_for` keeps the last few and returns a copy
of the kept one when the model is the same object **and** its content is unchanged:

* the **content key** is a snapshot of everything the analysis is built from: the
  ground's points, every field of every link and joint, the driver and the solver
  options (and the method asked for), pickled to bytes. A model is a mutable dataclass,
  edited in code (a point moved, a link added, the driver replaced, a tolerance
  changed): each such edit changes the bytes, so the next solve builds a new analysis.
  A field that cannot be pickled makes the model not kept at all: its analysis is built
  per call as before;
* the **copy per call**: an analysis keeps per-call state (the groups' caches of
  intermediate results keyed by their state, ``redundancy`` set by the start assembly),
  so every call gets its own shallow copy of the analysis and of each group, with empty
  caches. Two threads solving the same model share nothing they write;
* only plans made of the closed-form groups (driver link, driven slider, the RRR, RRP and
  RPR dyads) are kept: those keep no state between calls but their caches. A plan with a
  Newton group (its continuation state, where its sweep stopped) is built per call.
"""

from __future__ import annotations

import pickle
import threading

from mechsolve.core.program import program_for
from mechsolve.core.sweep import Analysis
from mechsolve.groups.closed import RPR, RRP, RRR, DrivenSlider, DriverLink
from mechsolve.model import Mechanism

KEPT_MAX = 4  # analyses kept (the most recently solved models)

# (model, content key, kept analysis, the model's validated snapshot it was last found by)
_KEPT: list[list] = []  # most recent last
_LOCK = threading.Lock()
_GROUPS = (DriverLink, DrivenSlider, RRR, RRP, RPR)


def content_key(mech: Mechanism, method: str | None) -> tuple | None:
    """What the analysis of ``mech`` is built from, as a snapshot: the types of its
    parts, and every field of its ground, links, joints, driver and solver options
    serialised by :mod:`pickle` (in C: some 4 us for a four-bar; a NumPy array with its
    type, shape and values). A model with a field that cannot be pickled (a motion law
    written as a lambda) gets None: its analysis is not kept."""
    links, joints, driver = mech.links, mech.joints, mech.driver
    try:
        data = pickle.dumps(
            (
                mech.ground,
                [lk.__dict__ for lk in links],
                [j.__dict__ for j in joints],
                driver.__dict__ if driver is not None else None,
                mech.solver.__dict__,
            ),
            pickle.HIGHEST_PROTOCOL,
        )
    except Exception:  # (pickle raises PicklingError, TypeError, AttributeError, ...)
        return None
    kinds = (type(driver), type(mech.solver), *map(type, links), None, *map(type, joints))
    return (method, kinds, data)


def _keepable(an: Analysis) -> bool:
    return not an.redundant and all(type(g) in _GROUPS for g in an.groups + an.plan)


def _group_copy(g):
    out = object.__new__(type(g))
    d = out.__dict__
    d.update(g.__dict__)
    d.pop("_ctoken", None)  # the caches are the call's own
    d.pop("_cache", None)
    return out


def _per_call(an: Analysis) -> Analysis:
    """A copy of ``an`` for one call: its own groups (with empty caches) and attributes."""
    out = object.__new__(Analysis)
    out.__dict__.update(an.__dict__)
    groups = [_group_copy(g) for g in an.groups]
    out.groups = groups
    if an.plan is an.groups:
        out.plan = groups
    else:
        same = {id(g): c for g, c in zip(an.groups, groups)}
        out.plan = [same.get(id(g)) or _group_copy(g) for g in an.plan]
    return out


def analysis_for(mech: Mechanism, method: str | None = None, checked: bool = False) -> Analysis:
    """The analysis of ``mech`` for one call: a copy of the kept one when ``mech`` is the
    model last solved with the same content, else a new one (kept when it can be).

    ``checked``: the caller has just run ``mech.ensure_valid()``, so the model's validated
    snapshot (everything the content key holds, and more) is its current content. When
    it is the very snapshot object the kept analysis was last found by, nothing was
    edited since, and the content key is not computed again (``ensure_valid`` keeps that
    object while the content is unchanged and makes a new one after any edit). The
    analysis then holds that snapshot as ``solved_snapshot``, at no cost: the content its
    results were solved for (see
    :meth:`~mechsolve.results.results.Results.model_as_solved`)."""
    snap = mech.__dict__.get("_validated") if checked else None
    if not isinstance(snap, tuple):
        snap = None
    an = _found(mech, method, snap)
    if checked:
        an.solved_snapshot = snap  # (None: a model that cannot be pickled)
    return an


def _found(mech: Mechanism, method: str | None, snap: tuple | None) -> Analysis:
    if snap is not None:
        with _LOCK:
            kept = next(
                (e[2] for e in _KEPT if e[0] is mech and e[3] is snap and e[1][0] == method),
                None,
            )
        if kept is not None:
            return _per_call(kept)
    key = content_key(mech, method)
    if key is None:
        return Analysis(mech, method)
    with _LOCK:
        entry = next((e for e in _KEPT if e[0] is mech and e[1] == key), None)
        if entry is not None:
            entry[3] = snap
    if entry is not None:
        return _per_call(entry[2])
    kept = Analysis(mech, method)
    if not _keepable(kept):
        return kept
    kept.program = program_for(kept)  # a chain of closed forms: its own sweep
    with _LOCK:
        _KEPT[:] = [e for e in _KEPT if e[0] is not mech][-(KEPT_MAX - 1) :]
        _KEPT.append([mech, key, kept, snap])
    return _per_call(kept)


def forget(mech: Mechanism | None = None) -> None:
    """Drop every kept analysis (tests, and a program that wants the memory back), or
    only that of ``mech`` (a model solved once, whose analysis would push out another's)."""
    with _LOCK:
        if mech is None:
            _KEPT.clear()
        else:
            _KEPT[:] = [e for e in _KEPT if e[0] is not mech]
