"""The per-user cache (crankfmu/cache.py) and what an installation carries of it."""


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
