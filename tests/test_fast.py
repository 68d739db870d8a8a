"""The fast path (issue 6): the tabulated model against the engine, the C kernel against the
reference, its located switches, batch steady cycles, the sweep."""

import math
import subprocess
import sys

import numpy as np
import pytest

import crankfmu
from crankfmu.scenario import load_scenario
from crankfmu.studies.batch import steady_cycles
from crankfmu.dynamics.tabulated import tabulate
from crankfmu.errors import ParameterError
from crankfmu.dynamics.tabulated import table_of
from crankfmu.integrators.fast import FastIntegrator
from crankfmu import native as layout

SCENARIOS = ["seed000", "seed001", "seed002", "seed003", "seed004"]


@pytest.mark.parametrize("name", SCENARIOS)
def test_table_matches_the_engine_within_its_checked_bound_at_random_angles(name):
    model = crankfmu.load_scenario(name).build()
    table = table_of(model.reduced)
    assert table.error_bound <= table.tolerance
    rng = np.random.default_rng(7)
    phi = rng.uniform(-20.0, 20.0, 3000)          # unwrapped angles, both signs
    omega = rng.choice([-1.0, 1.0], 3000) * rng.uniform(0.5, 30.0, 3000)
    J, half_dJ, Q = table.coefficients_at(phi, omega, model.reduced.J_flywheel)
    J_e, half_e, Q_e, kin = model.reduced.coefficients(phi)
    Q_e = Q_e + model.reduced.velocity_load(kin, omega)
    # the check angles are where a cubic spline errs most; random angles stay within a few times
    # the bound relative to each function's scale (Q's scale includes the slider forces' jumps)
    for got, exact in ((J, J_e), (half_dJ, half_e), (Q, Q_e)):
        scale = np.max(np.abs(exact))
        assert np.max(np.abs(got - exact)) <= 10 * table.tolerance * scale + 1e-12


def test_table_refuses_an_impossible_tolerance():
    model = crankfmu.load_scenario("seed000").build()
    with pytest.raises(crankfmu.CrankfmuError, match="cannot be tabulated"):
        tabulate(model.reduced, tolerance=1e-18, n_max=1024, loosest=1e-18)


def test_a_near_dead_point_geometry_is_tabulated_to_a_looser_reported_bound_and_still_right():
    scenario = crankfmu.load_scenario("seed004").with_params(e=0.21)
    table = table_of(scenario.build().reduced)
    assert table.tolerance < table.error_bound <= 1e-8
    fast = crankfmu.simulate(scenario, method="fast", t_end=0.5)
    ref = crankfmu.simulate(scenario, method="reference", t_end=0.5)
    assert fast.settings["table_error"] == table.error_bound
    assert np.max(np.abs(fast.omega1 - ref.omega1)) <= 1e-6 * np.max(np.abs(ref.omega1))


def test_fast_seed000_meets_1e8_rad_s_at_its_default_rtol(reference):
    fast = crankfmu.simulate("seed000", method="fast")
    assert fast.settings["rtol"] == 1e-11
    assert np.max(np.abs(fast.omega1 - reference.omega1)) <= 1e-8
    # the kink is located: the event's speed is omega_switch
    t_kink = [t for t, what in fast.trajectory.events if "kink" in what]
    assert len(t_kink) == 1
    assert fast.state([t_kink[0]])[1, 0] == pytest.approx(5.0, abs=1e-12)
    # outputs from the tables agree with the engine's at the same states
    eq = fast.model.equation.outputs(fast.phi1, fast.omega1)
    for name in ("epsilon1", "M_motor", "M_load", "J_red", "E_kin"):
        assert np.allclose(getattr(fast, name), eq[name], rtol=1e-9, atol=1e-8 * np.max(np.abs(eq[name])))
    assert abs(fast.summary()["energy_residual"]) < 1e-9


def _on_switch_angles(result, switch_angles):
    """Largest distance (rad) of the crank angle at each located slider switch from a switch angle."""
    times = [t for t, what in result.trajectory.events if "switch angle" in what]
    assert len(times) >= switch_angles.size
    phi = result.state(times)[0] % (2 * math.pi)
    return np.max(np.min(np.abs((phi[:, None] - switch_angles[None, :] + math.pi) % (2 * math.pi) - math.pi),
                         axis=1))


@pytest.mark.parametrize("name", ["seed001", "seed003"])
def test_slider_force_switches_are_located_and_the_answer_is_the_references(name):
    """Every integrator ends a step on each slider-force switch, and the fast path (rtol 1e-11, on
    tables) and the engine's reference (DOP853, rtol 1e-12) then agree to a few 1e-10 of the
    speed (measured 3e-10 and 4e-10); dopri5 (scipy RK45) at its default rtol 1e-11 within 1e-8."""
    fast = crankfmu.simulate(name, method="fast")
    switch_angles = fast.trajectory.table.switch_angles
    assert _on_switch_angles(fast, switch_angles) < 1e-11
    assert abs(fast.summary()["energy_residual"]) < 1e-9
    for method, bound in (("reference", 2e-9), ("dopri5", 1e-8)):
        engine = crankfmu.simulate(name, method=method)
        scale = np.max(np.abs(engine.omega1))
        assert np.max(np.abs(fast.omega1 - engine.omega1)) <= bound * scale, method
        assert _on_switch_angles(engine, switch_angles) < 1e-11, method
        assert abs(engine.summary()["energy_residual"]) < 1e-9, method


def test_a_motor_too_weak_to_start_leaves_the_crank_stuck_at_rest():
    scenario = crankfmu.load_scenario("seed003").with_params(A=100.0, A_low=100.0, omega1_start=0.0)
    for method in ("fast", "reference", "dopri5"):
        result = crankfmu.simulate(scenario, method=method, t_end=0.5)
        assert np.all(result.omega1 == 0.0) and np.all(result.phi1 == result.phi1[0]), method
        assert result.trajectory.modes == [(0.0, "stuck")], method
        assert np.all(result.epsilon1 == 0.0), method


def test_start_from_rest_and_reversal_with_slider_forces_agree_with_the_reference():
    # the motor line pushes the crank backwards past omega1 = 0: the slider forces change side
    scenario = crankfmu.load_scenario("seed003").with_params(A=-20000.0, A_low=-20000.0, omega1_start=2.0)
    fast = crankfmu.simulate(scenario, method="fast", t_end=1.0)
    ref = crankfmu.simulate(scenario, method="reference", t_end=1.0)
    assert fast.omega1[-1] < 0 < fast.omega1[0]
    # seed 003's motor kink is at omega1 = 0: the crossing is one event that turns the forces too
    for result in (fast, ref):
        t_zero = [t for t, what in result.trajectory.events if "omega1 = 0" in what or "kink" in what]
        assert len(t_zero) == 1
        assert [m for _, m in result.trajectory.modes][-1] != "stuck"
    # both locate the reversal and the switches: they agree to the tolerances (was 1e-6 while the
    # reference stepped across them)
    assert np.max(np.abs(fast.omega1 - ref.omega1)) < 1e-9 * np.max(np.abs(ref.omega1))


def test_the_kernel_library_is_the_one_compiled_from_these_sources(tmp_path, monkeypatch):
    """The loaded library says which sources it was compiled from; where the installed one does not
    match (a source checkout whose C files changed), the fallback compiles the same sources into
    the cache, and that library says the same hash and has the same layout."""
    from crankfmu import native

    native.LIBRARY.ck_source_digest.restype = native.ctypes.c_char_p
    assert native.LIBRARY.ck_source_digest().decode() == native.DIGEST
    monkeypatch.setenv("CRANKFMU_CACHE", str(tmp_path))
    compiled = native._open(native._compile_into_cache())
    assert compiled is not None and compiled.ck_source_digest().decode() == native.DIGEST
    assert str(tmp_path) in compiled._name


def test_fast_rejects_a_bad_rtol():
    with pytest.raises(ParameterError, match="rtol must be > 0"):
        FastIntegrator(-1.0)


def test_steady_cycles_agree_with_a_long_time_domain_run():
    batch = steady_cycles("seed000", [{}, {"J_flywheel": 5.0}])
    assert not batch.failed
    for design, row in zip([{}, {"J_flywheel": 5.0}], batch.rows):
        scenario = crankfmu.load_scenario("seed000").with_params(**design)
        run = crankfmu.simulate(scenario, method="fast", t_end=12.0)
        k = int(12.0 / row["period"]) - 1
        stats = run.cycle_stats(k)
        assert row["omega1_mean"] == pytest.approx(stats["omega1_mean"], rel=1e-8)
        # the batch integrates at rtol 1e-9 (about 5e-7 rad/s on a start-up transient, less on a
        # settled cycle; measured 8e-8) and locates the extremes where the slope changes sign
        assert row["omega1_min"] == pytest.approx(stats["omega1_min"], abs=5e-7)
        assert row["omega1_max"] == pytest.approx(stats["omega1_max"], abs=5e-7)
        assert row["delta"] == pytest.approx(stats["delta"], rel=1e-6)
    assert batch.rows[1]["delta"] < batch.rows[0]["delta"]      # the flywheel evens the speed


def test_steady_cycles_list_failed_designs_with_their_reason():
    designs = [{"J_flywheel": -1.0}, {"A": 10.0, "A_low": 10.0, "B_low": 0.2}, {"l1": 0.6}, {"B": 25.0}]
    batch = steady_cycles("seed000", designs)
    assert len(batch.rows) == 1 and batch.rows[0]["B"] == 25.0
    assert len(batch.failed) == 3
    text = " | ".join(f["reason"] for f in batch.failed)
    assert "J_flywheel" in text and "stalls" in text and "l1" in text


def test_a_batch_of_geometries_reads_the_mechanism_file_once(monkeypatch):
    """Every design of a sweep is a with_params copy of one scenario: they share the mechanism's
    definition, read once (the file is not read and looked up again per design); a copy pickled
    for a Dask worker reads it again there and gives the same steady cycle."""
    import pickle

    from crankfmu import scenario as scenario_module

    reads = []
    load = scenario_module.load_mechanism
    monkeypatch.setattr(scenario_module, "load_mechanism", lambda source: (reads.append(source), load(source))[1])
    designs = [{"l1": l1} for l1 in (0.19, 0.2, 0.21)]
    batch = steady_cycles("seed000", designs)
    assert len(batch.rows) == 3 and len(reads) == 1
    base = load_scenario("seed000")
    base.mechanism_definition()
    copy = pickle.loads(pickle.dumps(base.with_params(l1=0.21)))
    assert copy.mechanism_definition() is not None and len(reads) == 3      # base's read, then the copy's
    again = steady_cycles(copy, [{}])
    assert again.rows[0]["delta"] == batch.rows[2]["delta"]


def test_a_steady_batch_keeps_its_tables_only_when_asked():
    """SteadyBatch keeps each geometry's table for the next call (a root search over J_flywheel
    asks again and again); steady_cycles, one call over many geometries, drops each once its
    designs ran (a sweep chunk would hold hundreds of tables). Both give the same cycles."""
    from crankfmu.studies.batch import SteadyBatch

    designs = [{"l1": 0.19}, {"l1": 0.21}, {"l1": 0.21, "J_flywheel": 5.0}]
    kept, dropped = SteadyBatch("seed000"), SteadyBatch("seed000", keep=False)
    first, once = kept.run(designs), dropped.run(designs)
    assert [r["delta"] for r in first.rows] == [r["delta"] for r in once.rows]
    assert len(kept._models) == 2 and not dropped._models
    assert kept.run(designs[1:]).rows == first.rows[1:]


def test_sweep_on_a_local_dask_cluster_writes_rows_lists_failures_and_resumes(tmp_path):
    out = tmp_path / "sweep"
    args = [sys.executable, "-m", "crankfmu", "sweep", "seed000", "--param", "J_flywheel=-1:3:3",
            "--param", "B=15:25:2", "--out", str(out), "--chunk", "2"]
    first = subprocess.run(args, capture_output=True, text=True)
    assert first.returncode == 0, first.stderr
    assert "6 designs: 4 computed, 2 failed" in first.stdout
    assert "FAILED J_flywheel = -1" in first.stdout
    lines = (out / "steady.csv").read_text().splitlines()
    assert lines[0].startswith("J_flywheel,B,omega1_mean") and len(lines) == 5
    assert len((out / "failed.csv").read_text().splitlines()) == 3
    assert (out / "delta.png").stat().st_size > 0
    again = subprocess.run(args + ["--scheduler", "serial"], capture_output=True, text=True)
    assert again.returncode == 0, again.stderr
    assert "(4 already in steady.csv)" in again.stdout
    assert len((out / "steady.csv").read_text().splitlines()) == 5


def _malloc_settings(first, second, chunk):
    """A chunk's work on a sweep worker: the glibc malloc settings its environment gives."""
    import os

    return [os.environ.get(name) for name in ("MALLOC_TRIM_THRESHOLD_", "MALLOC_MMAP_THRESHOLD_")]


def test_the_local_sweep_cluster_keeps_glibcs_own_malloc_thresholds(monkeypatch):
    # Dask's default MALLOC_TRIM_THRESHOLD_ pins the mmap threshold at 128 kB, so every design's
    # table (0.5 MB) was mapped and unmapped again: 128 page faults a design
    from crankfmu.studies.sweep import run_chunks

    for name in ("MALLOC_TRIM_THRESHOLD_", "MALLOC_MMAP_THRESHOLD_"):
        monkeypatch.delenv(name, raising=False)
    outcomes = list(run_chunks(_malloc_settings, [[0], [1]], (None, None), scheduler="local"))
    assert [settings for _, settings in outcomes] == [[None, None], [None, None]]


def test_sweep_names_an_unreachable_scheduler(tmp_path):
    done = subprocess.run([sys.executable, "-m", "crankfmu", "sweep", "seed000", "--param", "B=15:25:2",
                           "--out", str(tmp_path), "--scheduler", "tcp://127.0.0.1:9"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode != 0
    assert "--scheduler tcp://127.0.0.1:9" in done.stderr


def test_kernel_state_is_one_array_and_a_restored_step_repeats_bit_for_bit():
    from crankfmu.integrators.fast import FastStepper

    model = crankfmu.load_scenario("seed000").build()
    stepper = FastStepper(table_of(model.reduced), model.motor, model.reduced.J_flywheel, 1e-10)
    stepper.start(0.0, model.y0)
    stepper.advance(0.5, 0.5)
    saved = stepper.state.copy()
    first = stepper.advance(0.6, 0.6).copy()
    stepper.state[:] = saved
    again = stepper.advance(0.6, 0.6).copy()
    assert np.array_equal(first, again)
    assert stepper.state.size == layout.STATE_SIZE


def test_a_step_clipped_to_the_limit_ends_on_it_exactly():
    """A step clipped to t_limit ends at t_limit itself: t + (t_limit - t) misses t_limit by an
    ulp when t is much smaller than t_limit, and the ulp left was a step-size underflow (found on
    the pumping well's first string step, 1/600 s). Every limit of a fine grid is reached from a
    fresh start, exactly."""
    from crankfmu.integrators.fast import FastStepper

    model = crankfmu.load_scenario("seed000").build()
    stepper = FastStepper(table_of(model.reduced), model.motor, model.reduced.J_flywheel, 1e-10)
    for k in range(1, 400):
        t_limit = k / 6e4
        stepper.start(0.0, model.y0)
        stepper.advance(t_limit, t_limit)     # raised SchemeError (underflow) before the fix
        assert stepper.state[layout.T] == t_limit


@pytest.mark.parametrize("field, value", [("STEP_INTERVAL", 7.0), ("STEP_MOTOR", 9.0), ("STEP_DIRECTION", 0.5)])
def test_a_state_whose_last_step_holds_no_mode_the_kernel_wrote_is_refused(field, value):
    """The output row inside the last step reads the step's mode (its switch interval indexes the
    slider forces): a state whose step fields no kernel wrote (a damaged serialized FMU state) is
    refused for its output row and for a step, never indexed beyond the tables. The same state
    untouched gives the trajectory's row."""
    from crankfmu.errors import CrankfmuError, SchemeError
    from crankfmu.integrators.fast import FastStepper

    model = crankfmu.load_scenario("seed001").build()
    stepper = FastStepper(table_of(model.reduced), model.motor, model.reduced.J_flywheel, 1e-10)
    stepper.start(0.0, model.y0)
    stepper.advance(0.5, 1.0)                      # the last step ends beyond 0.5 s
    inside = 0.5 * (stepper.state[layout.T_PREV] + stepper.state[layout.T])
    assert np.all(np.isfinite(stepper.refresh(inside)))
    stepper.state[layout._LAYOUT[field]] = value
    with pytest.raises(CrankfmuError, match="state is corrupted"):
        stepper.refresh(inside)
    with pytest.raises(SchemeError, match="no mode it can have written"):
        stepper.advance(0.6, 1.0)
