"""Build the packaged FMUs into build/fmus (``make fmu``): see crankfmu.fmi.python.build."""

import sys

from crankfmu.fmi.python.build import main

if __name__ == "__main__":
    sys.exit(main())
