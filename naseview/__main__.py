"""``python -m naseview`` runs the command line."""

import sys

from naseview.cli import main

sys.exit(main())
