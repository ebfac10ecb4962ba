"""Design studies: vary numbers of a mechanism file, solve every design, tabulate the
figures that decide it (``mechsolve sweep``)."""
