"""Sweeps: sweep files (spec), their points on Dask (runner), and the stored results (results)."""
