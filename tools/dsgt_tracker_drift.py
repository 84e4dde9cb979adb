"""DSGT's gradient-tracking invariant logged during a run: ``ramensim paper tracker-drift`` as a script
(the command: ramensim/commands/paper.py; the study: ramensim/paper/tracker_drift.py), so that the
command older pages print keeps working.

    python tools/dsgt_tracker_drift.py SCENARIO [--set KEY=VALUE ...] [--every-s 5] [--matched-lag] [--out DIR]
"""
import sys

from ramensim.commands.paper import main

if __name__ == "__main__":
    sys.exit(main(["tracker-drift", *sys.argv[1:]]))
