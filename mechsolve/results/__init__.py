"""The results layer: a solved sweep's tables, its summary, limit positions, requirement checks
and its tidy CSV.

Imports the core and the layers below it.
"""
