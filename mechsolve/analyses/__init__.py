"""The analyses, each reached through :mod:`mechsolve.api`: design batches, instants, dynamics,
flywheel, polygons, cam, synthesis, design studies, the file format's schema.

Import the writers, the results and the layers below them; one analysis may use another.
"""
