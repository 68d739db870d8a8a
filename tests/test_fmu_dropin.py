"""FourBar.fmu on a machine that did not build it: other Pythons, only numpy and fmpy installed,
processes that cannot see the building environment (env -i, an empty HOME, the building Python
recorded in the FMU made unreachable), a Python host and two C/C++ hosts.

The other Pythons: Debian's python3 always (/usr/bin/python3), and pyenv's 3.10, 3.12 and 3.13
where the machine has them (this image does; a fresh machine may not). Python 3.10 has no
tomllib: the FMU reads the JSON copies of its data files the build ships. Each gets a fresh virtual environment
with numpy and fmpy only, under build/dropin/ (made once, reused by later runs).
"""

from __future__ import annotations

import glob
import io
import json
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

import crankfmu

ROOT = Path(__file__).resolve().parents[1]
HERE = Path(__file__).resolve().parent


def other_pythons() -> list[str]:
    found = ["/usr/bin/python3"] if Path("/usr/bin/python3").exists() else []
    for minor in ("3.10", "3.12", "3.13"):
        found += sorted(glob.glob(str(Path.home() / ".pyenv" / "versions" / f"{minor}.*" / "bin" / "python3")))[-1:]
    return found


PYTHONS = other_pythons()


def fresh_venv(python: str) -> Path:
    """build/dropin/<version>: numpy and fmpy only (no scipy, no numba, no crankfmu)."""
    version = subprocess.run([python, "-c", "import sys; print('%d.%d.%d' % sys.version_info[:3])"],
                             capture_output=True, text=True, check=True).stdout.strip()
    venv = ROOT / "build" / "dropin" / f"py{version}"
    marker = venv / ".ready"
    if not marker.exists():
        shutil.rmtree(venv, ignore_errors=True)
        subprocess.run([python, "-m", "venv", str(venv)], check=True)
        subprocess.run([str(venv / "bin" / "python"), "-m", "pip", "install", "--quiet", "numpy", "fmpy"],
                       check=True, capture_output=True)
        marker.write_text(version)
    return venv


@pytest.fixture(scope="module")
def elsewhere(fmu_path, tmp_path_factory):
    """FourBar.fmu as another machine sees it: the building Python it records does not exist."""
    where = tmp_path_factory.mktemp("elsewhere")
    out = where / "FourBar.fmu"
    with zipfile.ZipFile(fmu_path) as zin, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "resources/python_env.txt":
                data = b"executable=/nonexistent/bin/python\nlibpython=/nonexistent/lib/libpython3.so\n"
            zout.writestr(item, data)
    return out


@pytest.fixture(scope="module")
def reference():
    times = np.round(np.arange(0, 2001) * 1e-3, 12)
    return crankfmu.simulate("seed000", output_times=times)


FMPY_HOST = r"""
import json, sys
from fmpy import simulate_fmu
messages = []
def logger(c, instance, status, category, message):
    messages.append((status, message.decode()))
r = simulate_fmu(sys.argv[1], stop_time=2.0, output_interval=1e-3, step_size=1e-3, output=["omega1"], logger=logger)
print(json.dumps({"time": r["time"].tolist(), "omega1": r["omega1"].tolist(), "messages": messages,
                  "python": sys.version.split()[0], "prefix": sys.prefix,
                  "outside": sorted({m.split(".")[0] for m in sys.modules} & {"scipy", "matplotlib", "dask", "crankfmu", "numba"})}))
"""


def isolated(tmp_path, *extra):
    home = tmp_path / "home"
    home.mkdir(exist_ok=True)
    return ["env", "-i", f"HOME={home}", "PATH=/usr/bin:/bin", *extra]


@pytest.mark.parametrize("python", PYTHONS)
def test_fmpy_in_another_python_with_numpy_and_fmpy_only(python, elsewhere, reference, tmp_path):
    venv = fresh_venv(python)
    done = subprocess.run(isolated(tmp_path) + [str(venv / "bin" / "python"), "-c", FMPY_HOST, str(elsewhere)],
                          capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-3000:]
    r = json.loads(done.stdout.strip().splitlines()[-1])
    omega = np.asarray(r["omega1"])
    ref = np.interp(r["time"], reference.time, reference.omega1)
    error = np.max(np.abs(omega - ref)) / np.max(np.abs(ref))
    print(f"Python {r['python']} ({r['prefix']}): omega1(2 s) = {omega[-1]:.10g}, max relative error {error:.2g}")
    assert error <= 1e-6
    assert r["outside"] == []                       # no scipy, matplotlib, dask, crankfmu or numba
    # the C kernel travels compiled in the FMU: nothing to warn about, nothing compiled on the host
    assert not [m for s, m in r["messages"] if s >= 1], r["messages"]


@pytest.fixture(scope="module")
def driver(tmp_path_factory):
    import fmpy

    out = tmp_path_factory.mktemp("c_host") / "fmu_driver"
    subprocess.run(["gcc", "-O1", "-Wall", "-Werror", f"-I{Path(fmpy.__file__).parent / 'c-code'}", "-o", str(out),
                    str(HERE / "c_host" / "fmu_driver.c"), "-ldl"], check=True)
    return out


@pytest.fixture(scope="module")
def unzipped_elsewhere(elsewhere):
    from fmpy import extract, read_model_description

    md = read_model_description(str(elsewhere))
    return extract(str(elsewhere)), md.guid, {v.name: v.valueReference for v in md.modelVariables}


def run_driver(driver, unzipped, tmp_path, *extra):
    where, guid, vr = unzipped
    cmd = isolated(tmp_path, *extra) + [str(driver), where, "FourBar", guid, "2000", "0.001", str(vr["omega1"])]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=600)


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc builds the C driver")
@pytest.mark.parametrize("how", ["CRANKFMU_PYTHON", "python3 on PATH"])
def test_c_host_finds_a_python_with_numpy(how, driver, unzipped_elsewhere, reference, tmp_path):
    python = str(fresh_venv(PYTHONS[0]) / "bin" / "python3")
    extra = [f"CRANKFMU_PYTHON={python}"] if how == "CRANKFMU_PYTHON" else [f"PATH={Path(python).parent}:/usr/bin:/bin"]
    done = run_driver(driver, unzipped_elsewhere, tmp_path, *extra)
    assert done.returncode == 0, done.stdout[-3000:]
    t, omega = map(float, re.search(r"result t=(\S+) value=(\S+)", done.stdout).groups())
    assert t == pytest.approx(2.0)
    assert abs(omega - reference.omega1[-1]) / reference.omega1[-1] < 1e-6
    assert "warning" not in done.stdout.lower()


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc builds the C driver")
def test_c_host_without_a_usable_python_gets_the_attempts_and_the_fix(driver, unzipped_elsewhere, tmp_path):
    """Debian's python3 has no numpy here, the building Python is unreachable: instantiation fails
    with a message that lists both and the command that fixes it."""
    if subprocess.run(["/usr/bin/python3", "-c", "import numpy"], capture_output=True).returncode == 0:
        pytest.skip("Debian's python3 has numpy on this machine")
    done = run_driver(driver, unzipped_elsewhere, tmp_path)
    assert done.returncode == 2, done.stdout
    assert "fmi2Instantiate returned NULL" in done.stdout
    assert "the building Python /nonexistent/bin/python: not on this machine" in done.stdout
    assert "python3 on PATH (python3): ModuleNotFoundError: No module named 'numpy'" in done.stdout
    assert "Fix: python3 -m pip install numpy" in done.stdout


def test_the_fmu_ships_only_what_runs_inside_it(fmu_path):
    with zipfile.ZipFile(fmu_path) as z, zipfile.ZipFile(io.BytesIO(z.read("resources/crankfmu_FourBar.zip"))) as package:
        shipped = set(package.namelist())
        assert not any("/crankfmu_FourBar/" in n for n in z.namelist())      # only as the one archive
    for study in ("cli/__init__.py", "simulation.py", "output.py", "plots.py", "check.py", "fmi/python/build.py", "fmi/documentation.py",
                  "integrators/time_domain.py", "integrators/crank_angle.py", "pictures/draw.py"):
        assert study not in shipped
    assert not any(n.startswith(("studies/", "pictures/")) for n in shipped)    # no study, no drawing
    assert {"fmi/python/slave.py", "native/crank_kernel.so", "native/kernel/crank_kernel.c", "dynamics/modes.py", "contract.py", "scenarios/seed000.toml"} <= shipped
    assert not any("__pycache__" in n for n in shipped)


def test_the_ecos_cpp_master_runs_it_where_the_building_python_is_gone(elsewhere, reference, tmp_path):
    """The ecos command (C++, no Python of its own) under env -i with an empty HOME: the shim finds
    the fresh numpy-only environment through CRANKFMU_PYTHON."""
    pytest.importorskip("ecospy")
    from crankfmu.validation.masters import ecos_command

    python = str(fresh_venv(PYTHONS[0]) / "bin" / "python3")
    cmd = isolated(tmp_path, f"CRANKFMU_PYTHON={python}") + [
        str(ecos_command()), "simulate", "--path", str(elsewhere), "--stopTime", "2", "--stepSize", "0.001", "-l", "debug"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    rows = (tmp_path / "FourBar.csv").read_text().splitlines()
    header = [h.strip() for h in rows[0].split(",")]
    k = header.index("instance::omega1[REAL]")
    omega = np.array([float(r.split(",")[k]) for r in rows[1:]])
    times = np.array([float(r.split(",")[1]) for r in rows[1:]])
    ref = np.interp(times, reference.time, reference.omega1)
    assert np.max(np.abs(omega - ref)) / np.max(np.abs(ref)) <= 1e-6     # ecos writes 6 decimals
