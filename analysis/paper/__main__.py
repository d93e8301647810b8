import sys

from analysis.paper.cli import main

sys.exit(main(sys.argv[1:]))
