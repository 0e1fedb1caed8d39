"""Measurements behind design choices (design) and the speed of the product (speed)."""
