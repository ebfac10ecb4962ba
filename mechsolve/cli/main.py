"""The ``mechsolve`` command. Thin: it parses options, calls :mod:`mechsolve.api`, prints.

Heavy modules (numpy, scipy, matplotlib) are imported inside the commands so that
``mechsolve --help`` starts fast, and a command's own module only when it is run (or
listed by ``--help``). What the commands share is in :mod:`mechsolve.cli.kit`.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator, MutableMapping
from typing import NoReturn

import click

from mechsolve.cli.kit import EXIT_CODES, EXIT_INPUT, Group, end_process

# every command is a module of mechsolve/cli/commands/ defining a command of its name;
# a command's module is imported when the command is looked up (``mechsolve run`` loads
# the run command's module only; ``--help`` and the docs load them all)
COMMANDS = (
    "run",
    "simulate",
    "flywheel",
    "shaking",
    "check",
    "bench",
    "cam",
    "synth",
    "sweep",
    "report",
    "animate",
    "polygons",
    "schema",
    "compare",
    "draw",
)


class _Commands(MutableMapping):
    """The group's commands by name, each imported from its module on first look-up:
    click reads ``Group.commands`` as a mapping (``get``, ``sorted``, items), so the
    group, ``--help``, completion and ``main.commands`` work as with a dict."""

    def __init__(self, names: tuple[str, ...]) -> None:
        self._names = list(names)
        self._loaded: dict[str, click.Command] = {}

    def __getitem__(self, name: str) -> click.Command:
        if name not in self._loaded:
            if name not in self._names:
                raise KeyError(name)
            module = importlib.import_module(f"mechsolve.cli.commands.{name}")
            self._loaded[name] = getattr(module, name)
        return self._loaded[name]

    def __setitem__(self, name: str, cmd: click.Command) -> None:
        if name not in self._names:
            self._names.append(name)
        self._loaded[name] = cmd

    def __delitem__(self, name: str) -> None:
        self._names.remove(name)
        self._loaded.pop(name, None)

    def __contains__(self, name: object) -> bool:
        return name in self._names

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._names))

    def __len__(self) -> int:
        return len(self._names)


@click.group(cls=Group, epilog=EXIT_CODES, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="mechsolve")
def main() -> None:
    """Solve planar mechanisms described in YAML files.

    \b
    mechsolve run mechanisms/crane.yaml      solve the sweep, write CSV and plots
    mechsolve run FILE --at "theta=30 deg, omega=10 rad/s, alpha=5 rad/s^2"
                                             every quantity and force at an instant
    mechsolve simulate mechanisms/motor-linkage.yaml
                                             a motor-driven start-up (forward dynamics)
    mechsolve flywheel mechanisms/shaper.yaml --delta 1/40
                                             size a flywheel by the energy method
    mechsolve cam mechanisms/shaper-cam.yaml design and check a cam: profile, pressure
                                             angle, curvature, DXF
    mechsolve synth mechanisms/synth/crane-crank-rocker.yaml -o design.yaml
                                             design a linkage (crank-rocker, slider-crank,
                                             guide bar, three positions, input window)
    mechsolve sweep mechanisms/studies/fourbar-study.yaml
                                             a design study: one row per design, on
                                             all cores or a Dask cluster
    mechsolve run FILE --watch               run again whenever FILE is saved
    mechsolve report mechanisms/crane.yaml -o crane.html
                                             one self-contained HTML report
    mechsolve animate mechanisms/crane.yaml -o crane.gif
                                             the mechanism in motion
    mechsolve polygons mechanisms/shaper.yaml --variant graphical --at 7
                                             velocity and acceleration polygons
    mechsolve schema -o mechanism.schema.json
                                             the file format's JSON Schema (editors)
    mechsolve check mechanisms/crane.yaml    validate, count DOF, assemble the start
    mechsolve compare A.yaml B.yaml C.yaml   schemes side by side: stroke, K, velocity,
                                             torque, reactions, flywheel
    mechsolve bench --quick                  speed against error, in one run
    """


main.commands = _Commands(COMMANDS)


def entry() -> NoReturn:
    """The ``mechsolve`` program (the console script and ``python -m mechsolve``): run
    :func:`main` and end the process with its exit code.

    A command's files are complete and closed when it returns (each is written
    atomically), so all that is left is the interpreter's teardown: freeing every object
    and module one by one (about 5 % of a ``run --no-plots``), which the operating system
    does at once. It is skipped, after standard output and error are flushed, unless
    something still has work to do at exit: an ``atexit`` handler (coverage, Dask, a
    process pool, logging, a temporary folder's clean-up) or another thread; then
    Python ends as usual. Other callers of :func:`main` (tests, embedding applications)
    are not affected."""
    try:
        main()
    except SystemExit as exc:
        code = exc.code
    else:  # pragma: no cover - click's standalone mode always exits
        code = 0
    end_process(code)


def __getattr__(name: str) -> click.Command:
    # ``from mechsolve.cli.main import run``: a command by its name, as when each was
    # imported here
    if name in COMMANDS:
        return main.commands[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


if __name__ == "__main__":  # pragma: no cover
    entry()

__all__ = ["main", "entry", "EXIT_INPUT"]
