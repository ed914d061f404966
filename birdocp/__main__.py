"""``python -m birdocp`` runs the command-line interface."""

import sys

from birdocp.cli.main import main

if __name__ == "__main__":
    sys.exit(main())
