"""``mechsolve bench``: speed against error, measured by the benchmark package beside
the solver (:mod:`mechsolve_bench`)."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import click

from mechsolve.base.errors import InputError
from mechsolve.cli.kit import EPILOG_NO_CHECK, Command


def _bench_tool() -> ModuleType:
    """The benchmark package ``mechsolve_bench``, imported here and nowhere else in mechsolve.

    The benchmarks (their cases, the hand-written references, the peers' models) are a
    tool beside the solver, not a part of it: this lazy import is the one edge from
    mechsolve to them (tests/test_issue24_bench.py checks it), so that no solver module
    loads them. They are installed with mechsolve; if they are missing, say how to get them.
    """
    try:
        import mechsolve_bench
    except ModuleNotFoundError as exc:
        if exc.name != "mechsolve_bench":
            raise  # something the bench imports is missing: a bug, not the install
        raise InputError(
            "mechsolve bench needs the benchmark package mechsolve_bench, which is not "
            "installed: pip install 'mechsolve[bench]' (from a checkout of the "
            "repository: pip install '.[bench]'; the extra adds the peers pylinkage and exudyn)"
        ) from None
    return mechsolve_bench


@click.command("bench", cls=Command, epilog=EPILOG_NO_CHECK)
@click.option("--quick", is_flag=True, help="Few repetitions and small sizes (as CI runs it).")
@click.option(
    "--case",
    "cases",
    multiple=True,
    type=click.Choice(
        [
            "fourbar-kinematics",
            "crane-kinematics",
            "newton-groups",
            "fourbar-kinetostatics",
            "crane-kinetostatics",
            "startup-dynamics",
            "dynamics-work-precision",
            "chain-growth",
            "positions-growth",
            "stream",
            "startup",
            "study",
            "peers",
            "synthesis",
            "multibody",
        ]
    ),
    help="Run only these cases (repeatable).",
)
@click.option(
    "--plot",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Write a work-precision diagram (time against error, log-log) to this file.",
)
def bench(quick, cases, plot) -> None:
    """Measure speed against error: mechsolve against hand-written closed forms.

    \b
    Each case prints its settings with their median wall time and largest error
    against an independent reference, then the ratio to the hand-written closed form.
    Results measured on this project's machine are in benchmarks/README.md.
    """
    b = _bench_tool()
    done = b.run(quick=quick, cases=list(cases) or None, echo=click.echo)
    if plot is not None:
        b.plot(done, plot)
        click.echo(f"wrote the work-precision diagram to {plot}")
        dyn = [c for c in done if c.name == "dynamics-work-precision"]
        if dyn:
            p = Path(plot)
            out = b.plot_dynamics(dyn[0], p.with_name(p.stem + "-dynamics" + p.suffix))
            click.echo(f"wrote the integrators' work-precision diagram to {out}")
