"""pytest's setup for tests/py: the analysis package's pure modules, tested
without a build. The checkout's root goes first on sys.path, so that this
checkout's analysis/ is the one tested whichever venv runs pytest; the
tests' shared files (tests/timeouts.json) are found from here too."""
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)
