"""The largest counts a run, an evaluation or a command line may ask for: what fits in memory and
in time. The command-line programs refuse larger values as they parse them, and a training run's
stored configuration is refused beyond them too (a damaged checkpoint)."""

#: Most of any count option: a run of 10^8 steps of even a millisecond takes a day.
MAX_COUNT = 10**8
#: Most held-out targets or evaluation trials: their errors after each move are kept in memory,
#: and 10^6 reach trials take hours.
MAX_TARGETS = 10**6
#: Most fine moves after a coarse move (the maps converge within a few; each is a trial step).
MAX_FINE_MOVES = 1000
#: Most errors an evaluation keeps (targets x moves): 10^7 float64 are 80 MB per array.
MAX_ERRORS = 10**7
#: Most worker processes of a training run (``train.py --workers``): each holds an env, its
#: renderer and a copy of the map (tens of MB), and a round is cut into one share per worker.
MAX_WORKERS = 256
