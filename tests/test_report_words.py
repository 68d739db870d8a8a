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


def test_a_published_number_on_the_results_page_says_where_and_in_what_unit():
    """seed000's settled_in_cycle_4, as the harness records it: the page gives the [[paper]] entry's
    source beside it and its tolerance as a ratio (unit 1)."""
    from crankfmu import load_scenario
    from crankfmu.pages.results import Group, _group_html

    entry = next(e for e in load_scenario("seed000").data["paper"] if e["name"] == "settled_in_cycle_4")
    checks = {"fmus": [{"name": "FourBar", "data": "src/crankfmu/scenarios/seed000.toml"}],
              "checks": [{"name": "FourBar.python.paper.settled_in_cycle_4", "verdict": "passed", "measured": 5.8e-10,
                          "published": "0", "tolerance": entry["tolerance"], "unit": "1", "note": ""}]}
    page = _group_html(Group("seed000"), checks)
    assert f"<td>{entry['source']}</td>" in page.replace("&#x27;", "'"), page
    assert f"<td>{entry['tolerance']} (a ratio)</td>" in page, page
