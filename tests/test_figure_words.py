"""The flywheel study's figures say what their own run is (issue 70): each title, legend, axis
label and caption is read off the figure as it is saved and held against the study's facts, for a
paper's scenario (seed003: its Figs. 3, 5-7, no flywheel, a motor against a cutting force) and an
engine (engine1: the file's flywheel, a gas force against a generator, no paper's figures). The
words of one must never be the other's.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import crankfmu.pictures.flywheel_study as figures
from crankfmu.cli import main
from crankfmu.units import engineering

#: words that belong to one machine's study only
FOREIGN = {"seed003": ("gas", "generator", "piston", "the file's flywheel"),
           "engine1": ("cutting", "ram", "Fig.", "Figs.", "without a flywheel", "no flywheel", "the paper's")}


def figure_texts(fig) -> list[str]:
    """Every word a reader sees: the titles (the figure's and its panels'), the axis labels, the
    legends' entries, annotations."""
    texts = [fig._suptitle.get_text()] if fig._suptitle is not None else []
    for ax in fig.axes:
        texts += [ax.get_title(), ax.get_xlabel(), ax.get_ylabel()]
        legend = ax.get_legend()
        if legend is not None:
            texts += [t.get_text() for t in legend.get_texts()]
        texts += [t.get_text() for t in ax.texts]
    return [t for t in texts if t]


@pytest.fixture(scope="module", params=["seed003", "engine1"])
def study(request, tmp_path_factory):
    """(name, {figure file: (texts, caption, the figure's lines)}, flywheel.json) of one study as
    `crankfmu flywheel` writes it."""
    seen = {}
    original = figures.save_figure

    def keep(fig, path, **kwargs):
        lines = [(np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float))
                 for ax in fig.axes for line in ax.get_lines()]
        seen[path.name] = (figure_texts(fig), kwargs.get("caption", ""), lines)
        return original(fig, path, **kwargs)

    figures.save_figure = keep
    try:
        out = tmp_path_factory.mktemp(request.param)
        delta = {"seed003": "0.05", "engine1": "0.02"}[request.param]
        assert main(["flywheel", request.param, "--delta", delta, "--out", str(out)]) == 0
    finally:
        figures.save_figure = original

    def refuse(constant):
        raise ValueError(f"flywheel.json holds {constant}, which is not JSON")

    summary = json.loads((out / "flywheel.json").read_text(), parse_constant=refuse)
    return request.param, seen, summary


def test_every_figure_is_drawn_and_listed(study):
    _, seen, summary = study
    assert sorted(seen) == sorted(summary["plots"])


def test_no_figure_borrows_the_other_machines_words(study):
    name, seen, _ = study
    for figure, (texts, caption, _) in seen.items():
        for word in FOREIGN[name]:
            for text in texts + [caption]:
                assert word not in text, (figure, word, text)


def test_the_flywheel_named_is_the_runs(study):
    name, seen, summary = study
    texts, caption, _ = seen["movement.png"]
    J = summary["baseline_J_flywheel"]
    said = "without a flywheel" if J == 0 else f"with the file's flywheel J_F = {J:.4g} kg.m2"
    assert said in texts[0] and said in caption, (texts[0], caption)
    texts, caption, _ = seen["flywheel.png"]
    assert f"with J_F = {summary['J_F_simulated']:.4g} kg.m2 (sized)" in " ".join(texts)
    assert any(said.replace("with ", "", 1) in t or said in t for t in texts), texts


def test_the_inertia_figure_states_the_mechanisms_own_range(study):
    name, seen, summary = study
    texts, caption, lines = seen["J_e.png"]
    title = texts[0]
    assert engineering(summary["J_e_min"], "kg.m2") in title and engineering(summary["J_e_max"], "kg.m2") in title
    drawn = lines[0][1]                       # the curve: the mechanism's own J_e, the flywheel not added
    assert np.min(drawn) == pytest.approx(summary["J_e_min"], rel=1e-4)
    assert np.max(drawn) == pytest.approx(summary["J_e_max"], rel=1e-4)
    assert ("(Fig. 3)" in title) == (name == "seed003")


def test_the_loads_are_named_from_the_file(study):
    name, seen, _ = study
    legend = " ".join(seen["movement.png"][0])
    moment = " ".join(seen["turning_moment.png"][0])
    if name == "engine1":
        assert "M_load: the gas force on the piston and the generator" in legend, legend
        assert "driving: the gas force on the piston" in moment and "resisting: the generator" in moment, moment
    else:
        assert "M_load: the weights and the cutting force on the ram" in legend, legend
        assert "driving: the motor" in moment and "resisting: the cutting force on the ram" in moment, moment


def test_the_turning_moments_areas_are_the_swing_it_states(study):
    """Driving less resisting, integrated from the start, swings by the dW_max the legend states
    (the same number flywheel.json holds), to the trapezoid rule's error on the figure's grid."""
    _, seen, summary = study
    texts, _, lines = seen["turning_moment.png"]
    (deg, driving), (_, resisting) = lines[0], lines[1]
    phi = np.radians(deg)
    excess = driving - resisting
    stored = np.concatenate([[0.0], np.cumsum(0.5 * (excess[1:] + excess[:-1]) * np.diff(phi))])
    assert abs(stored[-1]) < 1e-3 * np.ptp(stored)             # the driving side balances over the cycle
    assert np.ptp(stored) == pytest.approx(summary["dW_max"], rel=2e-3)
    assert f"dW_max = {engineering(summary['dW_max'], 'J')} (eq. 17)" in texts


def test_the_movement_is_drawn_at_half_a_degree_or_finer(study):
    _, seen, _ = study
    deg, _ = seen["movement.png"][2][0]
    assert np.max(np.diff(deg)) <= 0.5 + 1e-9


def test_the_stability_figure_states_no_infinite_estimate(study):
    _, seen, summary = study
    texts, caption, _ = seen["eq3_stability.png"]
    estimate = summary["eq3_stability"]["linear_estimate_deg"]
    if estimate is None:                          # no motor slope: no estimate, said in words
        assert "no linear estimate" in caption and not any("inf" in t for t in texts), (texts, caption)
    else:
        assert math.isfinite(estimate) and f"= {estimate:.2f} deg" in " ".join(texts)


def test_the_baseline_delta_is_checked_by_the_crank_angle_cycle(study):
    _, _, summary = study
    assert summary["delta_baseline_crank_angle"] == pytest.approx(summary["delta_baseline"], rel=1e-6)
    if summary["baseline_J_flywheel"] > 0:
        assert summary["baseline_reason"] and summary["delta_without_flywheel"] is None


def test_the_reactions_caption_names_the_loads_that_switch(tmp_path):
    """The pump jack's reactions jump where its polished-rod load changes with the beam's direction:
    the caption names that load from the file, never a friction the machine does not have."""
    from PIL import Image

    assert main(["equilibrium", "pumpjack", "--out", str(tmp_path)]) == 0
    (figure,) = tmp_path.glob("reactions_*.png")
    with Image.open(figure) as image:
        caption = image.text["Description"]
    assert "the polished-rod load (rods and fluid up, buoyant rods down)" in caption, caption
    assert "friction" not in caption, caption


def test_an_animation_of_a_run_says_the_run_not_its_folder(tmp_path):
    from PIL import Image

    run = tmp_path / "some" / "folder"
    assert main(["simulate", "seed000", "--method", "fast", "--out", str(run)]) == 0
    assert main(["animate", "seed000", "--result", str(run), "--frames", "4", "--out", str(tmp_path / "run.gif")]) == 0
    with Image.open(tmp_path / "run.gif") as image:
        about = json.loads(image.info["comment"])
    summary = json.loads((run / "summary.json").read_text())
    said = f"a run from omega1 = {summary['parameters']['omega1_start']:.4g} rad/s over "
    for text in (about["title"], about["caption"]):
        assert str(tmp_path) not in text and "folder" not in text, text
        assert said in text and "s (fast)" in text, (said, text)


def test_the_wells_figures_name_its_unit_as_the_well_scales_it(tmp_path):
    """rp11l_guo scales C-114D-133-54's geometry to an 86 in stroke: its animation says so (its
    [unit] title), not the packaged pump jack's own name alone."""
    from PIL import Image

    from crankfmu.dynamics.well import load_well

    assert main(["well", "rp11l_guo", "--frames", "4", "--out", str(tmp_path)]) == 0
    with Image.open(tmp_path / "well.gif") as image:
        about = json.loads(image.info["comment"])
    assert about["title"].startswith(load_well("rp11l_guo").unit["title"]), about["title"]
    assert "86 in stroke" in about["title"]


@pytest.mark.parametrize("name", ["seed000", "seed001", "seed002", "seed003", "seed004", "pumpjack", "engine1",
                                  "engine4", "jansen"])
def test_the_default_experiments_output_follows_the_machines_speed(name):
    """A packaged scenario's output step (the FMUs' default experiment, simulate's CSV and figures)
    turns the crank at most 3 deg at the run's fastest: an engine's 1 ms was 21.6 deg at 3600 rpm, its
    curves sampled rather than drawn."""
    import crankfmu

    scenario = crankfmu.load_scenario(name)
    run = crankfmu.simulate(scenario, method="fast")
    step = scenario.experiment.output_interval
    assert math.degrees(float(np.max(np.abs(run.omega1))) * step) <= 3.0, (name, step, float(np.max(run.omega1)))


def test_a_title_wider_than_its_figure_is_drawn_smaller_until_it_fits(tmp_path):
    """A long title over a panel narrowed by its legend outside ran off the figure's left edge
    (engine1's flywheel figure): save_figure draws it again smaller until it fits."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from crankfmu.atomic import save_figure
    from crankfmu.plots import legend_outside

    fig, ax = plt.subplots(figsize=(8, 4), constrained_layout=True)
    ax.plot([0, 1], [0, 1], label="a legend label long enough to narrow the panel")
    legend_outside(ax)
    ax.set_title("a title far wider than the panel under it " * 4)
    size = ax.title.get_fontsize()
    save_figure(fig, tmp_path / "long.png", dpi=120)
    box = ax.title.get_window_extent(fig.canvas.get_renderer())
    assert box.x0 >= -0.5 and box.x1 <= fig.bbox.width + 0.5
    assert ax.title.get_fontsize() < size
    plt.close(fig)
