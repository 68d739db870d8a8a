"""The FMI shell: crankfmu's model as FMI 2.0 co-simulation FMUs (pythonfmu).

``slave``: the FMU's variables and life cycle, run inside the FMU; ``slave_script.py.in``: the
one slave script template; ``shim/fmu_shim.c``: the linux64 binary in front of pythonfmu's;
``build``: the build step (run in crankfmu's own environment, not shipped).
"""
