"""An FMU (Python and native, FMI 2.0 and 3.0, a component's) stores every entry as a
regular file of mode 0644, a binary 0755, whatever zipfile's default (0600 for text) or the disk's
mode, so that an archive unpacked by one account can be read by another; as root, Info-ZIP's unzip
(which applies the stored modes) unpacks a native FMU and the account nobody reads its files. (The
SSPs are written by the same helper, fmi/archive.py.)"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
import zipfile
from pathlib import Path

import pytest

from crankfmu.cli import main


@pytest.fixture(scope="module")
def archives(tmp_path_factory):
    out = tmp_path_factory.mktemp("modes")
    for folder, args in (("python", ["seed002"]), ("native", ["seed002", "--native"]),
                         ("native3", ["seed002", "--native", "--fmi-version", "3"]),
                         ("shaft", ["elastic_shaft", "--shaft", "--native"])):
        assert main(["fmu", *args, "--out", str(out / folder)]) == 0
    return sorted(out.rglob("*.fmu"))


def test_every_entry_is_readable_by_everyone(archives):
    assert len(archives) == 4
    for fmu in archives:
        with zipfile.ZipFile(fmu) as z:
            for info in z.infolist():
                mode = (info.external_attr >> 16) & 0o7777
                want = 0o755 if info.filename.startswith("binaries/") else 0o644
                assert mode == want, (fmu.name, info.filename, oct(mode))


@pytest.mark.skipif(os.geteuid() != 0 or not shutil.which("unzip") or not shutil.which("runuser"),
                    reason="needs root, unzip and runuser to unpack as one account and read as another")
def test_another_account_reads_what_root_unpacked(archives):
    native = next(f for f in archives if f.parent.name == "native")
    where = Path(tempfile.mkdtemp(dir="/tmp"))
    try:
        where.chmod(0o755)
        subprocess.run(["unzip", "-q", str(native), "-d", str(where)], check=True)
        for name in ("modelDescription.xml", "documentation/index.html"):
            read = subprocess.run(["runuser", "-u", "nobody", "--", "cat", str(where / name)], capture_output=True)
            assert read.returncode == 0, (name, read.stderr.decode())
        library = next((where / "binaries" / "linux64").glob("*.so"))
        assert os.stat(library).st_mode & 0o777 == 0o755
    finally:
        shutil.rmtree(where)
