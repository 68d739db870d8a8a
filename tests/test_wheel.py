"""The wheel (issue 56, in part): `pip wheel --no-deps .` gives a wheel whose tag says what it holds
(a plain library loaded by ctypes: py3-none-<platform>), with the C kernel, the native FMUs'
objects and the Python FMUs' shim compiled at installation, so that `crankfmu fmu` builds a Python
FMU with no compiler on PATH (the shim carried, checked against its sources' digest)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    out = tmp_path_factory.mktemp("wheel")
    done = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", str(ROOT), "-w", str(out)],
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    (found,) = out.glob("crankfmu-*.whl")
    return found


def test_the_wheels_tag_says_what_it_holds(wheel):
    import sysconfig

    platform = sysconfig.get_platform().replace("-", "_").replace(".", "_")
    assert wheel.name.endswith(f"-py3-none-{platform}.whl"), wheel.name


def test_the_wheel_carries_the_kernel_the_objects_and_the_shim(wheel):
    from crankfmu.fmi.shim import prebuilt

    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        assert "crankfmu/native/crank_kernel.so" in names
        assert any(n.startswith("crankfmu/native/objects/") and n.endswith(".o") for n in names)
        assert "crankfmu/fmi/shim/fmu_shim.so" in names
        assert z.read("crankfmu/fmi/shim/fmu_shim.digest").decode().strip() == prebuilt.digest()
        assert "crankfmu/scenarios/engine1.toml" in names and "crankfmu/mechanisms/files/inline4.toml" in names


def test_a_python_fmu_is_built_with_no_compiler_from_the_shim_installed(tmp_path, monkeypatch):
    """The shim compiled at installation is copied into the FMU where its digest is the sources'; with
    no gcc on PATH the build then succeeds, and an edited source (another digest) asks for gcc."""
    from crankfmu.errors import CrankfmuError
    from crankfmu.fmi.build import compile_shim
    from crankfmu.fmi.shim import prebuilt

    installed = tmp_path / "installed"
    prebuilt.prebuild(installed)
    monkeypatch.setattr(prebuilt, "PREBUILT", installed / "fmu_shim.so")
    monkeypatch.setattr(prebuilt, "PREBUILT_DIGEST", installed / "fmu_shim.digest")
    monkeypatch.setenv("PATH", str(Path(sys.executable).parent))
    assert shutil.which("gcc") is None
    copy = compile_shim("FourBar", tmp_path / "FourBar.so")
    assert copy.read_bytes() == (installed / "fmu_shim.so").read_bytes()
    (installed / "fmu_shim.digest").write_text("another\n")
    with pytest.raises(CrankfmuError, match="gcc not found"):
        compile_shim("FourBar", tmp_path / "again.so")
    assert os.environ["PATH"] == str(Path(sys.executable).parent)
