"""The validation report's default-experiment table: a row's bar where every run has the same one,
else each cell's bar beside its error (a cell "1e-05, 1e-06" in the bar column was left unexplained)."""

from __future__ import annotations

from validation.report import _defaults


def section(build, interface, tol):
    return {"name": "SliderCrank", "build": build, "default": [{
        "interface": interface, "span": 1.0, "step": 1e-3, "fmu_wall": 0.5, "plot": "p.png",
        "rows": [{"output": "omega1", "unit": "rad/s", "rel": 2.5e-9, "tol": tol},
                 {"output": "phi1", "unit": "rad", "rel": 1.0e-9, "tol": 1e-6}]}]}


def test_one_bar_per_row_or_each_cells_own():
    lines = _defaults([section("native", "CoSimulation", 1e-6), section("native", "ModelExchange", 1e-5)])
    omega = next(line for line in lines if line.startswith("| omega1 "))
    phi = next(line for line in lines if line.startswith("| phi1 "))
    assert "2.5e-09 (bar 1e-06)" in omega and "2.5e-09 (bar 1e-05)" in omega and omega.endswith("| each cell's own |")
    assert "(bar" not in phi and phi.endswith("| 1e-06 |")
