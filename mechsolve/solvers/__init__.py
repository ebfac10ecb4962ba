"""Solvers of the core: Newton-Raphson on a group's equations, the force analysis."""
