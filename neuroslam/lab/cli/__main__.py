"""``python -m neuroslam.lab.cli``: the ``neuroslam`` command."""

import sys

from . import main

sys.exit(main())
