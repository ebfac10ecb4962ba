"""Writers: the plots and drawings of a solved sweep, and the fonts they use.

Import the results and the layers below them.
"""
