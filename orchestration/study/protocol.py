"""The numbers of the tuning protocol that ``sotc-cosim tune``'s options show as their defaults; the
protocol itself, and how it uses them, is ``orchestration.study.tuning``. Nothing is imported here, so
the command line is built without loading numpy or the cores."""
BUDGET = 64  # trials per controller, limit handling and seed
SEEDS = (0, 1, 2, 3, 4)  # independent searches, one per seed
CONVERGED = 0.01  # the budget is enough when doubling it moved the best by less than this (its last half)
