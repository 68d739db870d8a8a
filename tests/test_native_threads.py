"""Many instances of the native FMU in one process (issue 38): 8 threads, each initialising and
stepping its own instances with another geometry (the tables built per instance by the C
mechanism model), give omega1 bit for bit equal to the same designs run on one thread; the FMU's
sources and the host compiled with ThreadSanitizer report no race.
"""

import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")


def test_eight_threads_of_instances_of_other_geometry_equal_one_thread_under_tsan(tmp_path):
    import fmpy
    from fmpy import read_model_description

    from crankfmu.cli import main

    fmu = ROOT / "build" / "fmus" / "native" / "FourBar.fmu"
    if not fmu.exists():
        assert main(["fmu", "seed000", "--native", "--out", str(tmp_path / "built")]) == 0
        fmu = tmp_path / "built" / "FourBar.fmu"
    with zipfile.ZipFile(fmu) as z:
        z.extractall(tmp_path / "fmu")
    sources = tmp_path / "fmu" / "sources"
    headers = Path(fmpy.__file__).parent / "c-code"
    library, host = tmp_path / "FourBar.so", tmp_path / "threads"
    flags = ["-O1", "-g", "-fsanitize=thread", f"-I{headers}"]
    subprocess.run(["gcc", "-std=c99", *flags, "-fPIC", "-shared", "-DCK_API=", f"-I{sources}", "-o", str(library),
                    *map(str, sorted(sources.glob("*.c"))), "-lm"], check=True)
    subprocess.run(["gcc", *flags, f"-I{HERE / 'c_host'}", "-o", str(host), str(HERE / "c_host" / "threads_driver.c"),
                    "-ldl", "-lpthread"], check=True)
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    done = subprocess.run(["env", "-i", "TSAN_OPTIONS=halt_on_error=1", str(host), str(library), md.guid,
                           str(vr["l1"]), str(vr["J_flywheel"]), str(vr["omega1"]), "8", "2", "200",
                           f"file://{tmp_path / 'fmu' / 'resources'}"],
                          capture_output=True, text=True, timeout=600)
    assert "ThreadSanitizer" not in done.stderr, done.stderr[-4000:]
    assert done.returncode == 0, done.stdout + done.stderr[-4000:]
    assert re.search(r"^identical 16 ", done.stdout, re.M), done.stdout
