"""Seed 002 (slider-crank) and seed 004 (quick-return): the engine against closed forms written
here independently, the papers' numbers, the sweep and its failures."""

import csv
import json
import math

import numpy as np
import pytest

import crankfmu
from crankfmu.cli import main
from crankfmu.studies.kinematics import cycle, time_series, values_at
from crankfmu.mechanisms import Mechanism, load_mechanism
from crankfmu.studies.sweep import SweepAxis, run_sweep

R, BL, AC, W = 0.25, 0.5, 0.3, 31.41          # seed 002: OA, AB, AC, omega1


def slider_crank_closed_form(phi):
    """Exact slider-crank kinematics by hand: psi the rod's angle below the x axis."""
    s, c = math.sin(phi), math.cos(phi)
    psi = math.asin(R * s / BL)
    dpsi = R * c / (BL * math.cos(psi))
    ddpsi = (-R * s * BL * math.cos(psi) + R * c * BL * math.sin(psi) * dpsi) / (BL * math.cos(psi)) ** 2
    A = np.array([R * c, R * s])
    dA = np.array([-R * s, R * c])
    xB = R * c + BL * math.cos(psi)
    dB = np.array([-R * s - BL * math.sin(psi) * dpsi, 0.0])
    ddB = np.array([-R * c - BL * math.cos(psi) * dpsi ** 2 - BL * math.sin(psi) * ddpsi, 0.0])
    C = np.array([R * c + AC * math.cos(psi), R * s - AC * math.sin(psi)])
    dC = np.array([-R * s - AC * math.sin(psi) * dpsi, R * c - AC * math.cos(psi) * dpsi])
    ddC = np.array([-R * c - AC * (math.cos(psi) * dpsi ** 2 + math.sin(psi) * ddpsi),
                    -R * s - AC * (-math.sin(psi) * dpsi ** 2 + math.cos(psi) * ddpsi)])
    I2 = np.array([xB, xB * math.tan(phi)])     # OA extended meets the normal to v_B through B
    B = np.array([xB, 0.0])
    n = np.linalg.norm
    return {"v_A": W * n(dA), "v_B": W * n(dB), "v_C": W * n(dC), "Omega2": W * abs(dpsi),
            "v_BA": W * n(dB - dA), "v_CA": W * n(dC - dA), "I2_x": I2[0], "I2_y": I2[1],
            "I2A": n(I2 - A), "I2B": n(I2 - B), "I2C": n(I2 - C), "a_B": W * W * n(ddB),
            "eps2": W * W * abs(ddpsi), "a_C": W * W * n(ddC)}


@pytest.fixture(scope="module")
def seed002():
    return crankfmu.load_scenario("seed002")


@pytest.fixture(scope="module")
def seed004():
    return crankfmu.load_scenario("seed004")


def test_seed002_values_at_30_deg_against_closed_form(seed002):
    values, _ = values_at(seed002, 30.0)
    expected = slider_crank_closed_form(math.radians(30.0))
    assert set(values) == set(expected)
    for name, v in expected.items():
        assert values[name] == pytest.approx(v, rel=1e-9, abs=1e-12), name


def test_seed002_within_1_5_percent_of_the_paper(seed002):
    values, _ = values_at(seed002, 30.0)
    # the paper's graphical values (Figs. 2 and 5, mu_l = 0.01 m/mm, mu_V = 0.15 (m/s)/mm)
    paper = {"v_A": 7.85, "Omega2": 14.0, "v_B": 5.75, "v_C": 5.75, "v_BA": 7.05, "v_CA": 28 * 0.15,
             "I2A": 0.56, "I2B": 0.41, "I2C": 0.41}
    for name, v in paper.items():
        assert abs(v - values[name]) / values[name] <= 0.015, name


def test_instant_centre_relations(seed002):
    for at in (30.0, 75.0, 130.0, 250.0):
        v, _ = values_at(seed002, at)
        assert v["Omega2"] == pytest.approx(v["v_A"] / v["I2A"], rel=1e-12)
        assert v["v_B"] == pytest.approx(v["Omega2"] * v["I2B"], rel=1e-12)
        assert v["v_C"] == pytest.approx(v["Omega2"] * v["I2C"], rel=1e-12)


def test_mathcad_approximation_error(seed002):
    """The paper's psi = atan(Y_A/b) overestimates X_B most at 90 deg: b cos(atan(r/b)) - sqrt(b^2 - r^2)."""
    ts = time_series(seed002, span=2 * math.pi / W, n=3601)
    expected = BL * math.cos(math.atan(R / BL)) - math.sqrt(BL ** 2 - R ** 2)
    assert ts["approx_errors"]["x_B"] == pytest.approx(expected, rel=1e-6)


# ---------------------------------------------------------------- seed 004
L1, L3, L4, E, H, W4 = 0.2, 0.9, 0.7, 0.4, 0.5, 5.0


def quick_return_closed_form(phi, l1=L1, e=E):
    """Eqs. 3-6 of seed 004, with sin/cos of phi3 from eq. 1 (so complex steps pass through)."""
    s3 = np.sqrt(l1 ** 2 + 2 * l1 * e * np.sin(phi) + e ** 2)
    c3, s3n = -l1 * np.cos(phi) / s3, -(l1 * np.sin(phi) + e) / s3
    phi4 = np.arcsin((L3 * s3n + H) / L4)
    s5 = -L3 * c3 + L4 * np.cos(phi4)
    return {"s3": s3, "phi4": phi4, "s5": s5}


def test_seed004_closed_forms_against_the_engine_over_3600_angles():
    phi = np.linspace(0.0, 2 * math.pi, 3600, endpoint=False)
    values = {"l1": L1, "l3": L3, "l4": L4, "e": E, "h": H, "q1": 1, "m2": 1, "q3": 1, "q4": 1, "m5": 1}
    definition = load_mechanism("quickreturn")
    for closed in (True, False):          # the file's closed form and the Newton path
        kin = Mechanism(definition, values, use_closed_form=closed).kinematics(phi)
        ref = quick_return_closed_form(phi)
        # first derivatives by complex step, second by central differences of complex steps
        def d1(x):
            return {k: np.imag(v) / 1e-30 for k, v in quick_return_closed_form(x + 1e-30j).items()}
        dref = d1(phi)
        h = 1e-4
        ddref = {k: (d1(phi + h)[k] - d1(phi - h)[k]) / (2 * h) for k in dref}
        for u in ("s3", "phi4", "s5"):
            assert np.max(np.abs(kin.q[u] - ref[u])) < 1e-12, u
            assert np.max(np.abs(kin.dq[u] - dref[u])) < 1e-12 * max(1, np.max(np.abs(dref[u]))), u
            assert np.max(np.abs(kin.ddq[u] - ddref[u])) < 1e-6 * max(1, np.max(np.abs(ddref[u]))), u
        dphi3 = L1 * (L1 + E * np.sin(phi)) / ref["s3"] ** 2       # d/dphi1 of eq. 4, by hand
        assert np.max(np.abs(kin.dq["phi3"] - dphi3)) < 1e-12


def test_seed004_arm_speed_at_90_and_270_deg(seed004):
    mech = seed004.assembled_mechanism()[0]
    kin = mech.kinematics(np.radians([90.0, 270.0]))
    omega3 = kin.dq["phi3"] * W4
    assert omega3[0] == pytest.approx(L1 * W4 / (E + L1), rel=1e-12)
    assert omega3[1] == pytest.approx(-L1 * W4 / (E - L1), rel=1e-12)


@pytest.mark.parametrize("e,l1", [(0.4, 0.2), (0.35, 0.25), (0.45, 0.15)])
def test_seed004_stroke_time_ratio_and_swing(seed004, e, l1):
    c = cycle(seed004.with_params(e=e, l1=l1), ["omega3"])
    alpha = math.asin(l1 / e)
    assert c["stroke"] == pytest.approx(2 * L3 * l1 / e, rel=1e-12)
    assert c["time_ratio"] == pytest.approx((math.pi + 2 * alpha) / (math.pi - 2 * alpha), rel=1e-12)
    assert c["arm_swing"] == pytest.approx(2 * alpha, rel=1e-12)


def test_sweep_reports_a_failed_design_and_resumes(seed004, tmp_path):
    axes = [SweepAxis.parse("e=0.30:0.45:4", seed004), SweepAxis.parse("l1=0.15:0.30:4", seed004)]
    r = run_sweep(seed004, axes, tmp_path)
    assert len(r.rows) == 15 and len(r.failed) == 1
    assert (r.failed[0]["e"], r.failed[0]["l1"]) == (0.3, 0.3) and "l1 < 0.299999 m" in r.failed[0]["reason"]
    with (tmp_path / "peaks.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 15
    assert list(rows[0]) == ["e", "l1", "max_abs_omega3", "max_abs_eps3", "max_abs_v5", "max_abs_a5",
                             "time_ratio", "stroke"]
    again = run_sweep(seed004, axes, tmp_path)
    assert again.skipped == 15
    with (tmp_path / "peaks.csv").open() as f:
        assert len(list(csv.DictReader(f))) == 15
    # default design row: omega3 peak = l1 w1/(e - l1)
    row = next(x for x in rows if float(x["e"]) == 0.4 and float(x["l1"]) == 0.2)
    assert float(row["max_abs_omega3"]) == pytest.approx(0.2 * 5 / 0.2, rel=1e-9)


def test_out_of_range_designs_are_listed_with_the_range(seed004, tmp_path):
    r = run_sweep(seed004, [SweepAxis.parse("e=-0.1:0.4:2", seed004)], tmp_path)
    assert len(r.rows) == 1 and "valid range (0, inf) m" in r.failed[0]["reason"]


def test_cli_kinematics_and_sweep(tmp_path, capsys):
    assert main(["kinematics", "seed002", "--at", "30", "--out", str(tmp_path / "k")]) == 0
    values = json.loads((tmp_path / "k" / "values.json").read_text())
    assert list(values) == ["v_A", "v_B", "v_C", "Omega2", "v_BA", "v_CA", "I2_x", "I2_y", "I2A", "I2B",
                            "I2C", "a_B", "a_C", "eps2"]
    for png in ("x_B", "v_B", "a_B", "path", "velocity_plan"):
        assert (tmp_path / "k" / f"{png}.png").stat().st_size > 10_000
    assert main(["sweep", "seed004", "--param", "e=0.30:0.45:4", "--param", "l1=0.15:0.30:4",
                 "--out", str(tmp_path / "s")]) == 0
    out = capsys.readouterr().out
    assert "FAILED e = 0.3, l1 = 0.3" in out and "claim:" in out
    assert len(list((tmp_path / "s").glob("*_vs_*.png"))) == 8


@pytest.mark.parametrize("argv, message", [
    (["kinematics", "seed002", "--at", "nan", "--out", "x"], "crank angle"),
    (["kinematics", "seed002", "--at", "30", "--omega", "-1", "--out", "x"], "omega1 must be"),
    (["kinematics", "seed000", "--at", "30", "--out", "x"], "no [kinematics] section"),
    (["kinematics", "seed002", "--at", "30", "--set", "l2=0.2", "--out", "x"], "l2 > 0.25"),
    (["sweep", "seed004", "--param", "e=0.3:0.45", "--out", "x"], "NAME=START:STOP:COUNT"),
    (["sweep", "seed004", "--param", "zz=0.3:0.45:4", "--out", "x"], "unknown parameter 'zz'"),
    (["sweep", "seed004", "--param", "e=-1:-0.5:2", "--out", "x"], "no design of the sweep could be computed"),
])
def test_bad_kinematic_input(argv, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 1
    assert message in capsys.readouterr().err
