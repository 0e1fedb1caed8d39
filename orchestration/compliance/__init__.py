"""FMU compliance and interoperability: validate, FMI cross-check, SSP export, other engines."""
