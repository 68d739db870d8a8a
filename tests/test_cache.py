"""The per-user cache (crankfmu/cache.py) and what an installation carries of it."""

import os
from pathlib import Path

import pytest


def test_the_cache_reads_what_the_installation_carries_after_the_users_own(tmp_path, monkeypatch):
    """cache.kept: the per-user cache first, then the installation's prebuilt/ (a wheel's packaged
    scenarios), and only where neither has it is the value made (and kept in the per-user cache)."""
    from crankfmu import cache

    monkeypatch.setenv("CRANKFMU_CACHE", str(tmp_path / "user"))
    monkeypatch.setattr(cache, "INSTALLED", tmp_path / "installed")
    (tmp_path / "installed" / "references").mkdir(parents=True)
    (tmp_path / "installed" / "references" / "a.csv").write_text("installed")
    made = []

    def make():
        made.append(1)
        return "made"
    assert cache.kept("references", "a.csv", make, encoding="utf-8") == "installed"
    assert not made and not (tmp_path / "user" / "references" / "a.csv").exists()
    (tmp_path / "user" / "references").mkdir(parents=True)
    (tmp_path / "user" / "references" / "a.csv").write_text("user")
    assert cache.kept("references", "a.csv", make, encoding="utf-8") == "user"
    assert cache.kept("references", "b.csv", make, encoding="utf-8") == "made" and made == [1]
    assert (tmp_path / "user" / "references" / "b.csv").read_text() == "made"


def test_the_cache_runs_from_its_text_as_a_python_fmus_slave_script_runs_it(tmp_path, monkeypatch):
    """A Python FMU's slave script executes cache.py's text (no __file__) before its package is
    unpacked: it has no installation to read from, and keeps and reads the per-user cache alike."""
    from crankfmu import cache

    monkeypatch.setenv("CRANKFMU_CACHE", str(tmp_path))
    namespace = {"__name__": "crankfmu_cache"}
    exec(compile(open(cache.__file__).read(), "cache.py", "exec"), namespace)
    assert namespace["INSTALLED"] is None
    assert namespace["kept"]("figures", "a.png", lambda: b"drawn") == b"drawn"
    assert namespace["kept"]("figures", "a.png", lambda: b"again") == b"drawn"


def test_the_wheels_results_are_built_by_the_package_in_the_build_environment(tmp_path, monkeypatch):
    """fmi/prebuilt_results.py builds each packaged scenario with the package being built first on
    the path and the build's environment after it (pip's isolated build environment is a PYTHONPATH
    entry: a build that dropped it found no fmpy where no fmpy is installed globally), into a cache
    of its own; that cache's references/ and figures/ become the package's prebuilt/."""
    import subprocess

    from crankfmu.fmi import prebuilt_results

    package = tmp_path / "build" / "crankfmu"
    (package / "scenarios").mkdir(parents=True)
    for name in ("b", "a"):
        (package / "scenarios" / f"{name}.toml").write_text("")
    monkeypatch.setenv("PYTHONPATH", "/isolated/build/env")
    seen = []

    def run(command, env, **_):
        seen.append((command[command.index("fmu") + 1], env["PYTHONPATH"]))
        cache = Path(env["CRANKFMU_CACHE"])
        for kind in ("references", "figures"):
            (cache / kind).mkdir(parents=True, exist_ok=True)
            (cache / kind / f"{command[command.index('fmu') + 1]}.{kind}").write_text(kind)
        return subprocess.CompletedProcess(command, 0, "", "")
    monkeypatch.setattr(prebuilt_results.subprocess, "run", run)
    assert prebuilt_results.prebuild(package) == ["a", "b"]
    assert sorted(seen) == [(n, f"{package.parent}{os.pathsep}/isolated/build/env") for n in ("a", "b")]
    assert sorted(p.name for p in (package / "prebuilt" / "references").iterdir()) == ["a.references", "b.references"]

    def refused(command, env, **_):
        return subprocess.CompletedProcess(command, 1, "", "crankfmu: error: a.fmu: the runtimes failed\n")
    monkeypatch.setattr(prebuilt_results.subprocess, "run", refused)
    with pytest.raises(RuntimeError, match="crankfmu fmu a --native: crankfmu: error: a.fmu: the runtimes failed"):
        prebuilt_results.prebuild(package)
