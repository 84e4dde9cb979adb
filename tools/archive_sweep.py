"""Keep a sweep's results in the repository without its meshes: ``ramensim archive SWEEP DEST`` as a
script (the command: ramensim/commands/archive.py; the work: ramensim/sweep/archive.py), so that the
command older pages print keeps working.

    python tools/archive_sweep.py runs/sweeps/paper_table1 docs/results/paper/paper_table1 [--plan FILE]
"""
import sys

from ramensim.commands.archive import main

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
