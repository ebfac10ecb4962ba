"""Writers: CSV tables, plots and drawings of mechanisms. They only read results."""
