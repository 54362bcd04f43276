"""File formats: problem sets (CSV) and result archives (MCAP). The only package that imports mcap."""
