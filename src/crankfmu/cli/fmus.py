"""The FMU commands: ``crankfmu check`` (what a build would refuse), ``fmu`` (Python or native,
FMI 2.0 or 3.0) and ``ssp``."""

from __future__ import annotations

from pathlib import Path

from ..errors import CrankfmuError
from .arguments import parse_sets


def cmd_check(args) -> int:
    from ..check import check_scenario

    report = check_scenario(args.scenario)
    print(report.text())
    print({0: "check passed", 1: "check FAILED", 2: "the files cannot be read"}[report.status])
    return report.status


def cmd_schema(args) -> int:
    from ..schema import schema_json

    print(schema_json(args.kind))
    return 0


def cmd_fmu(args) -> int:
    kinds = [kind for kind in ("drive", "cushion", "shaft", "well") if getattr(args, kind)]
    if len(kinds) > 1:
        raise CrankfmuError("--drive, --cushion, --shaft and --well: give one (what kind of file SCENARIO is)")
    kind = kinds[0] if kinds else "scenario"
    values = parse_sets(args.set)
    if values and not (args.native and kind == "scenario"):
        raise CrankfmuError("--set: a native mechanism FMU's values only (--native with a scenario); every parameter "
                            f"of a{' native' if args.native else ' Python'} {kind} FMU is set by its host")
    if args.fmi_version == "3" and not args.native:
        raise CrankfmuError("--fmi-version 3: native FMUs only (--native); the Python FMUs (pythonfmu) are FMI 2.0")
    from ..fmi.stages import watching_stages
    from ..progress import StageLine

    line = StageLine()
    try:
        with watching_stages(line):
            path = _build_fmu(args, kind, values)
    finally:
        line.close()
    print(f"built {path} ({_platforms(path)})")
    return 0


def _platforms(path: Path) -> str:
    """What the FMU carries binaries for, as its build's summary names them."""
    import zipfile

    with zipfile.ZipFile(path) as z:
        folders = sorted({n.split("/")[1] for n in z.namelist() if n.startswith("binaries/") and n.count("/") >= 2
                          and not n.endswith("/")})
    return "binaries: " + (", ".join(folders) or "none")


def _build_fmu(args, kind: str, values: dict) -> Path:
    """The FMU cmd_fmu asked for: native or Python, a mechanism's or a component's."""
    if args.native and kind != "scenario":
        from ..fmi.native.components import build_native_component

        path = build_native_component(kind, args.source, Path(args.out), args.name, args.causality,
                                      fmi_version=f"{args.fmi_version}.0")
    elif args.native:
        from ..fmi.native.build import build_native

        path = build_native(args.source, Path(args.out), args.name, causality=args.causality, values=values,
                            fmi_version=f"{args.fmi_version}.0")
    else:
        from ..fmi.python.build import build

        path = build(kind, args.source, Path(args.out), args.name, args.causality)
    return path


def cmd_ssp(args) -> int:
    from ..fmi.ssp import write_ssp

    fmus = Path(args.fmus or ("build/fmus/native" if args.native else "build/fmus"))
    for system in args.system or ("FourBarDrive", "FourBarDriveSpeed"):
        system = "PumpingWell" if system == "well" else system
        path = write_ssp(fmus, Path(args.out), system=system, native=args.native)
        print(f"wrote {path}")
    return 0
