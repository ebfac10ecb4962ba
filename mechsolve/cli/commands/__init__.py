"""The commands of ``mechsolve`` that live in modules of their own (each defines one
``click.Command`` that :mod:`mechsolve.cli.main` registers)."""
