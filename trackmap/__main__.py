"""``python -m trackmap`` runs the ``trackmap`` command line."""

import sys

from trackmap.cli import main

sys.exit(main())
