"""Watch mode (``mechsolve run FILE --watch``): run again whenever the file is saved.

Editing a design is a loop: change a length, save, look. The watcher runs the job once,
then after every save of the file (editors that save by writing a new file and renaming
it are seen too), prints the summary and the figures that moved since the last good run,
and on a mistake in the file prints the message (file, key path, line) and keeps waiting:
a user's error never ends the watch; Ctrl-C does (exit 130). While the file is broken,
the output folder holds ``STALE.txt`` (the error, and when the last good run was), so
the plots there are never taken for the file as it is; the next good run removes it. A
save whose run fails after writing some files (a requirement that cannot be checked
comes after the table and the plots) says which files it wrote, and the marker names
only the files it left from an earlier run (there is none when it rewrote them all).
File events come from ``watchfiles`` (an optional dependency: ``pip install
"mechsolve[watch]"``), not from a polling loop.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from mechsolve.base.errors import InputError, MechsolveError

__all__ = [
    "STALE",
    "changes",
    "clear_stale",
    "figures_of",
    "files_of",
    "mark_stale",
    "watch_file",
]


def figures_of(res: Any, units: Any = None) -> dict[str, tuple[float, str]]:
    """The figures a designer watches, ``{name: (value, unit)}``, as the run's summary
    gives them: from the sweep its figures come from (:func:`mechsolve.api.for_plots`,
    1 degree or finer with the exact limit positions; the file's step only for the count
    of positions) and in the units it prints (``units``, an
    :class:`~mechsolve.base.units.OutputUnits`; default: the ones the summary was printed
    in, else the file's). Positions solved, each rocker's swing and slider's stroke, time
    ratios, each loop's smallest transmission angle, the driving effort's largest and
    smallest values, the work per cycle, each joint's peak reaction; a figure the summary
    says grows without bound (a toggle) is left out."""
    out: dict[str, tuple[float, str]] = {}
    if res is None:
        return out
    from mechsolve.base.units import pretty_unit
    from mechsolve.results.run import for_plots

    U = units or getattr(res, "_shown", None) or res.mechanism.output_units()
    src = for_plots(res.mechanism, res)
    out["positions solved"] = (float(sum(bool(x) for x in res.ok)), "")
    for lp in src.limit_positions():
        if lp.travels:
            v, unit = U.show(lp.swing, "m")
            out[f"{lp.name} stroke"] = (float(v), pretty_unit(unit))
        else:
            v, unit = U.show(math.degrees(lp.swing), "deg")
            out[f"{lp.name} swing"] = (float(v), pretty_unit(unit))
        if lp.time_ratio is not None:
            out[f"{lp.name} time ratio"] = (lp.time_ratio, "")
    for t in src.transmission_angles():
        v, unit = U.show(math.degrees(t.angle), "deg")
        out[f"min transmission angle, {t.group}"] = (float(v), pretty_unit(unit))
    if res.forces is not None and src.forces is not None:
        out.update(_force_figures(res, src, U))
    return out


def _force_figures(res: Any, src: Any, U: Any) -> dict[str, tuple[float, str]]:
    """The driving effort's max and min, the work and the peak reactions of ``src`` (the
    summary's sweep) as :meth:`~mechsolve.results.summary.Summary.force_summary` prints
    them: the same scale (kN and kN*m for large SI values) and units."""
    import numpy as np

    from mechsolve.base.units import pretty_unit
    from mechsolve.results.summary import edge_growth, or_zero, print_scale, unbounded_towards

    out: dict[str, tuple[float, str]] = {}
    kind, unit = res.effort_name
    e = np.asarray(src.driving_effort, float)
    if not np.any(np.isfinite(e)):
        return out
    scale, unit = print_scale(e, unit, U)
    if not res.idle_driver():
        for name, sign in (("max", 1.0), ("min", -1.0)):
            i = int(np.nanargmax(sign * e))
            if unbounded_towards(src, sign * e, i) is None and (
                edge_growth(src, lambda x, k, s=sign: s * src.effort_at(x, k)) is None
            ):
                out[f"driving {kind}, {name}"] = (float(e[i] / scale), pretty_unit(unit))
    work, _why = src._work_why()
    if math.isfinite(work):
        if U.energy == "J":
            big = abs(work) >= 1e4
            out["work of the driver"] = (work / (1e3 if big else 1.0), "kJ" if big else "J")
        else:
            v, wunit = U.show(work, "J")
            out["work of the driver"] = (float(v), pretty_unit(wunit))
    kf = U.convert("N")[0]
    kilo = unit in ("kN", "kN*m") and U.force == "N"
    fscale, funit = (1e3 / kf, "kN") if kilo else (1.0 / kf, U.force)
    g = src.forces
    peaks = []
    for j in res.mechanism.joints:
        mag = np.where(g.ok, np.abs(g.reactions[j.name][j.magnitude]), np.nan)
        if np.any(np.isfinite(mag)):
            peaks.append((j, mag, int(np.nanargmax(mag))))
    top = max((float(m[i]) for _, m, i in peaks), default=0.0)
    for j, mag, i in peaks:
        if unbounded_towards(src, mag, i) is None and (
            edge_growth(src, lambda x, k, j=j: np.abs(src.reaction_at(j.name, x, k)[j.magnitude]))
            is None
        ):
            value = or_zero(float(mag[i]), top) / fscale
            out[f"peak reaction {j.name}"] = (value, pretty_unit(funit))
    return out


def changes(before: dict, after: dict, rel: float = 1e-9) -> list[str]:
    """Lines saying which figures moved, by how much, and which appeared or went."""
    lines = []
    from mechsolve.base.units import spaced

    for name, (v, unit) in after.items():
        u = spaced(unit)
        if name not in before:
            lines.append(f"  new: {name} = {v:.6g}{u}")
            continue
        v0 = before[name][0]
        if math.isfinite(v) and math.isfinite(v0) and abs(v - v0) <= rel * max(abs(v), abs(v0)):
            continue
        if v0 == v:
            continue
        pct = f" ({(v - v0) / abs(v0):+.2%})" if v0 and math.isfinite(v0) else ""
        lines.append(f"  {name}: {v0:.6g} -> {v:.6g}{u}{pct}")
    for name in before:
        if name not in after:
            lines.append(f"  gone: {name}")
    return lines


STALE = "STALE.txt"  # in the output folder while the file is broken


def mark_stale(
    outdir: Path, path: Path, error: str, good: str | None, written: Sequence[str] = ()
) -> Path | None:
    """Write ``outdir/STALE.txt``: the files beside it are not from ``path`` as it is
    now (its last save failed with ``error``); ``good`` is when the last good run was.

    ``written``: the files the failed save's run did write before it failed (a run whose
    requirements cannot be checked writes its table and plots first); those are from the
    file as it is, and the marker names only the others, or is removed when there are
    none. Returns the marker, or None when there is none (no folder, nothing old)."""
    from mechsolve.base.atomic import write_text

    outdir = Path(outdir)
    if not outdir.is_dir():
        return None
    since = f"the last good run ({good})" if good else "an earlier run"
    if written:
        old = sorted(
            p.name for p in outdir.iterdir() if p.is_file() and p.name not in (STALE, *written)
        )
        if not old:
            clear_stale(outdir)
            return None
        text = (
            f"These files in this folder are from {since} of {path}, not from the file as\n"
            f"it is now: {', '.join(old)}.\n"
            f"The others ({', '.join(written)}) were written by its last save, whose run then\n"
            "failed. This file is removed by the next run that succeeds.\n\n"
            f"{error}\n"
        )
    else:
        text = (
            f"The files in this folder are from {since} of {path}, not from the file as it\n"
            "is now: its last save could not be run. They are replaced, and this file is\n"
            "removed, by the next run that succeeds.\n\n"
            f"{error}\n"
        )
    try:
        return write_text(outdir / STALE, text)
    except OSError:  # a full disk: the terminal line still says it
        return None


def files_of(outdir: Path | None) -> dict[str, tuple[int, int, int]]:
    """The files in ``outdir`` (not :data:`STALE`) with what tells a rewritten one apart:
    inode, modification time and size (a file written in place or replaced changes one)."""
    out: dict[str, tuple[int, int, int]] = {}
    if outdir is None or not Path(outdir).is_dir():
        return out
    for p in Path(outdir).iterdir():
        try:
            st = p.stat()
        except OSError:
            continue
        if p.is_file() and p.name != STALE:
            out[p.name] = (st.st_ino, st.st_mtime_ns, st.st_size)
    return out


def clear_stale(outdir: Path | None) -> None:
    """Remove the marker of :func:`mark_stale` after a good run."""
    if outdir is None:
        return
    try:
        (Path(outdir) / STALE).unlink()
    except FileNotFoundError:
        pass


def _say_what_is_stale(
    echo: Callable[[str], None], outdir: Path, path: Path, message: str, good: str | None,
    before: dict[str, tuple[int, int, int]],
) -> None:  # fmt: skip
    """After a save's run failed with ``message``: mark the files in ``outdir`` it did not
    write (``before``: the folder's files before it ran) as stale, and say which are
    whose."""
    written = sorted(n for n, key in files_of(outdir).items() if before.get(n) != key)
    marker = mark_stale(outdir, path, message, good, written)
    since = f"the last good run ({good})" if good else "an earlier run"
    if written:
        echo(
            f"this save's run wrote {', '.join(written)} in {outdir}/ before it failed "
            "(above): those are from the file as it is now"
        )
        if marker is not None:
            echo(f"the other files there are from {since}: see {marker}")
    elif marker is not None:
        echo(f"the files in {outdir}/ are from {since}, not from this save: see {marker}")


def watch_file(
    path: Path,
    job: Callable[[], tuple[int, Any]],
    echo: Callable[[str], None] = print,
    stop: Callable[[], bool] | None = None,
    outdir: Path | None = None,
) -> None:
    """Run ``job`` now and after every save of ``path`` until Ctrl-C (or ``stop()``).

    A save that cannot be run prints its error and keeps watching; with ``outdir`` (the
    folder the job writes) the files there are marked stale (:data:`STALE`, with the
    error) and the terminal says they are from the last good run, until a run succeeds.
    Ctrl-C prints "stopped watching" and raises :class:`KeyboardInterrupt` (exit 130).
    """
    try:
        from watchfiles import watch
    except ImportError:
        raise InputError(
            '--watch needs the watchfiles package: pip install "mechsolve[watch]"'
        ) from None
    path = Path(path)
    folder = path.resolve().parent
    if not folder.is_dir():
        raise InputError(f"{path}: its folder does not exist, there is nothing to watch")
    target = path.resolve()
    last: dict[str, tuple[float, str]] | None = None
    good: str | None = None  # when the last run that succeeded ended

    def broken(message: str, before: dict) -> None:
        echo(message)
        if outdir is not None:
            _say_what_is_stale(echo, outdir, path, message, good, before)

    def once() -> None:
        nonlocal last, good
        before = files_of(outdir)
        try:
            code, res, *shown = job()  # (and the units the run printed in)
        except KeyboardInterrupt:
            raise
        except MechsolveError as exc:
            broken(f"error: {exc}", before)
            echo(f"watching {path}: fix it and save")
            return
        except OSError as exc:
            broken(f"error: {exc.strerror or exc}: {exc.filename or path}", before)
            echo(f"watching {path}: fix it and save")
            return
        except Exception as exc:  # noqa: BLE001 - a bug must not end the user's session
            broken(f"internal error: {type(exc).__name__}: {exc} (a bug in mechsolve)", before)
            echo(f"watching {path}")
            return
        clear_stale(outdir)
        good = time.strftime("%H:%M:%S")
        figs = figures_of(res, shown[0] if shown else None)
        if last is not None and figs:
            moved = changes(last, figs)
            echo("changed since the last run:" if moved else "no figure changed")
            for line in moved:
                echo(line)
        if figs:
            last = figs
        echo(f"watching {path} (exit code of this run: {code}); Ctrl-C stops")

    def is_target(change: Any, name: str) -> bool:  # noqa: ARG001
        return Path(name).resolve() == target

    try:
        once()
        for _ in watch(folder, watch_filter=is_target, debounce=200, step=50, recursive=False):
            once()
            if stop is not None and stop():
                break
    except KeyboardInterrupt:
        echo("stopped watching")
        raise
