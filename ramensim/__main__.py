import sys

from ramensim.cli import main

sys.exit(main())
