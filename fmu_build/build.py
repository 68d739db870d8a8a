"""Build the packaged FMUs into build/fmus (``make fmu``): see crankfmu.fmi.build."""

import sys

from crankfmu.fmi.build import main

if __name__ == "__main__":
    sys.exit(main())
