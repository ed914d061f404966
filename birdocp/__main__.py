"""``python -m birdocp`` runs the command-line interface."""

import sys

try:
    from birdocp.cli.main import main
except KeyboardInterrupt:  # Ctrl-C while starting up
    sys.stderr.write("birdocp: interrupted\n")
    raise SystemExit(130) from None

if __name__ == "__main__":
    try:
        code = main()
    except KeyboardInterrupt:  # a Ctrl-C in the last instructions of main (its report is printed)
        code = 130
    sys.exit(code)
