"""``python -m mggp`` runs the command line (same as the ``mggp`` script)."""
import sys

from .cli.app import main

sys.exit(main())
