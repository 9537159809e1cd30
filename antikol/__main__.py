"""``python -m antikol`` runs the ``antikol`` command line."""

import sys

from antikol.cli import main

sys.exit(main())
