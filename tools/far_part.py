"""The far part's completion by first sight and by links: ``ramensim paper far-part`` as a script (the
command: ramensim/commands/paper.py; the study: ramensim/paper/far_part.py), so that the command
older pages print keeps working.

    python tools/far_part.py RUN_FOLDER [--window 100] [--samples 200000] [--out DIR]
    python tools/far_part.py --compare A/far_part.json B/far_part.json [...]
"""
import sys

from ramensim.commands.paper import main

if __name__ == "__main__":
    sys.exit(main(["far-part", *sys.argv[1:]]))
