"""Put the runs archived under docs/results/ back into the sweep folders:
``ramensim archive --restore`` as a script (the command: ramensim/commands/archive.py; the work:
ramensim/sweep/archive.py), so that the command older pages and tools/paper_queue.sh print keeps
working.

    python tools/restore_archives.py [ARCHIVES SWEEPS]    # = ramensim archive --restore [ARCHIVES SWEEPS]
"""
import sys

from ramensim.commands.archive import main

if __name__ == "__main__":
    sys.exit(main(["--restore", *sys.argv[1:]]))
