"""The FMI shells: crankfmu's models as FMUs.

``python/``: the Python FMUs (pythonfmu, FMI 2.0 Co-Simulation), what runs inside them and their
build; ``native/``: the native FMUs (the prebuilt C runtime, FMI 2.0 and 3.0, Co-Simulation and
Model Exchange), their model file, model descriptions and packaging; here, what both builds share:
the data file resolved and checked (``source``), the reference run beside a build (``reference``,
``background``), the stages, the archives, the documentation, the SSPs and the wheel's prebuilt
results.
"""
