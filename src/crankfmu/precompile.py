"""Compile the fast path's kernel ahead of time: ``crankfmu precompile``.

numba compiles the kernel on its first call (about 20 s on a 2-core machine) and caches the machine
code on disk. A user's first run on a fresh machine, and an FMU's first instantiation in a host
with an empty cache, would wait for it. This step runs every kernel entry point once, in a child
process with an empty cache (so nothing compiled earlier, for another CPU or kernel, is taken along),
for a generic x86-64 CPU (``compiled.py``), and keeps the result in the package
(``integrators/kernel/precompiled/kernel_<digest>.zip``). The kernel loader seeds a user's cache from
there; the FMU build ships it in every FMU (it runs this step when the kernel has changed).

The entry points and their argument types: ``run_chunk`` and ``dense_many`` (``simulate(...,
method="fast")``, with and without slider forces and a user's direction-switched load), ``begin``
and ``advance`` (the FMU's stepper, and a restart within a step), ``steady_batch`` and the
functions it calls (sweeps and flywheel studies). ``tests/test_precompile.py`` runs them again in a
fresh cache seeded from the package and checks that numba compiled nothing.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

from .errors import CrankfmuError


def kernel_dispatchers() -> dict:
    """name -> numba dispatcher of every compiled function of the kernel (empty without numba)."""
    from .integrators.kernel import COMPILED, drivers, method

    if not COMPILED:
        return {}
    found = {}
    for module in (method, drivers):          # drivers' namespace also holds method's functions
        for name, value in vars(module).items():
            if hasattr(value, "stats") and hasattr(value, "py_func") and value not in found.values():
                found[f"{module.__name__.split('_')[2]}.{name}"] = value
    return found


def digests() -> list[str]:
    """The content hashes of the kernel this package loads (its cache folders' names)."""
    from .integrators.kernel import drivers, method

    return [module.kernel_digest.decode() for module in (method, drivers)]


def run_entry_points():
    """Call every kernel entry point with the argument types the package passes it."""
    import numpy as np

    from .dynamics.tabulated import table_of
    from .integrators.fast import TABLE_TOLERANCE, FastIntegrator, FastStepper
    from .scenario import load_scenario
    from .simulation import simulate
    from .studies.batch import steady_cycles

    for name in ("seed000", "seed001", "pumpjack"):   # none, slider forces, a user's switched load
        scenario = load_scenario(name)
        t_end = min(scenario.experiment.stop_time, 0.2)
        simulate(scenario, method="fast", t_end=t_end, output_times=np.linspace(0.0, t_end, 5))
        model = scenario.build()
        FastIntegrator().run(model.equation, 0.0, model.y0, 0.05).dense([0.01, 0.02])
        stepper = FastStepper(table_of(model.reduced, TABLE_TOLERANCE), model.equation.motor,
                              model.reduced.J_flywheel, 1e-8, model.equation.tau_ext)
        stepper.start(0.0, model.y0)
        stepper.advance(0.01, 0.01)
        stepper.restart(0.005)
        stepper.advance(0.02, 0.02)
    steady_cycles(load_scenario("seed000"), [{"J_flywheel": 10.0}])


def precompile(quiet: bool = False) -> Path:
    """Compile the kernel in a child process with an empty cache and put one archive per kernel
    module into the package's ``precompiled`` folder, replacing what was there."""
    from .integrators.kernel import COMPILED, MACHINE_CODE, PRECOMPILED, STAMPS

    if not COMPILED:
        raise CrankfmuError("precompile: numba is not importable here (or CRANKFMU_JIT=0): nothing to compile")
    if not quiet:
        print("precompile: compiling the fast path's kernel ahead of time (about 30 s, once per kernel)", flush=True)
    started = time.perf_counter()
    # the old archives go first: the child would otherwise seed its empty cache from them
    shutil.rmtree(PRECOMPILED, ignore_errors=True)
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, CRANKFMU_CACHE=str(Path(tmp) / "cache"), NUMBA_CPU_NAME="generic")
        env.pop("NUMBA_CPU_FEATURES", None)
        done = subprocess.run([sys.executable, "-c", "from crankfmu.precompile import run_entry_points; run_entry_points()"],
                              env=env, capture_output=True, text=True)
        if done.returncode != 0:
            raise CrankfmuError(f"precompile: compiling the kernel failed:\n{done.stderr[-4000:]}")
        partial = PRECOMPILED.with_name(f"{PRECOMPILED.name}.{os.getpid()}")
        shutil.rmtree(partial, ignore_errors=True)
        partial.mkdir(parents=True)
        for digest in digests():
            compiled = Path(tmp) / "cache" / f"kernel_{digest}"
            with zipfile.ZipFile(partial / f"kernel_{digest}.zip", "w", zipfile.ZIP_DEFLATED) as archive:
                for source in sorted(compiled.glob("*.py")):
                    archive.write(source, source.name)
                for machine_code in sorted((compiled / "__pycache__").glob("*.nb[ic]")):
                    archive.write(machine_code, f"{MACHINE_CODE}/{machine_code.name}")
                archive.writestr(STAMPS, json.dumps({f.name: f.stat().st_mtime_ns for f in compiled.glob("*.py")}))
        os.replace(partial, PRECOMPILED)
    if not quiet:
        print(f"precompile: kernel {', '.join(digests())} compiled in {time.perf_counter() - started:.0f} s "
              f"into {PRECOMPILED}")
    return PRECOMPILED


def is_current() -> bool:
    """Whether the package holds the compiled kernel of this package."""
    from .integrators.kernel import PRECOMPILED

    return all((PRECOMPILED / f"kernel_{d}.zip").is_file() for d in digests())


def ensure(quiet: bool = False) -> bool:
    """Precompile unless the package already holds this kernel; False where numba is absent or the
    package's folder cannot be written (the kernel then compiles on first use)."""
    from .integrators.kernel import COMPILED

    if not COMPILED:
        return False
    if is_current():
        return True
    try:
        precompile(quiet=quiet)
    except OSError as exc:
        print(f"precompile: cannot write the precompiled kernel ({exc}); it will compile on first use",
              file=sys.stderr)
        return False
    return True

