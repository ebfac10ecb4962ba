"""The solver core: assembly, branches, singular positions, the sweep, the states at given
driver values and the forces (kinetostatics, loads, work).

Imports the groups, the system, the model and the base.
"""
