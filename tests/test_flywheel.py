"""Seed 003 (shaper, docs/papers.md data set): J_e by the paper's own velocity-ratio equations, the
flywheel found by simulation meets its target in a time-domain run, the eq. 3 stability limit."""

import json
import math

import numpy as np
import pytest

import crankfmu
from crankfmu.cli import main
from crankfmu.errors import AssemblyError, ParameterError
from crankfmu.studies.flywheel import design_flywheel, energy_swing, eq3_stability

TARGET = 0.05


@pytest.fixture(scope="module")
def seed003():
    return crankfmu.load_scenario("seed003")


@pytest.fixture(scope="module")
def flywheel_run(tmp_path_factory):
    """`crankfmu flywheel seed003 --delta 0.05` once for the module (about 20 s)."""
    out = tmp_path_factory.mktemp("flywheel")
    assert main(["flywheel", "seed003", "--delta", str(TARGET), "--out", str(out), "--steps-deg", "1,5,20"]) == 0
    return out, json.loads((out / "flywheel.json").read_text())


def test_equivalent_inertia_by_the_papers_velocity_ratios(seed003):
    """Eq. 12 with the velocity ratios of eqs. 10-11 solved here, against the reduced model."""
    p = seed003.values
    theta1 = np.radians(np.arange(0.0, 360.0, 1.0))
    bx, by = p["l1"] * np.cos(theta1), p["l6"] + p["l1"] * np.sin(theta1)
    s3, th3 = np.hypot(bx, by), np.arctan2(by, bx)
    h = p["l3"] * (1 + math.cos(math.asin(p["l1"] / p["l6"]))) / 2
    th4 = np.pi - np.arcsin((h - p["l3"] * np.sin(th3)) / p["l4"])
    r3 = np.empty_like(theta1)
    r4, rE = np.empty_like(theta1), np.empty_like(theta1)
    for i in range(theta1.size):
        a = np.array([[np.cos(th3[i]), -s3[i] * np.sin(th3[i])], [np.sin(th3[i]), s3[i] * np.cos(th3[i])]])
        _, r3[i] = np.linalg.solve(a, [-p["l1"] * np.sin(theta1[i]), p["l1"] * np.cos(theta1[i])])   # eq. 10
        b = np.array([[1.0, p["l4"] * np.sin(th4[i])], [0.0, -p["l4"] * np.cos(th4[i])]])
        vE, w4 = np.linalg.solve(b, [-p["l3"] * np.sin(th3[i]), p["l3"] * np.cos(th3[i])])            # eq. 11
        rE[i], r4[i] = vE * r3[i], w4 * r3[i]
    vD = p["l3"] * r3 * np.array([-np.sin(th3), np.cos(th3)])
    vS3 = vD * p["l3s"] / p["l3"]
    vS4 = 0.5 * (vD + np.array([rE, 0 * rE]))
    J_e = (p["J0"] + p["m3"] * np.sum(vS3 ** 2, axis=0) + p["m4"] * np.sum(vS4 ** 2, axis=0) + p["m5"] * rE ** 2
           + p["J3"] * r3 ** 2 + p["m4"] * p["l4"] ** 2 / 12 * r4 ** 2)
    J = seed003.build().reduced.coefficients(theta1)[0]
    assert np.max(np.abs(J - J_e)) < 1e-11
    # Fig. 3's shape: minimum J0 where the lever stops (the crank at right angles to it, near 107 and
    # 253 deg of the paper's angle), maximum in the middle of the quick return (near 180 deg)
    paper_deg = (np.degrees(theta1) - 90) % 360
    assert J.min() == pytest.approx(p["J0"], abs=1e-3)
    assert abs(paper_deg[np.argmax(J)] - 180) < 3
    assert min(abs(paper_deg[np.argmin(J)] - a) for a in (106.8, 253.2)) < 1


def test_energy_swing_against_a_plain_trapezoid(seed003):
    model = seed003.with_params(J_flywheel=0.0).build()
    dW, _, _ = energy_swing(model)
    phi = np.linspace(0, 2 * np.pi, 200001)
    J, half_dJ, Q, kin = model.reduced.coefficients(phi)
    Q = Q + model.reduced.velocity_load(kin, np.ones_like(phi))
    work = np.concatenate([[0.0], np.cumsum(0.5 * (Q[1:] + Q[:-1]) * np.diff(phi))])
    swing = work - work[-1] / (2 * np.pi) * phi
    assert dW == pytest.approx(np.ptp(swing), rel=1e-4)    # the trapezoid smears the jumps: O(h)


def test_flywheel_found_by_simulation_meets_the_target_in_a_time_domain_run(seed003, flywheel_run):
    _, d = flywheel_run
    assert d["J_F_eq16"] == pytest.approx(d["J_F_eq17"] - d["J_e_mean"], rel=1e-12)
    assert d["J_F_eq17"] == pytest.approx(d["dW_max"] / (d["omega_m"] ** 2 * TARGET), rel=1e-12)
    assert d["delta_achieved"] == pytest.approx(TARGET, rel=1e-9)
    # the fast kernel's delta (secant shooting, time domain, on the tables) against the periodic
    # solution in the crank angle on the engine (DOP853, rtol 1e-11, extremes located): measured
    # to agree to about 2e-11 relative; 1e-9 leaves room for the two tolerances
    assert d["delta_achieved_crank_angle"] == pytest.approx(d["delta_achieved"], rel=1e-9)
    assert d["delta_baseline_crank_angle"] == pytest.approx(d["delta_baseline"], rel=1e-9)
    assert d["delta_baseline"] == d["delta_without_flywheel"]          # seed003's design starts from none
    assert 0 < d["J_F_simulated"] < d["J_F_eq17"]           # the steep motor line regulates too
    assert d["delta_with_J_F_eq17"] < TARGET
    # an independent check: the time-domain reference from the scenario's start, run until settled
    scenario = seed003.with_params(J_flywheel=d["J_F_simulated"])
    r = crankfmu.simulate(scenario, t_end=9.0, rtol=1e-9)
    k = int((r.phi1[-1] - r.phi1[0]) // (2 * np.pi)) - 1
    stats = r.cycle_stats(k)
    assert stats["delta"] == pytest.approx(TARGET, rel=0.01)
    assert d["epsilon_peak_reduction"] > 0.5 and d["omega_peak_reduction"] > 0


def test_no_flywheel_when_the_mechanism_already_meets_the_target(seed003):
    d = design_flywheel(seed003, 0.2)          # without a flywheel delta is 0.0618
    assert d.J_F_simulated == 0.0
    assert d.delta_achieved == d.delta_without_flywheel < 0.2
    assert d.delta_achieved_crank_angle == pytest.approx(d.delta_achieved, rel=1e-9)


def test_flywheel_outputs_written(flywheel_run):
    out, d = flywheel_run
    for key in ("J_e_min", "J_e_max", "dW_max", "J_F_eq17", "J_F_eq16", "J_F_simulated", "delta_achieved"):
        assert math.isfinite(d[key])
    for name in ("J_e.png", "movement.png", "flywheel.png", "eq3_stability.png"):
        assert (out / name).stat().st_size > 10_000
    assert d["movement"]["eq3_1deg_max_error_first_3_turns"] < 0.2


def test_eq3_stability_limit_near_the_linear_estimate(seed003):
    s = eq3_stability(seed003, [5.0, 9.0, 11.0, 20.0], turns=20, resolution_deg=0.05)
    rows = {r["step_deg"]: r for r in s.rows}
    assert rows[5.0]["stable"] and rows[9.0]["stable"]
    assert not rows[11.0]["stable"] and not rows[20.0]["stable"]
    limit = s.limit["largest_stable_deg"]
    # linearised: |1 - dphi B / (J omega1)| < 1 at the cycle's worst point, so the limit is at
    # least the estimate (taken at the worst point) and not far above it
    assert s.linear_estimate_deg * 0.98 < limit < s.linear_estimate_deg * 1.2
    assert rows[5.0]["error"] < 0.15


def test_a_bigger_flywheel_moves_the_eq3_limit(seed003):
    """2 J omega1 / B: ten times the inertia, about ten times the stable step."""
    s = eq3_stability(seed003.with_params(J_flywheel=9 * 31.0), [20.0, 60.0], turns=6)
    assert s.linear_estimate_deg > 80
    assert all(r["stable"] for r in s.rows)


def test_bad_flywheel_inputs(seed003, capsys, tmp_path):
    for bad in (0.0, -0.05, 1.0, float("nan")):
        with pytest.raises(ParameterError, match="delta"):
            design_flywheel(seed003, bad)
    assert main(["flywheel", "seed003", "--delta", "0", "--out", str(tmp_path)]) == 1
    assert "delta" in capsys.readouterr().err
    with pytest.raises(AssemblyError, match="l4"):
        seed003.with_params(l4=0.005).build()
