"""Building the FMUs in a child process, each bundling its code under names unique to its build."""
