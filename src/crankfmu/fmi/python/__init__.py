"""The Python FMUs (pythonfmu): the FMU's core and slaves (``core``, ``slave``, ``speed`` and the
components'), the one slave script template (``slave_script.py.in``), the linux64 shim
(``shim/``) and their build (``build``); what runs inside a Python FMU is here and below
``crankfmu`` (build.RUNTIME)."""
