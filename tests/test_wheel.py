"""The wheel: `pip wheel --no-deps .` gives a wheel whose tag says what it holds (a plain library
loaded by ctypes: py3-none-<platform>), with the C kernel, the native mechanism FMUs' runtimes (one
per FMI version and platform whose compiler the building machine has, for the mechanisms and
the components alike) and the Python FMUs' shim, so that `crankfmu fmu` builds a Python FMU, and `crankfmu fmu
--native` a native one for every platform the wheel carries, with no compiler on PATH; and the
packaged scenarios' reference runs and documentation figures (fmi/prebuilt_results.py), so that a
packaged scenario's native build integrates and draws nothing."""

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


#: the runtimes a wheel built here carries: every platform whose compiler is installed
def _platforms_here() -> dict:
    from crankfmu.native.sources import PLATFORMS

    return {version: sorted(folder for folder, cc in platforms if shutil.which(cc))
            for version, platforms in PLATFORMS.items()}


def test_the_wheel_carries_the_kernel_the_runtimes_and_the_shim(wheel):
    from crankfmu.fmi.python.shim import prebuilt

    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        for version, folders in _platforms_here().items():
            for folder in folders:
                assert any(n.startswith(f"crankfmu/native/runtimes/fmi{version[0]}/{folder}/crankfmu-") for n in names), \
                    (version, folder)
        assert "crankfmu/native/crank_kernel.so" in names
        assert "crankfmu/fmi/python/shim/fmu_shim.so" in names
        assert z.read("crankfmu/fmi/python/shim/fmu_shim.digest").decode().strip() == prebuilt.digest()
        assert "crankfmu/scenarios/engine1.toml" in names and "crankfmu/mechanisms/files/inline4.toml" in names
        # one reference run, one mechanism drawing and one default-experiment plot per packaged scenario
        scenarios = len(list((ROOT / "src" / "crankfmu" / "scenarios").glob("*.toml")))
        for kind, count in (("references/", scenarios), ("figures/mechanism_", scenarios),
                            ("figures/experiment_", scenarios)):
            assert sum(n.startswith(f"crankfmu/prebuilt/{kind}") for n in names) == count, kind


def test_a_python_fmu_is_built_with_no_compiler_from_the_shim_installed(tmp_path, monkeypatch):
    """The shim compiled at installation is copied into the FMU where its digest is the sources'; with
    no gcc on PATH the build then succeeds, and an edited source (another digest) asks for gcc."""
    from crankfmu.errors import CrankfmuError
    from crankfmu.fmi.python.build import compile_shim
    from crankfmu.fmi.python.shim import prebuilt

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


@pytest.fixture(scope="module")
def installed(wheel, tmp_path_factory):
    """The wheel installed on its own (its dependencies are this environment's), and an environment
    with no compiler on PATH, a fresh HOME and a fresh crankfmu cache."""
    where = tmp_path_factory.mktemp("installed")
    done = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--quiet", "--target",
                           str(where / "site"), str(wheel)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    env = {"PATH": str(Path(sys.executable).parent), "HOME": str(where / "home"), "PYTHONPATH": str(where / "site"),
           "CRANKFMU_CACHE": str(where / "cache"), "MPLBACKEND": "Agg"}
    (where / "home").mkdir()
    return where, env


@pytest.mark.parametrize("version", ["2", "3"])
def test_a_native_fmu_is_built_from_the_wheel_with_no_compiler_for_every_platform(installed, version):
    """`crankfmu fmu seed000 --native` from the installed wheel, no gcc on PATH: it compiles nothing,
    names every platform in its summary and carries the wheel's runtime of each; fmpy runs the FMU
    and it gives the in-process reference within 1e-8 (FMI 2.0; FMI 3.0 likewise)."""
    import fmpy
    import numpy as np

    where, env = installed
    assert not any(shutil.which(cc, path=env["PATH"]) for cc in ("gcc", "cc", "x86_64-w64-mingw32-gcc"))
    located = subprocess.run([sys.executable, "-c", "import crankfmu; print(crankfmu.__file__)"], env=env,
                             capture_output=True, text=True)
    assert located.stdout.startswith(str(where / "site")), located
    out = where / f"fmi{version}"
    done = subprocess.run([sys.executable, "-m", "crankfmu", "fmu", "seed000", "--native", "--fmi-version", version,
                           "--out", str(out)], env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    folders = _platforms_here()[f"{version}.0"]
    assert done.stdout.strip().endswith(f"(binaries: {', '.join(folders)})"), done.stdout
    fmu = out / "FourBar.fmu"
    with zipfile.ZipFile(fmu) as z:
        carried = sorted({n.split("/")[1] for n in z.namelist() if n.startswith("binaries/") and n.count("/") == 2})
        assert carried == folders
        runtimes = {f: z.read(f"binaries/{f}/FourBar{'.dll' if 'win' in f else '.so'}") for f in folders}
    for folder, binary in runtimes.items():       # the wheel's runtime, byte for byte: nothing compiled
        (shipped,) = (where / "site" / "crankfmu" / "native" / "runtimes" / f"fmi{version}" / folder).glob("crankfmu-*")
        assert shipped.read_bytes() == binary, folder
    assert not (where / "cache" / "runtimes").exists()
    # the reference run and the figures are the wheel's: the per-user cache has none of them
    assert not (where / "cache" / "references").exists() and not (where / "cache" / "figures").exists()
    reference = np.genfromtxt(out / "FourBar_ref.csv", delimiter=",", names=True)
    result = fmpy.simulate_fmu(str(fmu), stop_time=float(reference["time"][-1]), output=["omega1"],
                               output_interval=float(reference["time"][1] - reference["time"][0]))
    scale = np.max(np.abs(reference["omega1"]))
    assert np.max(np.abs(result["omega1"] - reference["omega1"])) <= 1e-8 * scale


def test_a_design_the_wheel_does_not_carry_is_run_and_drawn_in_its_build(installed, tmp_path):
    """seed000 at another crank length: the wheel has no reference of it, so the build integrates it
    and keeps it in the per-user cache; its FMU gives that reference within 1e-8 in fmpy."""
    import fmpy
    import numpy as np

    _, env = installed
    env = {**env, "CRANKFMU_CACHE": str(tmp_path / "cache")}
    done = subprocess.run([sys.executable, "-m", "crankfmu", "fmu", "seed000", "--native", "--set", "l1=0.21",
                           "--out", str(tmp_path)], env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    assert len(list((tmp_path / "cache" / "references").glob("*.csv"))) == 1
    assert len(list((tmp_path / "cache" / "figures").glob("*.png"))) == 2
    reference = np.genfromtxt(tmp_path / "FourBar_ref.csv", delimiter=",", names=True)
    result = fmpy.simulate_fmu(str(tmp_path / "FourBar.fmu"), stop_time=float(reference["time"][-1]),
                               output=["omega1"], output_interval=float(reference["time"][1] - reference["time"][0]))
    scale = np.max(np.abs(reference["omega1"]))
    assert np.max(np.abs(result["omega1"] - reference["omega1"])) <= 1e-8 * scale
