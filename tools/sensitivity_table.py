"""Which of the paper's main claims survive which knob of the sensitivity sweeps: ``ramensim
sensitivity`` as a script (the command: ramensim/commands/sensitivity.py; the analyses:
ramensim/paper/sensitivity.py), so that the command older pages print keeps working.

    python tools/sensitivity_table.py --out docs/results/sensitivity.md    # = ramensim sensitivity --out ...
"""
import sys

from ramensim.commands.sensitivity import main

if __name__ == "__main__":
    sys.exit(main())
