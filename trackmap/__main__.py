"""``python -m trackmap`` runs the ``trackmap`` command line."""

import sys

from trackmap.cli import main

__all__: list[str] = []

sys.exit(main())
