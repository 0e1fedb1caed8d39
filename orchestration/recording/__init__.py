"""Streaming runs into Rerun recordings (.rrd) with a stored blueprint of the paper's figures."""
