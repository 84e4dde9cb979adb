"""Count finished runs of one sweep as points of another when both ran the same scenario:
``ramensim archive --adopt`` as a script (the command: ramensim/commands/archive.py; the work:
ramensim/sweep/adopt.py), so that the command older pages and tools/paper_queue.sh print keeps
working.

    python tools/adopt_runs.py SOURCE_RUN [SOURCE_RUN ...] --plan SWEEP_FILE --into SWEEP_FOLDER
"""
import sys

from ramensim.commands.archive import main

if __name__ == "__main__":
    sys.exit(main(["--adopt", *sys.argv[1:]]))
