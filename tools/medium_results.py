"""The tables of docs/results/medium.md from archived medium sweeps: ``ramensim paper medium`` as a
script (the command: ramensim/commands/paper.py; the study: ramensim/paper/medium.py), so that the
command older pages print keeps working.

    python tools/medium_results.py docs/results/medium/medium_table1 [MORE_ARCHIVES ...] [--reference links]
"""
import sys

from ramensim.commands.paper import main

if __name__ == "__main__":
    sys.exit(main(["medium", *sys.argv[1:]]))
