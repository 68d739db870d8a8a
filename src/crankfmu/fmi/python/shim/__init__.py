"""The Python FMUs' linux64 shim: its C sources and the copy compiled at installation (prebuilt.py)."""
