"""Drawings and animations of mechanisms (packaged and a user's own), the fixed study plots, and the
FMU documentation: every figure is rendered and looked at (non-empty, no two texts overlapping by
matplotlib's rendered extents), and the geometry it shows is checked against a second method."""

from __future__ import annotations

import html

import math
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pytest

from crankfmu import load_scenario
from crankfmu.cli import main
from crankfmu.errors import CrankfmuError, ParameterError
from crankfmu.plots import pyplot
from crankfmu.pictures.animate import animate, animation_figure
from crankfmu.pictures.draw import OVERLAYS, draw_figure, save
from crankfmu.pictures.labels import overlapping_texts
from crankfmu.pictures.sketch import Sketch

ROOT = Path(__file__).resolve().parents[1]
USER = ROOT / "tests" / "data" / "user" / "sixbar_scenario.toml"
MECHANISMS = {"packaged seed002": "seed002", "user six-bar": str(USER)}


def ink(path: Path) -> float:
    """Share of the image's pixels that are not white: a drawn figure has lines, not a blank page."""
    from PIL import Image

    img = np.asarray(Image.open(path).convert("L"), dtype=float)
    return float(np.mean(img < 250))


def test_a_point_on_another_all_the_turn_shares_its_label():
    """engine1's slider-crank keeps the rod's point C at A (l_AC = 0): one label "A = C", not C on top
    of A; B, apart from A, keeps its own."""
    fig = draw_figure(load_scenario("engine1"), 30.0)
    texts = [t.get_text() for t in fig.findobj(lambda a: hasattr(a, "get_text")) if t.get_text()]
    assert "A = C" in texts and "C" not in texts and "A" not in texts and "B" in texts, texts


@pytest.mark.parametrize("which", MECHANISMS)
def test_drawing_with_every_overlay_is_drawn_and_its_labels_do_not_overlap(which, tmp_path):
    fig = draw_figure(load_scenario(MECHANISMS[which]), 40.0, OVERLAYS, trace=None)
    assert overlapping_texts(fig) == []
    texts = {t.get_text() for t in fig.findobj(lambda a: hasattr(a, "get_text")) if t.get_text()}
    assert {"A", "O"} <= texts                                  # point labels
    assert any(t.startswith("v_A ") for t in texts)             # velocities with their magnitudes
    assert any(t.startswith("F_") and t.endswith(" N") for t in texts)   # reactions
    assert any(t.endswith(" m") and t[0].isdigit() for t in texts)       # the length scale
    save(fig, tmp_path / "m.png")
    assert ink(tmp_path / "m.png") > 0.02


def test_the_drawn_instant_centre_is_where_the_normals_to_two_velocities_meet():
    """Second method: seed 002's rod, I2 as the intersection of the normals to v_A and v_B (the
    paper's construction, Fig. 2), against the sketch's I = P + k x v_P / w from the mass centre;
    and I2A against the paper's graphical 0.56 m (read to 1.5 %)."""
    scenario = load_scenario("seed002")
    sketch = Sketch.of(scenario.assembled_mechanism()[0])
    frames = sketch.frames([math.radians(30.0)])
    ic = sketch.instant_centre(frames, "rod")
    a, b = frames.xy["A"][0], frames.xy["B"][0]
    va, vb = frames.v["A"][0], frames.v["B"][0]
    # a + s va_perp = b + t vb_perp
    perp = lambda v: np.array([-v[1], v[0]])  # noqa: E731
    s, _ = np.linalg.solve(np.column_stack([perp(va), -perp(vb)]), b - a)
    meet = a + s * perp(va)
    assert np.allclose(ic, meet, rtol=0, atol=1e-12)
    assert abs(np.hypot(*(ic - a)) - 0.56) / 0.56 < 0.015


@pytest.mark.parametrize("which", MECHANISMS)
def test_bars_and_blocks_sit_at_the_contour_engines_positions(which):
    """The drawing moves its artists to the kinematics of the mechanism file: every pin marker at
    the engine's point, every bar's ends on its link's joints, each block centred on its slide."""
    from crankfmu.pictures.draw import MechanismPicture

    scenario = load_scenario(MECHANISMS[which])
    mechanism = scenario.assembled_mechanism()[0]
    sketch = Sketch.of(mechanism)
    phis = np.radians([0.0, 73.0, 200.0])
    frames = sketch.frames(phis)
    kin = mechanism.kinematics(phis)
    fig, ax = pyplot().subplots()
    picture = MechanismPicture(ax, sketch, frames, sketch.frames(np.linspace(0, 2 * np.pi, 73)))
    for i in range(phis.size):
        picture.update(i)
        pins = np.column_stack(picture.pins.get_data())
        expected = np.array([[kin.point(p)[0][i], kin.point(p)[1][i]] for p in [*sketch.ground_pins, *sketch.pins]])
        assert np.allclose(pins, expected, atol=1e-12)
        for link, line in picture.bars.items():
            ends = np.column_stack(line.get_data())
            joints = np.array([frames.xy[p][i] for p in sketch.link_points[link]])
            for end in ends:
                assert np.min(np.hypot(*(joints - end).T)) < 1e-12
        for s in sketch.slides:
            assert np.allclose(picture.blocks[s.joint].get_xy()[:4].mean(axis=0), frames.xy[s.point][i], atol=1e-12)
    pyplot().close(fig)


def test_a_links_with_three_joints_off_one_line_is_a_plate_and_a_slider_is_a_block():
    sketch = Sketch.of(load_scenario(str(USER)).assembled_mechanism()[0])
    assert {"A", "B", "P"} <= set(sketch.link_points["plate"])      # and its mass centre G2, inside
    frames = sketch.frames([0.3])
    from crankfmu.pictures.sketch import is_colinear

    assert not is_colinear(np.array([frames.xy[p][0] for p in sketch.link_points["plate"]]), 1.0)
    # a point carried by a link beyond its joints extends its bar: the pumping unit's horsehead
    pumpjack = Sketch.of(load_scenario("pumpjack").assembled_mechanism()[0])
    assert {"E", "S", "H"} <= set(pumpjack.link_points["beam"])
    assert [(s.block, s.guide) for s in sketch.slides] == [("slider", "ground")]
    shaper = Sketch.of(load_scenario("seed003").assembled_mechanism()[0])
    assert {(s.block, s.guide) for s in shaper.slides} == {("block", "lever"), ("ram", "ground")}


def test_a_mechanism_without_joints_is_drawn_from_its_point_definitions(tmp_path):
    """No [[joints]]: each point is joined to the point it is defined from (A from O, B from A,
    P from A, D from P), mass centres aside."""
    import re
    import shutil

    text = (USER.parent / "sixbar.toml").read_text()
    (tmp_path / "sixbar.toml").write_text(re.sub(r"\[\[joints\]\].*?(?=\n\[assembly\])", "", text, flags=re.S))
    shutil.copy(USER, tmp_path / "scenario.toml")
    scenario = load_scenario(str(tmp_path / "scenario.toml"))
    sketch = Sketch.of(scenario.assembled_mechanism()[0])
    assert not sketch.link_points and sorted(sketch.segments) == [("", "A", "B"), ("", "A", "P"), ("", "O", "A"),
                                                                  ("", "P", "D")]
    fig = draw_figure(scenario, 40.0, ["velocities", "instant_centres"])
    assert overlapping_texts(fig) == []
    save(fig, tmp_path / "n.png")
    assert ink(tmp_path / "n.png") > 0.02


@pytest.mark.parametrize("which", MECHANISMS)
def test_animation_frames_keep_their_labels_apart_and_the_gif_has_every_frame(which, tmp_path):
    scenario = load_scenario(MECHANISMS[which])
    fig, frame, count = animation_figure(scenario, trace=None, frames=9)
    for i in (0, 4, 8):
        frame(i)
        assert overlapping_texts(fig) == [], f"frame {i}"
    pyplot().close(fig)
    from PIL import Image

    path = animate(scenario, tmp_path / "a.gif", frames=6, fps=10)
    with Image.open(path) as img:
        assert img.n_frames == 6
        assert img.size[0] > 400
        img.seek(3)
        assert np.mean(np.asarray(img.convert("L")) < 250) > 0.02


@pytest.mark.parametrize("name", ["seed000", "seed001", "seed003", "seed004"])
def test_every_packaged_animation_and_drawing_keeps_its_texts_apart(name):
    scenario = load_scenario(name)
    fig, frame, count = animation_figure(scenario, frames=3)
    for i in range(count):
        frame(i)
        assert overlapping_texts(fig) == [], f"frame {i}"
    pyplot().close(fig)
    fig = draw_figure(scenario, 100.0, OVERLAYS)
    assert overlapping_texts(fig) == []
    pyplot().close(fig)


def test_animation_of_a_simulated_run_follows_its_crank_angle(tmp_path):
    from crankfmu import simulate
    from crankfmu.output import write_run

    scenario = load_scenario("seed000")
    write_run(simulate(scenario, method="fast"), tmp_path / "run")
    fig, frame, count = animation_figure(scenario, result_dir=tmp_path / "run", trace=["B"], frames=5)
    frame(count - 1)
    readout = [t.get_text() for t in fig.texts if t.get_text().startswith("t = ")][0]
    assert readout.startswith("t =   2.0000 s")
    pyplot().close(fig)


def test_bad_drawing_and_animation_requests_are_refused_with_the_parameter_named(tmp_path):
    seed002 = load_scenario("seed002")
    with pytest.raises(ParameterError, match="unknown overlay.*valid: velocities"):
        draw_figure(seed002, 30.0, ["forces"])
    with pytest.raises(ParameterError, match="trace: 'Z' is not a point.*points: O, A"):
        draw_figure(seed002, 30.0, trace=["Z"])
    with pytest.raises(ParameterError, match="--at must be a crank angle"):
        draw_figure(seed002, math.nan)
    with pytest.raises(ParameterError, match="omega1 = -1.*> 0"):
        draw_figure(seed002, 30.0, ["velocities"], omega1=-1.0)
    with pytest.raises(ParameterError, match="--frames must be an integer in \\[2, 2000\\]"):
        animate(seed002, tmp_path / "a.gif", frames=1)
    with pytest.raises(ParameterError, match="written as .gif or .mp4"):
        animate(seed002, tmp_path / "a.avi")
    with pytest.raises(CrankfmuError, match="no timeseries.csv there"):
        animate(seed002, tmp_path / "a.gif", result_dir=tmp_path)
    assert main(["draw", "seed002", "--out", str(tmp_path / "x.jpg")]) == 1


def test_mp4_without_ffmpeg_is_refused_with_the_fix(tmp_path, monkeypatch):
    import shutil

    monkeypatch.setattr(shutil, "which", lambda name: None)
    with pytest.raises(CrankfmuError, match="MP4 needs ffmpeg on the PATH.*write a .gif"):
        animate(load_scenario("seed002"), tmp_path / "a.mp4")


def test_draw_and_animate_commands_write_their_files(tmp_path, capsys):
    assert main(["draw", str(USER), "--reactions", "--out", str(tmp_path / "u.svg")]) == 0
    assert (tmp_path / "u.svg").read_text().lstrip().startswith("<?xml")
    assert main(["animate", "seed004", "--frames", "3", "--out", str(tmp_path / "q.gif")]) == 0
    assert (tmp_path / "q.gif").stat().st_size > 10_000
    assert "wrote" in capsys.readouterr().out


def test_velocity_plan_has_no_overlapping_labels_and_a_square_frame_around_the_polygon(tmp_path):
    from crankfmu.pictures.velocity_plan import plot_velocity_plan
    from crankfmu.studies.kinematics import values_at

    scenario = load_scenario("seed002")
    _, detail = values_at(scenario, 30.0)
    plt = pyplot()
    captured = {}
    original = plt.close
    plt.close = lambda fig=None: captured.setdefault("fig", fig)
    try:
        plot_velocity_plan(detail, scenario.kinematics_study["relative"], tmp_path / "plan.png", "plan")
    finally:
        plt.close = original
    fig = captured["fig"]
    ax = fig.axes[0]
    assert overlapping_texts(fig) == []
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert math.isclose(x1 - x0, y1 - y0, rel_tol=1e-9)
    corners = np.array([[0.0, 0.0], *detail["velocities"].values()])
    assert np.all(corners[:, 0] > x0) and np.all(corners[:, 0] < x1)
    assert np.all(corners[:, 1] > y0) and np.all(corners[:, 1] < y1)
    # the polygon fills the frame: no half of it empty
    assert np.ptp(corners[:, 0]) > 0.5 * (x1 - x0) or np.ptp(corners[:, 1]) > 0.5 * (y1 - y0)
    plt.close(fig)


def test_steady_map_is_logarithmic_with_labelled_target_contours(tmp_path):
    from matplotlib.colors import LogNorm

    from crankfmu.plots import plot_steady
    from crankfmu.studies.sweep import SweepAxis, run_sweep

    scenario = load_scenario("seed000")
    axes = [SweepAxis.parse("J_flywheel=0:20:6", scenario), SweepAxis.parse("B=10:30:5", scenario)]
    result = run_sweep(scenario, axes, tmp_path, scheduler="serial", study="steady")
    plt = pyplot()
    captured = {}
    original = plt.close
    plt.close = lambda fig=None: captured.setdefault("fig", fig)
    try:
        plot_steady(result, tmp_path, {"J_flywheel": "kg.m2", "B": "N.m.s/rad"})
    finally:
        plt.close = original
    fig = captured["fig"]
    mesh = fig.axes[0].collections[0]
    assert isinstance(mesh.norm, LogNorm)
    labels = sorted(t.get_text() for t in fig.axes[0].texts)
    deltas = [r["delta"] for r in result.rows]
    expected = [f"delta = {d:g}" for d in (0.01, 0.02, 0.05, 0.1) if min(deltas) < d < max(deltas)]
    assert expected and set(expected) <= set(labels)
    assert overlapping_texts(fig) == []
    plt.close(fig)


def test_every_fmu_carries_its_documentation(fmu_path):
    """documentation/index.html (FMI 2.0, 2.10): every variable of the modelDescription with its unit,
    the images it shows inside the FMU, the equations and the default experiment; a mechanism's (as
    its annotation says: a component's kind is its data file's) also its drawing and movement
    equation."""
    from crankfmu.fmi.ssp import built_from

    for fmu in sorted(Path(fmu_path).parent.glob("*.fmu")):
        with zipfile.ZipFile(fmu) as z:
            names = set(z.namelist())
            page = z.read("documentation/index.html").decode()
            md = ET.fromstring(z.read("modelDescription.xml"))
        for sv in md.find("ModelVariables"):
            assert f"<td>{sv.get('name')}</td>" in page, (fmu.name, sv.get("name"))
            real = sv.find("Real")
            if real is not None and real.get("unit"):
                assert f"<td>{real.get('unit')}</td>" in page
        for src in __import__("re").findall(r'src="([^"]+)"', page):
            assert f"documentation/{src}" in names, (fmu.name, src)
        assert "Default experiment" in page and "Equations" in page
        assert "dynamics." not in page, fmu.name                  # no module names: the reader has the page
        source = built_from(fmu)
        if source.get("kind") == "scenario":      # a mechanism, not a component (a drive, a shaft, ...)
            # the movement equation as MathML (its annotation keeps the text it was written as)
            assert "documentation/mechanism.png" in names and "J(phi1)*der(omega1)" in page and "<math" in page
            # J's derivative with primed symbols, never a word set upright ("tt_j" as text)
            assert 'mathvariant="normal">tt_j' not in page and "<mo>′</mo>" in page, fmu.name
            # what drives it and its loads, from its own file (an engine has no motor, a gas force, a generator)
            from crankfmu.fmi.documentation import machine_words

            if source.get("file"):            # a user's scenario: the copy the FMU carries
                from crankfmu.validation.fmu_runner import FmuUnderTest

                under_test = FmuUnderTest(fmu)
                scenario = load_scenario(under_test.scenario_source)
                under_test.close()
            else:
                scenario = load_scenario(source["name"])
            said = machine_words(scenario, source.get("causality") == "speed")
            assert html.escape(said) in page, (fmu.name, said)


def test_an_animation_fits_a_page_at_most_one_megabyte_with_readable_text(tmp_path):
    """A full 120-frame GIF of a mechanism (seed 001, the busiest drawing) is at most 1 MB at 441
    pixels high and at most 960 wide (9 pt text 12 px high at 96 dpi): one palette for all frames,
    no dithering, so each frame after the first stores only what moved. The frames still differ
    where the links move. At constant speed the mechanism alone fills the frame (a speed panel
    would be a flat line), as wide as its shape needs."""
    from PIL import Image

    path = animate(load_scenario("seed001"), tmp_path / "a.gif", frames=120, fps=20)
    assert path.stat().st_size <= 1_000_000, path.stat().st_size
    with Image.open(path) as img:
        assert img.n_frames == 120 and img.size[1] >= 440 and 576 <= img.size[0] <= 960, img.size
        img.seek(0)
        first = np.asarray(img.convert("L")).copy()
        img.seek(60)
        half = np.asarray(img.convert("L"))
    assert np.mean(first != half) > 0.005
