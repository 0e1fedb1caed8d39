"""Running scenarios: the scenario files, the fmpy master, metrics, summaries, interruption."""
