"""Completion over time per archived paper-horizon experiment (docs/images/results/):
``ramensim paper figures`` as a script (the command: ramensim/commands/paper.py; the study:
ramensim/paper/figures.py), so that the command older pages print keeps working.

    python tools/results_figures.py [--results docs/results/paper] [--out docs/images/results]
"""
import sys

from ramensim.commands.paper import main

if __name__ == "__main__":
    sys.exit(main(["figures", *sys.argv[1:]]))
