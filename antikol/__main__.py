"""``python -m antikol`` runs the ``antikol`` command line."""

import sys

__all__: list[str] = []

from antikol.cli import main

sys.exit(main())
