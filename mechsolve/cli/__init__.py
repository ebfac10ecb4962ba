"""The command line: one module per command in :mod:`.commands`, one kit (:mod:`.kit`) that
maps every error to the one exit-code rule, the watcher.

Imports everything below it; nothing imports it.
"""
