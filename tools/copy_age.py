"""The copies' age on arrival, window by window of a run: ``ramensim paper copy-age`` as a script (the
command: ramensim/commands/paper.py; the study: ramensim/paper/copy_age.py), so that the command
older pages print keeps working.

    python tools/copy_age.py RUN_FOLDER_OR_MESSAGES_CSV [--every 60] [--out DIR]
"""
import sys

from ramensim.commands.paper import main

if __name__ == "__main__":
    sys.exit(main(["copy-age", *sys.argv[1:]]))
