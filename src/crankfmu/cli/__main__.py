"""``python -m crankfmu.cli``: the command line, as the ``crankfmu`` command runs it."""

import sys

from . import main

sys.exit(main())
