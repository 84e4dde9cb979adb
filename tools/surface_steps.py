"""Completion's change against the seen surface's steps over an archived sweep:
``ramensim paper surface-steps`` as a script (the command: ramensim/commands/paper.py; the study:
ramensim/paper/surface_steps.py), so that the command older pages print keeps working.

    python tools/surface_steps.py docs/results/paper/paper_fig7_authors_split [--jump 5] [--until 600]
"""
import sys

from ramensim.commands.paper import main

if __name__ == "__main__":
    sys.exit(main(["surface-steps", *sys.argv[1:]]))
