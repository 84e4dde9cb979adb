"""Where a map's artifacts lie relative to what its own robots saw: ``ramensim paper artifacts`` as a
script (the command: ramensim/commands/paper.py; the study: ramensim/paper/artifacts.py), so that
the command older pages print keeps working.

    python tools/artifacts_by_distance.py RUN_FOLDER [--samples 200000] [--bad 0.05] [--out DIR]
    python tools/artifacts_by_distance.py --compare A/artifacts_by_distance.json B/... [...]
"""
import sys

from ramensim.commands.paper import main

if __name__ == "__main__":
    sys.exit(main(["artifacts", *sys.argv[1:]]))
