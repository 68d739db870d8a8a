"""The entries of the archives crankfmu writes (FMUs, SSPs): readable by every account that unpacks
them. zipfile's writestr stores 0600 for a name given as text, and write the file system's mode of
the moment, so an FMU unpacked by one user (a shared tool installation, a CI runner, a container)
could not be read by another; here every entry is a regular file of mode 0644, and a binary 0755,
as fmpy and the Reference FMUs store them."""

from __future__ import annotations

import time
import zipfile
from pathlib import Path

#: a regular file (S_IFREG) with the permissions of each kind of entry
_REGULAR = 0o100000
FILE_MODE, BINARY_MODE = 0o644, 0o755


def _mode(name: str) -> int:
    return BINARY_MODE if name.startswith("binaries/") else FILE_MODE


def entry(name: str, like: zipfile.ZipInfo | None = None) -> zipfile.ZipInfo:
    """A ZipInfo for ``name`` (or a copy of ``like``'s date) with its mode, deflated."""
    info = zipfile.ZipInfo(name, date_time=like.date_time if like else time.localtime()[:6])
    info.compress_type = zipfile.ZIP_DEFLATED
    info.external_attr = (_REGULAR | _mode(name)) << 16
    return info


def add_bytes(archive: zipfile.ZipFile, name: str, data, like: zipfile.ZipInfo | None = None) -> None:
    """Write ``data`` (bytes or text) as ``name``."""
    archive.writestr(entry(name, like), data)


def add_file(archive: zipfile.ZipFile, path: Path, name: str) -> None:
    """Write the file ``path`` as ``name``, whatever its mode on this disk."""
    info = entry(name)
    info.date_time = zipfile.ZipInfo.from_file(path, name).date_time
    archive.writestr(info, Path(path).read_bytes())
