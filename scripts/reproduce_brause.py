"""Reproduce Brause (1989) §5-6 and appendix B for the PUMA 560: storage table 6a, the
linear-approximation error e^LA along a straight path (Figs. 5f-5i, fit 5.7-5.8) and over the
whole reachable workspace (slope scan), the optimal storage resolution (§6.2, appendix B, Figs.
6.2 and B.1), and e^LA of learned Kohonen maps, trained with Brause's own protocol (coarse Θ_c,
fine (3.7), learning (3.9)/(3.10), step neighbourhood, one rate) and with the MRS loop (rule
"mrs", Gaussian RITT3 neighbourhood, averaged coarse move, exploration: this project's additions).

The program is :mod:`envs.cli.reproduce_brause` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.reproduce_brause import run

if __name__ == "__main__":
    run()
