"""A run's final meshes scored with the views of earlier times: ``ramensim paper rescore`` as a script
(the command: ramensim/commands/paper.py; the study: ramensim/paper/rescore.py), so that the command
older pages print keeps working.

    python tools/rescore_over_time.py RUN_FOLDER [--at 30 60 ...] [--own] [--out DIR]
"""
import sys

from ramensim.commands.paper import main

if __name__ == "__main__":
    sys.exit(main(["rescore", *sys.argv[1:]]))
