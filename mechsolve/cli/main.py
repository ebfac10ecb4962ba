"""The ``mechsolve`` command. Thin: it parses options, calls :mod:`mechsolve.api`, prints.

Heavy modules (numpy, scipy, matplotlib) are imported inside the commands so that
``mechsolve --help`` starts fast. What the commands share is in :mod:`mechsolve.cli.kit`.
"""

from __future__ import annotations

import click

from mechsolve.cli.commands.animate import animate
from mechsolve.cli.commands.bench import bench
from mechsolve.cli.commands.cam import cam
from mechsolve.cli.commands.check import check
from mechsolve.cli.commands.compare import compare
from mechsolve.cli.commands.draw import draw
from mechsolve.cli.commands.flywheel import flywheel
from mechsolve.cli.commands.polygons import polygons
from mechsolve.cli.commands.report import report
from mechsolve.cli.commands.run import run
from mechsolve.cli.commands.schema import schema
from mechsolve.cli.commands.shaking import shaking
from mechsolve.cli.commands.simulate import simulate
from mechsolve.cli.commands.sweep import sweep
from mechsolve.cli.commands.synth import synth
from mechsolve.cli.kit import EXIT_CODES, EXIT_INPUT, Group


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


# every command is a module of mechsolve/commands/
main.add_command(run)
main.add_command(simulate)
main.add_command(flywheel)
main.add_command(shaking)
main.add_command(check)
main.add_command(bench)
main.add_command(cam)
main.add_command(synth)
main.add_command(sweep)
main.add_command(report)
main.add_command(animate)
main.add_command(polygons)
main.add_command(schema)
main.add_command(compare)
main.add_command(draw)

if __name__ == "__main__":  # pragma: no cover
    main()

__all__ = ["main", "EXIT_INPUT"]
