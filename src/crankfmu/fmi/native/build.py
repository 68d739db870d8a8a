"""``crankfmu fmu SCENARIO --native``: a native FMI 2.0 (or 3.0) FMU that needs nothing on the host
machine, no Python and no numpy, and whose build compiles nothing.

The FMU's binary is a runtime compiled when crankfmu was installed (native/sources.py: the C kernel,
the C mechanism model and the model behind one FMI shell, one binary per FMI version and platform),
and the scenario is data: the model file in ``resources/`` (fmi.native.model, fmi.native.model_file), which
the runtime reads and checks when a host makes an instance. The FMU builds its tables when
initialisation ends, at the values the host set; the build checks that the file's values give
them. It carries every platform the installation has a runtime for (FMI 2.0: linux64, win64; FMI
3.0: x86_64-linux, x86_64-windows, aarch64-linux), each linking libgcc statically and nothing
beyond the C library; a runtime the installation lacks (an editable installation whose sources
changed) is compiled into the per-user cache where its compiler is installed. The FMU carries the
runtime's C sources (``sources/``, with the modelDescription's SourceFiles, a
``buildDescription.xml`` and a ``CMakeLists.txt``) so that ``fmpy compile`` or CMake on another
platform builds the same runtime, which reads the same model file.

The native component FMUs (fmi.native.components) are the same runtime with a component's model file.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
import zipfile
from contextlib import ExitStack
from pathlib import Path

from ...atomic import replacing
from ...errors import CrankfmuError
from ..archive import add_bytes, add_file
from ...native.sources import FMU_COMPILERS, PLATFORMS, RUNTIMES, compile_runtime, runtime, runtime_files, runtime_name
from ..background import reference_beside
from ..reference import LS_REF, LS_REF_MANIFEST, cross_check_options
from ..source import NATIVE_USER_FILES, preflight
from ..stages import stage
from .model_file import NAME as MODEL_FILE
from .model import NativeModel

FMI_VERSIONS = tuple(PLATFORMS)


def build_description(identifier: str, sources: list[str]) -> str:
    files = "\n".join(f'      <SourceFile name="{name}"/>' for name in sources if name.endswith(".c"))
    return (f'<?xml version="1.0" encoding="UTF-8"?>\n<fmiBuildDescription fmiVersion="3.0">\n'
            f'  <BuildConfiguration modelIdentifier="{identifier}">\n'
            f'    <SourceFileSet language="C99">\n{files}\n'
            f'      <PreprocessorDefinition name="CK_API" value=""/>\n'
            f'    </SourceFileSet>\n  </BuildConfiguration>\n</fmiBuildDescription>\n')


def cmake_lists(identifier: str) -> str:
    """sources/CMakeLists.txt: the FMU's binary from its sources alone, as the runtimes are built
    (C99, no FMA contraction, only the FMI functions exported), on any platform CMake knows: cmake
    -S sources -B build && cmake --build build."""
    return f"""# builds {identifier}'s binary from these sources alone: cmake -S sources -B build && cmake --build build
cmake_minimum_required(VERSION 3.10)
project({identifier} C)
file(GLOB SOURCES "${{CMAKE_CURRENT_SOURCE_DIR}}/*.c")
add_library({identifier} SHARED ${{SOURCES}})
set_target_properties({identifier} PROPERTIES PREFIX "" C_STANDARD 99 C_VISIBILITY_PRESET hidden)
target_compile_definitions({identifier} PRIVATE CK_API=)
target_include_directories({identifier} PRIVATE "${{CMAKE_CURRENT_SOURCE_DIR}}")
if(CMAKE_C_COMPILER_ID MATCHES "GNU|Clang")
  # the same numbers on every CPU: no fused multiply-add
  target_compile_options({identifier} PRIVATE -ffp-contract=off)
endif()
if(UNIX)
  target_link_libraries({identifier} m)
endif()
"""


def _run(cmd: list, compiler: str) -> str:
    """A compiler's run (a runtime the installation lacks, compiled into the per-user cache)."""
    try:
        done = subprocess.run(cmd, capture_output=True, text=True)
    except FileNotFoundError:
        raise CrankfmuError(f"{compiler} not found; it compiles the native FMUs' runtime") from None
    if done.returncode != 0:
        raise CrankfmuError(f"compiling the native FMUs' runtime with {compiler} failed: {done.stderr.strip()}")
    return done.stdout


def package_native(source, dest: Path, describe, parameters: dict, reference, extra: dict, about: dict,
                   written: ExitStack, fmi_version: str, runtimes: dict) -> Path:
    """Write a native FMU (a mechanism's or a component's) into ``dest``: the ``runtimes`` (platform
    folder -> the prebuilt binary: native_runtimes) with the runtime's sources (``sources/``, the
    FMI headers, a buildDescription.xml and a CMakeLists.txt); the modelDescription
    ``describe(sources)`` gives; the documentation (its ``about``: the tables' error bound); the
    ``extra`` files (path in the FMU -> text or bytes: the model file among them). ``reference``:
    the reference CSV, or a function that waits for it (the documentation calls it once its
    drawings, made while the run goes on, are done; else it is called before the FMU is written).
    Before it is written the FMU starts in a host, from a folder of what it needs, beside the
    documentation. The FMU replaces ``dest/<identifier>.fmu`` when ``written`` closes without an
    error."""
    fmu = source.fmu
    dest.mkdir(parents=True, exist_ok=True)
    out = dest / f"{fmu}.fmu"
    files = runtime_files(fmi_version)
    sources = sorted([path.name for path in files] + ["CMakeLists.txt"])
    with tempfile.TemporaryDirectory() as tmp:
        with stage(fmu, "the modelDescription"):
            md = describe(sources)
        check = None
        host = [folder for folder in runtimes if folder in HOST_PLATFORMS]
        if host:
            unzipped = Path(tmp) / "unzipped"
            (unzipped / "binaries" / host[0]).mkdir(parents=True)
            (unzipped / "modelDescription.xml").write_bytes(md)
            binary = runtimes[host[0]]
            shutil.copy2(binary, unzipped / "binaries" / host[0] / f"{fmu}{binary.suffix}")
            for path, content in extra.items():
                if path.startswith("resources/"):
                    (unzipped / path).parent.mkdir(parents=True, exist_ok=True)
                    (unzipped / path).write_bytes(content if isinstance(content, bytes) else content.encode())
            check = initialising(unzipped, fmu)
        with stage(fmu, "the documentation"):
            # a mechanism's documentation draws it before it waits for the reference run to plot
            docs = source.documentation(fmu, md, parameters, reference, build="native", platforms=list(runtimes),
                                        **about)
        if callable(reference):             # a documentation without the plot: the run's CSV all the same
            reference()
        partial = written.enter_context(replacing(out))
        with stage(fmu, "writing the FMU"), zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
            add_bytes(z, "modelDescription.xml", md)
            for folder, binary in runtimes.items():
                add_file(z, binary, f"binaries/{folder}/{fmu}{binary.suffix}")
            for path in files:
                add_file(z, path, f"sources/{path.name}")
            add_bytes(z, "sources/CMakeLists.txt", cmake_lists(fmu))
            add_bytes(z, "sources/buildDescription.xml", build_description(fmu, sources))
            for path, content in {**docs, **extra}.items():
                add_bytes(z, path, content)
        if check is not None:
            with stage(fmu, "initialising the FMU at its start values"):
                check()
    return out


#: the binaries this machine runs itself: the build initialises the FMU once through one of them
HOST_PLATFORMS = ("linux64", "x86_64-linux")


def initialises(path: Path, fmu: str) -> None:
    """Instantiate the FMU at ``path``, initialise it at its start values and step one output
    interval, in a fresh process (fmpy, as a host does): a build reports success only for an FMU
    that starts, and a crash cannot take the build with it. CrankfmuError with the FMU's own
    message otherwise (the FMU is then not written)."""
    initialising(path, fmu)()


def initialising(path: Path, fmu: str):
    """initialises' check started (``path``: the FMU, or a folder of it unpacked): returns the
    function that waits for it and raises where it failed."""
    import sys

    script = ("import sys, fmpy\n"
              "md = fmpy.read_model_description(sys.argv[1])\n"
              "e = md.defaultExperiment\n"
              "start = float(e.startTime or 0.0) if e else 0.0\n"
              "step = float(e.stepSize or 1e-3) if e else 1e-3\n"
              "fmpy.simulate_fmu(sys.argv[1], start_time=start, stop_time=start + step, output_interval=step)\n")
    process = subprocess.Popen([sys.executable, "-c", script, str(path)], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)

    def wait() -> None:
        try:
            out, err = process.communicate(timeout=300)
        finally:
            if process.poll() is None:
                process.kill()
        if process.returncode != 0:
            said = [line for line in (out + err).splitlines() if line.strip()]
            raise CrankfmuError(f"{fmu}: the FMU built does not initialise at its start values: "
                                + (said[-1] if said else f"the host process exited with {process.returncode}"))
    return wait


def native_runtimes(fmi_version: str, win64: bool | None) -> dict:
    """{platform folder: runtime} for a native FMU: each platform of ``fmi_version`` whose
    runtime the installation has (native/runtimes) or the per-user cache has, else compiled into
    the cache where its compiler is installed. Linux x86_64 always (refused, saying why, where it
    can be had neither way); Windows unless ``win64`` is False (and required where it is True)."""
    from ...cache import cache_root

    roots = [RUNTIMES, cache_root() / "runtimes"]
    found = {}
    for folder, cc in PLATFORMS[fmi_version]:
        windows = FMU_COMPILERS[cc]
        if windows and win64 is False:
            continue
        path = runtime(fmi_version, folder, cc, roots)
        if path is None and shutil.which(cc):
            path = compile_runtime(fmi_version, cc, roots[1] / f"fmi{fmi_version[0]}" / folder /
                                   runtime_name(fmi_version, cc, windows),
                                   run=lambda command, cc=cc: _run(command, cc))
        if path is not None:
            found[folder] = path
        elif cc == "gcc" or (windows and win64):
            raise CrankfmuError(f"no {folder} runtime of FMI {fmi_version} in this installation for its sources "
                                f"(reinstall crankfmu), and {cc} is not installed to compile one")
    return found


def build_native(data_name: str, dest: Path, name: str | None = None, win64: bool | None = None,
                 causality: str | None = None, values: dict | None = None, fmi_version: str = "2.0") -> Path:
    """The native FMU of a scenario (a packaged name or a user's file) in ``dest``. ``win64``: also
    the Windows binary (default: where x86_64-w64-mingw32-gcc is installed). ``causality``:
    "torque" or "speed" (default: the file's [crank] causality), as for the Python FMU. ``values``:
    parameters to build it for other than the file's (``crankfmu fmu --native --set``).
    ``fmi_version``: "2.0" or "3.0" (the same model behind the other shell: fmi3)."""
    if fmi_version not in FMI_VERSIONS:
        raise CrankfmuError(f"--fmi-version must be one of {', '.join(v.removesuffix('.0') for v in FMI_VERSIONS)}, "
                            f"got {fmi_version!r}")
    source = preflight("scenario", data_name, name, causality, values)
    # the reference run from now until the FMU is written, beside the tables and the drawing
    with reference_beside(source.reference) as reference_text:
        return _build_native(source, data_name, dest, win64, fmi_version, reference_text)


def _build_native(source, data_name, dest: Path, win64, fmi_version: str, reference_text) -> Path:
    fmu = source.fmu
    with stage(fmu, "compiling the model and checking its tables"):
        model = NativeModel(source, data_name, source.causality)
    computed = {}

    def reference():                # the background run's text (the documentation waits for it)
        with stage(fmu, "the reference run of the default experiment"):
            computed["csv"] = reference_text()
        extra[f"{LS_REF}/{fmu}_out.csv"] = computed["csv"]
        return computed["csv"]
    extra = {**{f"{NATIVE_USER_FILES}/{path}": text for path, text in source.files.items()},   # a user's files
             f"{LS_REF}/fmi-ls-manifest.xml": LS_REF_MANIFEST.format(name=fmu)}
    describe = model.model_description
    if fmi_version == "3.0":
        from . import fmi3
        from ..documentation import mechanism_png

        describe = lambda sources: fmi3.model_description(model, sources)  # noqa: E731
        with stage(fmu, "the terminals and icon"):
            extra["terminalsAndIcons/terminalsAndIcons.xml"] = fmi3.terminals_and_icons(model)
            extra["terminalsAndIcons/icon.png"] = mechanism_png(model.scenario)
    with stage(fmu, "the runtimes"):
        runtimes = native_runtimes(fmi_version, win64)
    extra[f"resources/{MODEL_FILE}"] = model.model_file()
    with ExitStack() as written:
        out = package_native(source, dest, describe, model.parameters(), reference, extra,
                             {"table_error": max(e for e, _ in model.table_errors.values())}, written, fmi_version,
                             runtimes)
        Path(written.enter_context(replacing(dest / f"{fmu}_ref.csv"))).write_text(computed["csv"], encoding="utf-8")
        Path(written.enter_context(replacing(dest / f"{fmu}_ref.opt"))).write_text(cross_check_options(source),
                                                                                   encoding="utf-8")
    return out
