"""The co-simulation master of sotc-cosim: scenarios, FMU builds, the fmpy loop, summaries."""
