"""The Python FMU of a data file (``crankfmu fmu``), and the packaged ones: ``python
fmu_build/build.py [--dest build/fmus]`` (this module's ``main``). What it is built from, and the
checks before, are fmi.source's; its reference result fmi.reference's.

On linux64 the FMU's binary is the shim of ``shim/fmu_shim.c`` beside this file (compiled when crankfmu
is installed, shim/prebuilt.py; here with gcc only where its sources changed since), named ``<model>.so``,
in front of pythonfmu's binary, renamed ``<model>_pythonfmu.so``: it makes the FMU load in plain
C/C++ hosts and turns refusals logged by the slave into fmi2Error. ``resources/python_env.txt``
records the Python that built the FMU, the last place the shim looks in a C host (README, "Using
the FMU elsewhere").

pythonfmu packs the slave script with crankfmu's own package in the resources (the same model
code and scenario files as the CLI, as one archive: ``pack``) and writes a modelDescription without units, unit
definitions or initial unknowns; this step completes it: each Real gets its SI unit (from the
scenario file), ``UnitDefinitions`` gives each unit's SI base exponents, ``InitialUnknowns``
lists the outputs with the parameters they depend on at initialisation, and the
``DefaultExperiment`` comes from the scenario's experiment. As the Reference FMUs do, the FMU
carries the default experiment's result (``extra/org.fmi-standard.fmi-ls-ref/<model>_out.csv``
with its manifest), written beside it too as the cross-check files ``<model>_ref.csv`` and
``<model>_ref.opt``; the result comes from the in-process reference integrator, an independent
method from the FMU's own stepper.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile
from contextlib import ExitStack
from pathlib import Path
from xml.dom.minidom import parseString
from xml.etree import ElementTree as ET

from ... import units as si
from ...contract import direct_dependencies
from ...atomic import replacing
from ...errors import CrankfmuError
from ..archive import add_bytes, add_file
from ..background import reference_beside
from ..reference import LS_REF, LS_REF_MANIFEST, cross_check_options
from ..source import Source, preflight, vendor_annotations
from ..stages import stage

HERE = Path(__file__).resolve().parent
PACKAGE = HERE.parents[1]       # the crankfmu package, shipped in every FMU's resources

#: what runs inside an FMU, relative to the package: the core on numpy alone and the FMI shell's
#: slave. Studies, plots, sweeps, the CLI, the harness, the build step and the scipy-based
#: integrators stay out (tests/test_fmu_dropin.py runs the FMUs where scipy cannot be imported).
RUNTIME = ("__init__.py", "cache.py", "contract.py", "errors.py", "expressions.py", "numerics.py", "scenario.py",
           "scenario_loads.py", "units.py",
           "mechanisms", "dynamics", "scenarios",
           "integrators/__init__.py", "integrators/base.py", "integrators/fast.py", "native",
           "fmi/__init__.py", "fmi/variables.py", "fmi/python/__init__.py", "fmi/python/core.py", "fmi/python/slave.py",
           "fmi/python/speed.py", "fmi/python/drive.py", "fmi/python/cushion.py", "fmi/python/shaft.py",
           "fmi/python/rodstring.py", "parameters.py", "datafiles.py", "schema.py", "drives", "elements",
           "shafts", "wells")


#: the package's folders of data files: an FMU carries only the files it reads (Source.data)
DATA_FOLDERS = ("scenarios", "drives", "elements", "shafts", "wells", "mechanisms/files")


def copy_runtime(dest: Path, files: dict | None = None, data=()):
    """The runtime part of the package (RUNTIME) into ``dest``, with the packaged data files
    ``data`` (paths in the package) and ``files`` (path -> text: a user's data files); each data
    file also as JSON, which an FMU reads where tomllib is missing (Python 3.10:
    datafiles.read_toml). The fewer the files, the faster a host that extracts the FMU on every
    run starts it."""
    import json
    import tomllib

    from ... import native
    from ...native.sources import RUNTIMES

    # the C kernel travels compiled for linux64 (and its sources): the library this process loaded;
    # not the native FMUs' runtimes
    library = native.LIBRARY_PATH

    def ignore(folder, names):
        skip = {n for n in names if n == "__pycache__" or n.endswith((".so", ".dll", ".o"))}
        if Path(folder) == RUNTIMES.parent:
            skip.add(RUNTIMES.name)
        inside = Path(folder).relative_to(PACKAGE).as_posix()
        if inside in DATA_FOLDERS:
            skip |= {n for n in names if f"{inside}/{n}" not in data}
        return skip

    for entry in RUNTIME:
        source = PACKAGE / entry
        if source.is_dir():
            shutil.copytree(source, dest / entry, ignore=ignore)
        else:
            (dest / entry).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, dest / entry)
    shutil.copy2(library, dest / "native" / native.library_name(sys.platform))
    for path, text in (files or {}).items():
        (dest / path).parent.mkdir(parents=True, exist_ok=True)
        (dest / path).write_text(text, encoding="utf-8")
    for toml in dest.rglob("*.toml"):
        toml.with_suffix(".json").write_text(json.dumps(tomllib.loads(toml.read_text(encoding="utf-8"))), encoding="utf-8")


def pack(folder: Path) -> Path:
    """The package folder as one archive beside it (``<folder>.zip``), its content hash (every
    file's path and bytes) as the archive's comment: the FMU carries it as
    ``resources/crankfmu_<model>.zip`` and its slave script unpacks it once into the per-user cache,
    under that hash (slave_script.py.in). One file instead of some sixty: a host that extracts the
    FMU on every run (fmpy) spends about 0.15 ms per file."""
    import hashlib

    files = sorted(p for p in folder.rglob("*") if p.is_file())
    digest = hashlib.sha256()
    for path in files:
        digest.update(path.relative_to(folder).as_posix().encode() + b"\0" + path.read_bytes())
    archive = folder.with_name(folder.name + ".zip")
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as out:
        for path in files:
            out.write(path, path.relative_to(folder).as_posix())
        out.comment = digest.hexdigest()[:16].encode()
    return archive


#: the data files the packaged FMUs are built from: every packaged scenario and drive file that
#: names its FMU (``fmu = "FourBar"``); the FMU's model identifier lives in the file
def packaged_sources() -> list[tuple[str, str]]:
    """(kind, name) of every packaged data file with an ``fmu`` key, in file order."""
    from ...dynamics.cushion import available_cushions, load_cushion
    from ...dynamics.drive import available_drives, load_drive
    from ...dynamics.shaft import available_shafts, load_shaft
    from ...dynamics.well import available_wells, load_well
    from ...scenario import available_scenarios, load_scenario

    return ([("scenario", n) for n in available_scenarios() if load_scenario(n).data.get("fmu")]
            + [("drive", n) for n in available_drives() if load_drive(n).fmu]
            + [("cushion", n) for n in available_cushions() if load_cushion(n).fmu]
            + [("shaft", n) for n in available_shafts() if load_shaft(n).fmu]
            + [("well", n) for n in available_wells() if load_well(n).fmu])


def complete_model_description(xml_bytes: bytes, declared, source: Source) -> bytes:
    """pythonfmu's modelDescription with units, parameter ranges (min/max where a bound exists),
    UnitDefinitions, DefaultExperiment, the data file's name, the outputs' dependencies and
    InitialUnknowns, from what the core declares (``declared``: fmi.python.core.Declared)."""
    units, parameters = declared.units, {p.name: p for p in declared.parameters}
    root = ET.fromstring(xml_bytes)
    variables = root.find("ModelVariables")
    index = {}
    for i, sv in enumerate(variables.findall("ScalarVariable"), start=1):
        name = sv.get("name")
        index[name] = i
        real = sv.find("Real")
        unit = units.get(name)
        if unit is None:
            raise CrankfmuError(f"build: no unit for variable {name}")
        if real is not None and unit != "1":
            real.set("unit", si.fmi_name(unit))
        if real is not None and real.get("start") is not None:
            # pythonfmu writes 16 digits (rtol 1e-11 as 9.999999999999999e-12): the shortest text
            # of the same double, as the data file writes it (the native FMU's repr does too)
            real.set("start", repr(float(real.get("start"))))
        p = parameters.get(name)
        if real is not None and p is not None:
            # FMI's min/max are inclusive: an exclusive bound is declared as the bound itself and
            # refused by the FMU with its message
            if p.min is not None:
                real.set("min", repr(float(p.min)))
            if p.max is not None:
                real.set("max", repr(float(p.max)))
    # UnitDefinitions must come before ModelVariables (after LogCategories / DefaultExperiment order:
    # CoSimulation, UnitDefinitions, TypeDefinitions, LogCategories, DefaultExperiment, ...)
    unit_defs = ET.Element("UnitDefinitions")
    for unit in sorted({si.fmi_name(u) for u in units.values() if u != "1"}):
        u = ET.SubElement(unit_defs, "Unit", name=unit)
        ET.SubElement(u, "BaseUnit", {k: str(v) for k, v in si.base_units(unit).items()})
    children = list(root)
    position = [c.tag for c in children].index("CoSimulation") + 1
    root.insert(position, unit_defs)

    exp = source.experiment
    for old in root.findall("DefaultExperiment"):
        root.remove(old)
    default = ET.Element("DefaultExperiment", startTime=repr(exp.start_time), stopTime=repr(exp.stop_time),
                         tolerance=repr(exp.tolerance), stepSize=repr(exp.output_interval))
    position = [c.tag for c in root].index("ModelVariables")
    root.insert(position, default)
    for old in root.findall("VendorAnnotations"):
        root.remove(old)
    root.insert(position + 1, vendor_annotations(source, "python"))

    structure = root.find("ModelStructure")
    # each output's direct dependencies on the inputs (contract.Variable.depends): a Python FMU
    # declares no states, so an output that depends on none lists none (no algebraic loop through it)
    by_name = {v.name: v for v in declared.outputs}
    input_names = [p.name for p in declared.inputs]
    name_at = {i: name for name, i in index.items()}
    for unknown in structure.find("Outputs").findall("Unknown"):
        v = by_name[name_at[int(unknown.get("index"))]]
        depends = direct_dependencies(v.depends, declared.outputs, input_names)
        unknown.set("dependencies", " ".join(str(index[n]) for n in depends))
        unknown.set("dependenciesKind", " ".join("dependent" for _ in depends))
    for old in structure.findall("InitialUnknowns"):
        structure.remove(old)
    initial = ET.SubElement(structure, "InitialUnknowns")
    outputs = [sv.get("name") for sv in variables.findall("ScalarVariable") if sv.get("causality") == "output"]
    everything = [sv.get("name") for sv in variables.findall("ScalarVariable")
                  if sv.get("causality") in ("parameter", "input")]
    for name in outputs:
        deps = []
        for d in source.depends.get(name, ("*all",)):
            deps += everything if d == "*all" else source.groups.get(d, [d])
        refs = sorted({index[d] for d in deps if d in index})
        ET.SubElement(initial, "Unknown", index=str(index[name]), dependencies=" ".join(map(str, refs)))
    for element in root.iter():           # drop pythonfmu's whitespace before re-indenting
        if element.text is not None and not element.text.strip():
            element.text = None
        element.tail = None
    text = ET.tostring(root, encoding="UTF-8")
    return parseString(text).toprettyxml(encoding="UTF-8", indent="  ")


def pythonfmu_binaries() -> dict[str, Path]:
    """pythonfmu's platform libraries, from its installed distribution's files: the pythonfmu that
    ``import`` finds may be the copy inside an FMU this process has loaded (pythonfmu puts an FMU's
    resources first on sys.path), which ships without its binaries, and FmuBuilder would then
    silently build an FMU without them."""
    from importlib.metadata import PackageNotFoundError, distribution

    try:
        dist = distribution("pythonfmu")
    except PackageNotFoundError:
        raise CrankfmuError("build: pythonfmu is not installed (python -m pip install pythonfmu)") from None
    found = {Path(str(f)).parent.name: Path(dist.locate_file(f)) for f in dist.files or []
             if "resources/binaries/" in str(f) and Path(str(f)).suffix in (".so", ".dll", ".dylib")}
    if "linux64" not in found or not found["linux64"].is_file():
        raise CrankfmuError(f"build: pythonfmu's linux64 library is missing from its installation ({dist.locate_file('pythonfmu')})")
    return found


def compile_shim(name: str, out: Path) -> Path:
    """The linux64 shim of model ``name`` at ``out``: the one compiled when crankfmu was installed
    (shim/prebuilt.py), or gcc's where the sources changed since."""
    from .shim import prebuilt

    try:
        return prebuilt.shim(out)
    except FileNotFoundError:
        raise CrankfmuError("build: gcc not found; it compiles the FMU's linux64 shim (apt-get install gcc), "
                            "which an installed crankfmu carries compiled") from None
    except subprocess.CalledProcessError as exc:
        raise CrankfmuError(f"build: compiling the shim failed:\n{exc.stderr}") from None


def python_env() -> str:
    """The building Python, the last place the shim looks for one in a C host (README: "Using the
    FMU elsewhere"): key=value lines."""
    libpython = Path(sysconfig.get_config_var("LIBDIR")) / sysconfig.get_config_var("INSTSONAME")
    return (f"executable={sys.executable}\nlibpython={libpython}\n"
            f"version={sys.version.split()[0]}\n")


def slave_script(name: str, source: Source, digest: str) -> str:
    """The slave script of one FMU, from the one template; ``digest``: its package's content hash."""
    from string import Template

    module, cls = source.core.split(":")
    template = Template((HERE / "slave_script.py.in").read_text(encoding="utf-8"))
    return template.substitute(NAME=name, SOURCE=source.load, CORE_MODULE=module, CORE_CLASS=cls,
                               DESCRIPTION=repr(source.title), DIGEST=digest)


def build(kind: str, data_name: str, dest: Path, name: str | None = None, causality: str | None = None) -> Path:
    """Build the FMU of a data file (a packaged name, or a user's scenario file by path) into
    ``dest``; ``name`` overrides the file's ``fmu`` key. Returns the FMU's path.

    Every file it writes (the FMU and its cross-check files) is written whole or not at all: a
    failure at any stage leaves ``dest`` as it was (``atomic.replacing``)."""
    from pythonfmu import FmuBuilder

    source = preflight(kind, data_name, name, causality)
    name = source.fmu
    if source.initialise is not None:          # no FMU that cannot start at its own start values
        with stage(name, "initialising the model at the FMU's start values"):
            source.initialise()
    dest.mkdir(parents=True, exist_ok=True)
    out = dest / f"{name}.fmu"
    # the reference run from now on, beside the packing and the shim's compiler (fmi.background)
    with tempfile.TemporaryDirectory() as tmp, ExitStack() as written, \
            reference_beside(source.reference) as reference_text:
        # the package travels under a private name (see slave_script.py.in)
        private = Path(tmp) / "pkg" / f"crankfmu_{name}"
        script_dir = Path(tmp) / "script"
        script_dir.mkdir()
        script = script_dir / f"{name}.py"
        with stage(name, "copying the package"):
            copy_runtime(private, source.files, source.data)
        with stage(name, "packing the package"):
            archive = pack(private)
            with zipfile.ZipFile(archive) as packed:
                script.write_text(slave_script(name, source, packed.comment.decode()), encoding="utf-8")
        sys.path.insert(0, str(private.parent))
        sys.path.insert(0, str(script_dir))
        try:
            with stage(name, "pythonfmu's build of the slave"):
                raw = FmuBuilder.build_FMU(script, dest=Path(tmp) / f"{name}.fmu",
                                           project_files=[archive],
                                           canGetAndSetFMUstate=True, canSerializeFMUstate=True)
        finally:
            sys.path.remove(str(private.parent))
            sys.path.remove(str(script_dir))
            sys.modules.pop(name, None)
        with stage(name, "declaring the variables"):
            declared = source.variables()
            slave_parameters = {p.name: p for p in declared.parameters}
        with stage(name, "compiling the linux64 shim"):
            shim = compile_shim(name, Path(tmp) / f"{name}.so")

        def reference_run():            # the documentation waits for it once it has drawn the mechanism
            with stage(name, "the reference run of the default experiment"):
                return reference_text()
        with stage(name, "finding pythonfmu's platform binaries"):
            platform_binaries = pythonfmu_binaries()
        binary = f"binaries/linux64/{name}.so"
        partial = written.enter_context(replacing(out))
        with zipfile.ZipFile(raw) as zin, zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as zout:
            for item in zin.infolist():
                if item.filename.startswith("binaries/"):
                    continue                  # pythonfmu's binaries come from its installation, below
                data = zin.read(item.filename)
                if item.filename == "modelDescription.xml":
                    with stage(name, "completing the modelDescription"):
                        data = complete_model_description(data, declared, source)
                    with stage(name, "the documentation"):
                        docs = source.documentation(name, data, slave_parameters, reference_run, build="python",
                                                    platforms=sorted(platform_binaries))
                add_bytes(zout, item.filename, data, like=item)
            reference = reference_run()
            with stage(name, "writing the FMU"):
                for platform, library in platform_binaries.items():
                    inner = f"{name}_pythonfmu.so" if platform == "linux64" else f"{name}{library.suffix}"
                    add_file(zout, library, f"binaries/{platform}/{inner}")
                add_file(zout, shim, binary)
                add_bytes(zout, "resources/python_env.txt", python_env())
                for path, content in docs.items():
                    add_bytes(zout, path, content)
                if reference is not None:
                    add_bytes(zout, f"{LS_REF}/fmi-ls-manifest.xml", LS_REF_MANIFEST.format(name=name))
                    add_bytes(zout, f"{LS_REF}/{name}_out.csv", reference)
        if reference is not None:
            with stage(name, "writing the cross-check files"):
                Path(written.enter_context(replacing(dest / f"{name}_ref.csv"))).write_text(reference, encoding="utf-8")
                Path(written.enter_context(replacing(dest / f"{name}_ref.opt"))).write_text(cross_check_options(source), encoding="utf-8")
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--dest", default="build/fmus")
    args = parser.parse_args(argv)
    try:
        for kind, data_name in packaged_sources():
            path = build(kind, data_name, Path(args.dest))
            print(f"built {path}")
    except CrankfmuError as exc:
        print(f"build: error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
