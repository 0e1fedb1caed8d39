"""Generated documentation: every measured table in README.md and docs/ is written from here."""
