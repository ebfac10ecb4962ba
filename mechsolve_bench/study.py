"""Benchmark of design studies (``mechsolve bench --case study``): designs per second.

The designs are four-bar crank-rockers (crank and coupler lengths varied over a grid,
uniform bars, gravity, a conditional load at the coupler point, 361 positions with
kinematics and forces). Measured in one run:

* the batch (:func:`mechsolve.analyses.batch.solve_designs`): every design's kinematics and forces
  as one computation over design x position;
* ``mechsolve.solve`` called once per design (what a user's loop over designs does);
* a hand-written numpy closed form of the same designs' kinematics and kinetostatics,
  vectorised over designs and positions (:mod:`mechsolve_bench.fourbar_batch`, written
  independently of the solver), with the batch's error against it;
* the same for a study without forces: the batch asked for kinematics only against a
  hand-written closed form of what such a study reads (angles, rates, the transmission
  angle: ``fourbar_batch.kinematics_only``);

* the batch from the study's values (:func:`mechsolve.analyses.study.family.solve_family`):
  the study's file parsed once, each call stacks the designs' numbers from their values,
  no design parsed or read back. This is how a study solves its designs, so the targets
  are read on these rows; the rows of parsed designs are kept beside them.

The targets printed: the batch at most 1.5x its closed form with forces, at most 1.2x
kinematics only, each read twice: on the wall-time rows (six calls interleaved in a
shuffled order), and in CPU time (``time.thread_time``) of the batch and its closed form
alone, alternating call by call, medians of many rounds, which other processes on a
shared machine do not move. The separate solves' ratio is information only.
* the study's executor (each design's row: its figures, exact limit positions and
  work included) in this process (and, for comparison, with every design parsed as
  before the design family), on the local pool with 1 and 2 workers, and on a
  Dask local cluster when dask is installed (its overhead over the pool). The rows of
  every executor are compared: the same table, whichever runs it.
"""

from __future__ import annotations

import math
import statistics
import time

import numpy as np

__all__ = ["case_study"]

_FOURBAR = """
name: bench four-bar study
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [87.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [26.5, 0]}, mass: 0.05 kg, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [105.6, 0], P: {length: 60, angle: 30}},
            mass: 0.2 kg, uniform_bar: [A, B]}
  rocker: {points: {O4: [0, 0], B: [59, 0]}, mass: 0.11 kg, uniform_bar: [O4, B]}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, speed: 1 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 1 deg}
gravity: 9.81 m/s^2
loads:
  pull: {force: [0, -2 N], at: P, when: P.vx > 0}
"""


def _grid(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Crank and coupler lengths (mm) of about ``n`` designs, all Grashof crank-rockers."""
    k = max(2, int(math.ceil(math.sqrt(n))))
    a = np.linspace(20.0, 30.0, k)
    b = np.linspace(95.0, 110.0, k)
    A, B = np.meshgrid(a, b, indexing="ij")
    return A.ravel()[:n], B.ravel()[:n]


def _study(n: int):
    from mechsolve.analyses.study.designs import make_study
    from mechsolve.model.source import load_text

    a, b = _grid(n)
    opts = [
        "links.crank.points.A[0]=" + ", ".join(f"{x:.6g}" for x in sorted(set(a))) + " mm",
        "links.coupler.points.B[0]=" + ", ".join(f"{x:.6g}" for x in sorted(set(b))) + " mm",
    ]
    return make_study(load_text(_FOURBAR, "bench-study.yaml"), opts)


def _median(f, repeats: int) -> tuple[float, object]:
    ts, out = [], None
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        out = f()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts), out


def _wrapped(x: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * x))


def _force_errors(batch, kin: dict, frc: dict, n: int) -> dict[str, float]:
    """The batch with forces against the closed form, every design and position (the
    torque away from the samples where the pull switches on or off)."""
    e_th = e_w = e_al = e_t = 0.0
    for k in range(n):
        r = batch.results(k)
        rk = r.link("rocker")
        e_th = max(e_th, float(np.max(np.abs(_wrapped(rk.angle - kin["th4"][k])))))
        e_w = max(e_w, float(np.max(np.abs(rk.omega - kin["w4"][k]))))
        e_al = max(e_al, float(np.max(np.abs(rk.alpha - kin["al4"][k]))))
        calm = np.abs(kin["P.vx"][k]) > 1e-6
        e_t = max(e_t, float(np.max(np.abs(r.forces.effort - frc["torque"][k])[calm])))
    return {
        "rocker angle [rad]": e_th,
        "rocker omega [rad/s]": e_w,
        "rocker alpha [rad/s^2]": e_al,
        "torque [N m]": e_t,
    }


def _kinematic_errors(batch, kin: dict, n: int) -> dict[str, float]:
    """The kinematics-only batch against the kinematics-only closed form: the coupler's
    and rocker's angles, the rocker's rate, the sine of the transmission angle (the
    loop's indicator), and the rocker's acceleration where the batch has it."""
    e = dict.fromkeys(("th3", "th4", "w4", "mu", "al4"), 0.0)
    for k in range(n):
        r = batch.results(k)
        cp, rk = r.link("coupler"), r.link("rocker")
        e["th3"] = max(e["th3"], float(np.max(np.abs(_wrapped(cp.angle - kin["th3"][k])))))
        e["th4"] = max(e["th4"], float(np.max(np.abs(_wrapped(rk.angle - kin["th4"][k])))))
        e["w4"] = max(e["w4"], float(np.max(np.abs(rk.omega - kin["w4"][k]))))
        loop = next(i for i, g in enumerate(r.analysis.plan) if g.n_modes == 2)
        ind = r.solution.indicator[loop]
        e["mu"] = max(e["mu"], float(np.max(np.abs(ind - kin["sin_mu"][k]))))
        if "al4" in kin and r.solution.has_acceleration:
            e["al4"] = max(e["al4"], float(np.max(np.abs(rk.alpha - kin["al4"][k]))))
    out = {
        "coupler angle [rad]": e["th3"],
        "rocker angle [rad]": e["th4"],
        "rocker omega [rad/s]": e["w4"],
        "sin(transmission angle) [-]": e["mu"],
    }
    if "al4" in kin and batch.results(0).solution.has_acceleration:
        out["rocker alpha [rad/s^2]"] = e["al4"]
    return out


def _cpu_ratio(label: str, cpu: dict[str, float], target: float, rounds: int) -> str:
    """The batch from the study's values against its closed form in CPU time (medians of
    ``rounds`` interleaved runs of the two, :func:`mechsolve_bench.interleaved_cpu`)."""
    r = cpu["batch"] / cpu["ref"]
    verdict = "met" if r <= target else "NOT met"
    return (
        f"  {label}, CPU time (thread_time, medians of {rounds} interleaved runs of the two "
        f"alone): closed form {1e3 * cpu['ref']:.2f} ms, batch from the study's values "
        f"{1e3 * cpu['batch']:.2f} ms = {r:.2f}x (at most {target}: {verdict})"
    )


def _same(a: list[dict], b: list[dict]) -> bool:
    """Two studies' rows equal to the last bit (blank figures alike)."""
    if len(a) != len(b):
        return False
    for x, y in zip(a, b):
        if list(x) != list(y):
            return False
        for key, v in x.items():
            w = y[key]
            if isinstance(v, float) and isinstance(w, float):
                if not (math.isnan(v) and math.isnan(w)) and (
                    np.float64(v).view(np.int64) != np.float64(w).view(np.int64)
                ):
                    return False
            elif v != w:
                return False
    return True


def case_study(quick: bool = False, designs: int | None = None):
    """Designs per second: the batch, separate solves, the hand-written closed form, and
    the study's executors (see the module's docstring)."""
    import mechsolve as ms
    from mechsolve.analyses.batch import solve_designs
    from mechsolve.analyses.study import execute as ex
    from mechsolve.analyses.study.family import DesignFamily, solve_family
    from mechsolve_bench import Case, Row, interleaved_cpu
    from mechsolve_bench.fourbar_batch import kinematics, kinematics_only, kinetostatics

    n_batch = 24 if quick else 1000
    study = _study(n_batch)
    nb_ = len(study)
    case = Case(
        "study",
        f"a four-bar design study: {nb_} designs x 361 positions, kinematics and forces",
    )
    mechs = [study.mechanism(k) for k in range(nb_)]
    vals = np.array([study.values(k) for k in range(nb_)]) / 1e3  # mm -> m
    u = np.linspace(0.0, 2 * math.pi, 361)
    reps = 3 if quick else 7

    def closed():
        kin = kinematics(vals[:, 0], vals[:, 1], 0.059, 0.0875, u)
        return kin, kinetostatics(kin)

    # a study without forces reads positions, rates and transmission angles (its
    # figures), no accelerations: both sides compute what it reads (both links' angles
    # and rates, the transmission angle's sine; see the line printed below)
    def closed_kin():
        return kinematics_only(vals[:, 0], vals[:, 1], 0.059, 0.0875, u, acceleration=False)

    def batch_kin():  # (solve_designs checks each design's content first, as solve does)
        return solve_designs(mechs, forces=False, acceleration=False)

    # the design family as a study's chunk gets it (execute.study_family): the study's
    # file parsed once per study and process, and a family of the chunk's values made
    # from it (with_values: the parsed file and the values' conversions to SI shared);
    # each call stacks the designs' numbers from the values (no design parsed or read)
    whole = DesignFamily(study.source, study.params, vals[:0]).prepare()
    table = np.array([study.values(k) for k in range(nb_)])

    def family():
        return whole.with_values(table)

    def fam_forces():
        return solve_family(family())

    def fam_kin():
        return solve_family(family(), forces=False, acceleration=False)

    # one call first: imports, and the allocator's first large arrays (a process's first
    # batch costs up to twice as much: the memory's pages are mapped as it goes)
    solve_designs(mechs)
    batch_kin()
    fam_forces()
    fam_kin()
    # interleaved in a shuffled order, so that all six see the same moments of a shared
    # machine and none always follows the same one (what the one before freed decides
    # whether a call's arrays fault their pages in anew)
    times: dict[str, list[float]] = {}
    got: dict[str, object] = {}
    calls = {
        "closed": closed,
        "batch": lambda: solve_designs(mechs),
        "closed_kin": closed_kin,
        "batch_kin": batch_kin,
        "fam": fam_forces,
        "fam_kin": fam_kin,
    }
    order = list(calls)
    rng = np.random.default_rng(0)
    for _ in range(reps):
        rng.shuffle(order)
        for name in order:
            t, got[name] = _median(calls[name], 1)
            times.setdefault(name, []).append(t)
    t_cfs, t_bs, t_cks = times["closed"], times["batch"], times["closed_kin"]
    t_bks, t_fs, t_fks = times["batch_kin"], times["fam"], times["fam_kin"]
    kin, frc = got["closed"]
    batch, kin_only, batch_k = got["batch"], got["closed_kin"], got["batch_kin"]
    fam_b, fam_k = got["fam"], got["fam_kin"]
    t_cf, t_b = statistics.median(t_cfs), statistics.median(t_bs)
    t_ck, t_bk = statistics.median(t_cks), statistics.median(t_bks)
    t_f, t_fk = statistics.median(t_fs), statistics.median(t_fks)
    t_sep, _ = _median(lambda: [ms.solve(m) for m in mechs], 1)
    # the ratios read against the targets again in CPU time (time.thread_time: what
    # other processes on a shared machine do not add to), each side alternating with its
    # own reference call by call in one loop: a run's verdict then does not hinge on
    # when another process woke up, nor on what a force batch of the loop above freed
    cpu_k = interleaved_cpu({"ref": closed_kin, "batch": fam_kin}, 7 if quick else 31)
    cpu_f = interleaved_cpu({"ref": closed, "batch": fam_forces}, 5 if quick else 15)
    case.rows.append(
        Row(
            "hand-written closed form, every design at once (reference)",
            t_cf,
            {},
            f"{nb_ / t_cf:.0f} designs/s",
        )
    )
    case.rows.append(
        Row(
            "mechsolve batch (solve_designs), every design at once",
            t_b,
            _force_errors(batch, kin, frc, nb_),
            f"{nb_ / t_b:.0f} designs/s; {int(batch.batched.sum())} of {nb_} in the batch; "
            "errors against the closed form",
        )
    )
    case.rows.append(
        Row(
            "hand-written closed form, kinematics only (reference)",
            t_ck,
            {},
            f"{nb_ / t_ck:.0f} designs/s; angles, rates and the transmission angle",
        )
    )
    case.rows.append(
        Row(
            "mechsolve batch of parsed designs (solve_designs), kinematics only",
            t_bk,
            _kinematic_errors(batch_k, kin_only, nb_),
            f"{nb_ / t_bk:.0f} designs/s; {int(batch_k.batched.sum())} of {nb_} in the "
            "batch; each design's content checked first, as solve does (an edited model "
            "is validated again); errors against the closed form",
        )
    )
    case.rows.append(
        Row(
            "mechsolve batch from the study's values (no parsed designs), with forces",
            t_f,
            _force_errors(fam_b, kin, frc, nb_),
            f"{nb_ / t_f:.0f} designs/s; {int(fam_b.batched.sum())} of {nb_} in the batch; "
            "what a study solves (solve_family); errors against the closed form",
        )
    )
    case.rows.append(
        Row(
            "mechsolve batch from the study's values (no parsed designs), kinematics only",
            t_fk,
            _kinematic_errors(fam_k, kin_only, nb_),
            f"{nb_ / t_fk:.0f} designs/s; {int(fam_k.batched.sum())} of {nb_} in the "
            "batch; errors against the closed form",
        )
    )
    case.rows.append(
        Row("mechsolve.solve once per design", t_sep, {}, f"{nb_ / t_sep:.0f} designs/s")
    )
    lines = [
        f"ratio batch of parsed designs / closed form, with forces: {t_b / t_cf:.2f}, "
        f"kinematics only: {t_bk / t_ck:.2f} (information: a study does not solve its "
        "designs so; the parsed designs' content checks are in these rows)",
        f"ratio batch from the study's values / closed form, with forces: {t_f / t_cf:.2f} "
        f"(target 3, read on this row: a study solves its designs so; at most 1.5: "
        f"{'met' if t_f <= 1.5 * t_cf else 'NOT met'})",
        _cpu_ratio("with forces", cpu_f, 1.5, 5 if quick else 15),
        f"ratio batch from the study's values / closed form, kinematics only: "
        f"{t_fk / t_ck:.2f} (target 3, read on this row: at most 1.2: "
        f"{'met' if t_fk <= 1.2 * t_ck else 'NOT met'})",
        _cpu_ratio("kinematics only", cpu_k, 1.2, 7 if quick else 31),
        "kinematics only, what each side computes: both sides the coupler's and rocker's "
        "angles and rates and the sine of the transmission angle (a study row reads the "
        "rocker's angle and rate and the transmission angle); the closed form also forms "
        "the joints A and B, the batch also each link's cosine and sine and A's velocity "
        "(the state a design's Results is made of) and screens every design for singular "
        "positions",
        f"separate solves / batch: {t_sep / t_b:.1f}; separate solves / closed form: "
        f"{t_sep / t_cf:.1f} (information only: {1e3 * t_sep / nb_:.2f} ms a design)",
    ]

    # the study's executors: each design's row (figures included)
    n = designs or (12 if quick else 420)
    study = _study(n)
    n = len(study)
    t_one, rows_one = _median(lambda: ex.execute(study, jobs=1).rows, 1)
    case.rows.append(
        Row(
            f"study of {n} designs (rows with figures), this process",
            t_one,
            {},
            f"{n / t_one:.1f} designs/s",
        )
    )
    t_p2, rows_p2 = _median(lambda: ex.execute(study, jobs=2).rows, 1)
    case.rows.append(
        Row("the same study on a pool of 2 processes", t_p2, {}, f"{n / t_p2:.1f} designs/s")
    )
    ex.FAMILY = False  # every design parsed and read back: the study before the family
    try:
        t_old, rows_old = _median(lambda: ex.execute(study, jobs=1).rows, 1)
    finally:
        ex.FAMILY = True
    case.rows.append(
        Row(
            "the same study, every design parsed (before the design family)",
            t_old,
            {},
            f"{n / t_old:.1f} designs/s",
        )
    )
    lines.append(
        f"study in this process: {n / t_old:.1f} -> {n / t_one:.1f} designs/s with the design "
        f"family ({t_old / t_one:.2f}x); same rows: {'yes' if _same(rows_old, rows_one) else 'NO'}"
    )
    same = [r["status"] for r in rows_p2] == [r["status"] for r in rows_one]
    lines.append(
        f"pool of 2 / 1 process: speed-up {t_one / t_p2:.2f} (target 1.7 on 2 cores; "
        f"the machine's other load counts); same rows: {'yes' if same else 'NO'}"
    )
    try:
        import dask.distributed  # noqa: F401
    except ImportError:
        lines.append("dask: not installed (pip install 'mechsolve[dask]'), skipped")
    else:
        t_d, rows_d = _median(lambda: ex.execute(study, jobs=2, dask=True).rows, 1)
        case.rows.append(Row("the same study on a Dask local cluster, 2 workers", t_d, {}, ""))
        same_d = [r["status"] for r in rows_d] == [r["status"] for r in rows_one]
        lines.append(
            f"Dask local cluster over the pool: +{t_d - t_p2:.2f} s ({t_d / t_p2:.2f}x, the "
            f"cluster's start included); same rows: {'yes' if same_d else 'NO'}"
        )
    case.lines = lines
    return case
