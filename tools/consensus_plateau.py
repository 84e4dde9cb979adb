"""Where runs' consensus error levels off (peak, end, late level): ``ramensim paper plateau`` as a
script (the command: ramensim/commands/paper.py; the study: ramensim/paper/plateau.py), so that the
command older pages print keeps working.

    python tools/consensus_plateau.py RUN [RUN ...] [--from 400] [--out DIR]
"""
import sys

from ramensim.commands.paper import main

if __name__ == "__main__":
    sys.exit(main(["plateau", *sys.argv[1:]]))
