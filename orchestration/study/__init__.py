"""The paper's experiment and our studies of it: the pure loop, readings, comparisons, reproduce."""
