"""The paper's claims judged on the archived paper-horizon runs: ``ramensim claims`` as a script
(the command: ramensim/commands/claims.py; the analyses: ramensim/paper/), so that the command
older pages print keeps working.

    python tools/paper_claims.py --out docs/results/paper/claims.md    # = ramensim claims --out ...
"""
import sys

from ramensim.commands.claims import main

if __name__ == "__main__":
    sys.exit(main())
