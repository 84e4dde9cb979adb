"""Screenshot the real Rerun viewer showing a recording (e.g. for docs/images/viewer.png); the work is
ramensim/recording/screenshot.py (it needs the ``rerun`` viewer binary and a Vulkan driver, so it is
no ``ramensim`` command).

    python tools/viewer_screenshot.py runs/<run>/run.rrd --out docs/images/viewer.png [--time 30]
    python tools/viewer_screenshot.py --demo --out docs/images/viewer.png
"""
import sys

from ramensim.recording.screenshot import main

if __name__ == "__main__":
    sys.exit(main())
