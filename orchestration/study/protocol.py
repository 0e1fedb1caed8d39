"""The numbers of the tuning protocol that ``sotc-cosim tune``'s options show as their defaults; the
protocol itself, and how it uses them, is ``orchestration.study.tuning``. Nothing is imported here, so
the command line is built without loading numpy or the cores."""
BUDGET = 1024  # TPE trials per controller, limit handling and seed
POLISH = 512  # then CMA-ES trials from the TPE best (orchestration.study.polish), the phase the rule judges
SEEDS = (0, 1, 2, 3, 4)  # independent searches, one per seed
CONVERGED = 0.01  # enough when doubling the judged phase moved the best by less than this (its last half)
HELD_OUT_POINTS = 128  # per set and draw of the held-out points (orchestration.study.fair)
