"""``crankfmu fmu SCENARIO --native``: a native FMI 2.0 (or 3.0) FMU that needs nothing on the host
machine, no Python and no numpy, and whose build compiles nothing.

The FMU's binary is a runtime compiled when crankfmu was installed (native/sources.py: the C kernel,
the C mechanism model and the model behind one FMI shell, one binary per FMI version and platform),
and the scenario is data: the model file in ``resources/`` (fmi.native_model, fmi.model_file), which
the runtime reads and checks when a host makes an instance. The FMU builds its tables when
initialisation ends, at the values the host set; the build checks that the file's values give
them. It carries every platform the installation has a runtime for (FMI 2.0: linux64, win64; FMI
3.0: x86_64-linux, x86_64-windows, aarch64-linux), each linking libgcc statically and nothing
beyond the C library; a runtime the installation lacks (an editable installation whose sources
changed) is compiled into the per-user cache where its compiler is installed. The FMU carries the
runtime's C sources (``sources/``, with the modelDescription's SourceFiles, a
``buildDescription.xml`` and a ``CMakeLists.txt``) so that ``fmpy compile`` or CMake on another
platform builds the same runtime, which reads the same model file.

The native component FMUs (fmi.native_components) are still compiled, from their generated data.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
import zipfile
from concurrent.futures import ThreadPoolExecutor
from contextlib import ExitStack
from pathlib import Path

from ..atomic import replacing
from ..errors import CrankfmuError
from ..native.sources import (FMI_HEADERS, FMU_COMPILERS, PLATFORMS, PREBUILT, RUNTIMES, WIN64_CC, compile_object,
                               compile_runtime, fmu_flags, includes, object_name, runtime, runtime_files,
                               runtime_name)
from .background import reference_beside
from .reference import LS_REF, LS_REF_MANIFEST, cross_check_options
from .source import NATIVE_USER_FILES, preflight
from .stages import stage
from .model_file import NAME as MODEL_FILE
from .native_model import NativeModel

FMI_VERSIONS = tuple(PLATFORMS)


def build_description(identifier: str, sources: list[str]) -> str:
    files = "\n".join(f'      <SourceFile name="{name}"/>' for name in sources if name.endswith(".c"))
    return (f'<?xml version="1.0" encoding="UTF-8"?>\n<fmiBuildDescription fmiVersion="3.0">\n'
            f'  <BuildConfiguration modelIdentifier="{identifier}">\n'
            f'    <SourceFileSet language="C99">\n{files}\n'
            f'      <PreprocessorDefinition name="CK_API" value=""/>\n'
            f'    </SourceFileSet>\n  </BuildConfiguration>\n</fmiBuildDescription>\n')


def cmake_lists(identifier: str) -> str:
    """sources/CMakeLists.txt: the FMU's binary from its sources alone, as the runtimes and
    compile_binary are built (C99, no FMA contraction, only the FMI functions exported), on any
    platform CMake knows: cmake -S sources -B build && cmake --build build."""
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


#: the compilers run at a lower priority: a build's longest single task is the reference run, one
#: process from the build's start to its end (fmi.background); the compilers' work can be spread
#: over what the cores have left, and where they are busy (two cores: the reference run, two
#: compilers and the documentation) the build then ends when the reference run does
_YIELDING = ["nice", "-n", "10"] if shutil.which("nice") else []


def _run(cmd: list, compiler: str) -> str:
    try:
        if _YIELDING and shutil.which(cmd[0]) is None:      # nice would say it, in its words
            raise FileNotFoundError(cmd[0])
        done = subprocess.run([*_YIELDING, *cmd], capture_output=True, text=True)
    except FileNotFoundError:
        raise CrankfmuError(f"{compiler} not found; it compiles the native FMU's binary") from None
    if done.returncode != 0:
        raise CrankfmuError(f"compiling the native FMU with {compiler} failed: {done.stderr.strip()}")
    return done.stdout


def _cached_object(compiler: str, flags: list, source: Path, generated) -> Path | None:
    """The object of ``source``: the one installed with the package (sources.PREBUILT), else the
    per-user cache's (compiled into it the first time), where nothing it includes is generated per
    FMU (the kernel and the mechanism model are the same for every scenario: only their compiler,
    flags and content name the object); None otherwise."""
    from ..cache import cache_root

    made = [source, *includes(source, [Path(f[2:]) for f in flags if f.startswith("-I")])]
    if any(Path(dep).name in generated for dep in made):
        return None
    name = object_name(compiler, flags, made)
    if (PREBUILT / name).is_file():
        return PREBUILT / name
    obj = cache_root() / "objects" / name
    if not obj.is_file():
        obj.parent.mkdir(parents=True, exist_ok=True)
        compile_object(compiler, flags, source, obj, run=lambda command: _run(command, compiler))
    return obj


def compile_binary(compiler: str, folder: Path, out: Path, windows: bool, generated=()):
    """The FMU's binary from the sources in ``folder``: C99, libgcc linked statically, nothing beyond
    the C library (and libm on Linux); the FMI headers come with fmpy. The sources that include
    nothing ``generated`` (the kernel, the mechanism model) come compiled: installed with the
    package, else from the per-user cache."""
    import fmpy

    headers = Path(fmpy.__file__).parent / "c-code"
    flags = fmu_flags(windows) + [f"-I{folder}", f"-I{headers}"]
    inputs = []
    for source in sorted(folder.glob("*.c")):
        try:
            cached = None if source.name in generated else _cached_object(compiler, flags, source, generated)
        except OSError:                # a cache that cannot be written: compile it here
            cached = None
        inputs.append(str(cached or source))
    cmd = [compiler, *flags, "-shared", "-static-libgcc", "-o", str(out), *inputs]
    _run(cmd + ([] if windows else ["-lm"]), compiler)


def package_native(source, dest: Path, copied, generated: dict, describe, parameters: dict, win64: bool | None,
                   reference: str | None, extra: dict, about: dict, written: ExitStack,
                   fmi_version: str = "2.0", runtimes: dict | None = None) -> Path:
    """Compile and write a native FMU (a mechanism's or a component's) into ``dest``: the sources
    ``copied`` ((folder, names) pairs) and ``generated`` (name -> text) compiled for each platform
    of ``fmi_version`` (PLATFORMS: Linux x86_64 always; Windows where MinGW-w64 is installed
    (``win64`` None) or asked for; FMI 3.0's aarch64 Linux where its cross compiler is installed);
    the modelDescription ``describe(sources)`` gives; the documentation (its ``about``: the tables'
    error bound); the ``extra`` files (path in the FMU -> text or bytes). ``reference``: the
    reference CSV, or a function that waits for it (the documentation calls it once its drawings,
    made while the run goes on, are done; else it is called before the FMU is written). ``runtimes``:
    the binaries, prebuilt (platform folder -> path), instead of compiling ``copied`` and
    ``generated``. The FMU replaces ``dest/<identifier>.fmu`` when ``written`` closes without an
    error."""
    fmu = source.fmu
    if win64 is None:
        win64 = shutil.which(WIN64_CC) is not None
    platforms = [] if runtimes is not None else [
        (folder, cc, FMU_COMPILERS[cc]) for folder, cc in PLATFORMS[fmi_version]
        if cc == "gcc" or (win64 if FMU_COMPILERS[cc] else shutil.which(cc) is not None)]
    dest.mkdir(parents=True, exist_ok=True)
    out = dest / f"{fmu}.fmu"
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "sources"
        src.mkdir()
        for folder, names in copied:
            for n in names:
                shutil.copy2(folder / n, src / n)
        for n, text in generated.items():
            (src / n).write_text(text, encoding="utf-8")
        import fmpy

        for n in FMI_HEADERS[fmi_version]:
            shutil.copy2(Path(fmpy.__file__).parent / "c-code" / n, src / n)
        (src / "CMakeLists.txt").write_text(cmake_lists(fmu), encoding="utf-8")
        sources = sorted(p.name for p in src.iterdir())
        binaries = dict(runtimes or {})
        # every platform's compiler at once, the reference run beside them; this process writes
        # the modelDescription and draws the documentation meanwhile (the compilers are other
        # processes: waiting for them first left its core to them alone)
        with ThreadPoolExecutor(max_workers=max(len(platforms), 1)) as pool:
            compiling = []
            for folder, cc, windows in platforms:
                binaries[folder] = Path(tmp) / folder / f"{fmu}{'.dll' if windows else '.so'}"
                binaries[folder].parent.mkdir()
                compiling.append((folder, pool.submit(compile_binary, cc, src, binaries[folder], windows, generated)))
            with stage(fmu, "the modelDescription"):
                md = describe(sources)
            # prebuilt binaries: the FMU starts in a host (its model file read and its tables built)
            # beside the documentation, from a folder of what it needs, instead of after the zip
            check = None
            host = [folder for folder in binaries if folder in HOST_PLATFORMS] if runtimes is not None else []
            if host:
                unzipped = Path(tmp) / "unzipped"
                (unzipped / "binaries" / host[0]).mkdir(parents=True)
                (unzipped / "modelDescription.xml").write_bytes(md)
                shutil.copy2(binaries[host[0]], unzipped / "binaries" / host[0] / f"{fmu}{binaries[host[0]].suffix}")
                for path, content in extra.items():
                    if path.startswith("resources/"):
                        (unzipped / path).parent.mkdir(parents=True, exist_ok=True)
                        (unzipped / path).write_bytes(content if isinstance(content, bytes) else content.encode())
                check = initialising(unzipped, fmu)
            with stage(fmu, "the documentation"):
                # a mechanism's documentation draws it before it waits for the reference run to plot
                docs = source.documentation(fmu, md, parameters, reference, build="native",
                                            platforms=list(binaries), **about)
            for folder, job in compiling:
                with stage(fmu, f"compiling the {folder} binary"):
                    job.result()
        if callable(reference):             # a documentation without the plot: the run's CSV all the same
            reference()
        partial = written.enter_context(replacing(out))
        with stage(fmu, "writing the FMU"), zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("modelDescription.xml", md)
            for folder, binary in binaries.items():
                z.write(binary, f"binaries/{folder}/{fmu}{binary.suffix}")
            for n in sources:
                z.write(src / n, f"sources/{n}")
            z.writestr("sources/buildDescription.xml", build_description(fmu, sources))
            for path, content in {**docs, **extra}.items():
                z.writestr(path, content)
        if check is not None or any(folder in HOST_PLATFORMS for folder in binaries):
            with stage(fmu, "initialising the FMU at its start values"):
                (check or initialising(partial, fmu))()
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


def mechanism_runtimes(fmi_version: str, win64: bool | None) -> dict:
    """{platform folder: runtime} for a native mechanism FMU: each platform of ``fmi_version`` whose
    runtime the installation has (native/runtimes) or the per-user cache has, else compiled into
    the cache where its compiler is installed. Linux x86_64 always (refused, saying why, where it
    can be had neither way); Windows unless ``win64`` is False (and required where it is True)."""
    from ..cache import cache_root

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
    ``fmi_version``: "2.0" or "3.0" (the same model behind the other shell: native_fmi3)."""
    if fmi_version not in FMI_VERSIONS:
        raise CrankfmuError(f"--fmi-version must be one of {', '.join(v.removesuffix('.0') for v in FMI_VERSIONS)}, "
                            f"got {fmi_version!r}")
    source = preflight("scenario", data_name, name, causality, values)
    # the reference run from now until the FMU is written, beside the tables and the compilers
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
        from . import native_fmi3
        from .documentation import mechanism_png

        describe = lambda sources: native_fmi3.model_description(model, sources)  # noqa: E731
        with stage(fmu, "the terminals and icon"):
            extra["terminalsAndIcons/terminalsAndIcons.xml"] = native_fmi3.terminals_and_icons(model)
            extra["terminalsAndIcons/icon.png"] = mechanism_png(model.scenario)
    with stage(fmu, "the runtimes"):
        runtimes = mechanism_runtimes(fmi_version, win64)
    extra[f"resources/{MODEL_FILE}"] = model.model_file()
    # the runtime's sources (package_native adds the FMI headers)
    files = [path for path in runtime_files(fmi_version) if path.name not in FMI_HEADERS[fmi_version]]
    with ExitStack() as written:
        out = package_native(source, dest, [(path.parent, (path.name,)) for path in files], {},
                             describe, model.parameters(), win64, reference, extra,
                             {"table_error": max(e for e, _ in model.table_errors.values())}, written, fmi_version,
                             runtimes=runtimes)
        Path(written.enter_context(replacing(dest / f"{fmu}_ref.csv"))).write_text(computed["csv"], encoding="utf-8")
        Path(written.enter_context(replacing(dest / f"{fmu}_ref.opt"))).write_text(cross_check_options(source),
                                                                                   encoding="utf-8")
    return out
