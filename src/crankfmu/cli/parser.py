"""The command line's parser: every subcommand with its options and help (docs/cli.md documents
each; tests/test_docs.py holds the two together)."""

from __future__ import annotations

import argparse

from ..integrators import METHODS
from .fmus import cmd_check, cmd_fmu, cmd_schema, cmd_ssp
from .pictures import cmd_animate, cmd_draw, cmd_page
from .studies import cmd_equilibrium, cmd_flywheel, cmd_kinematics, cmd_schemes, cmd_simulate, cmd_sweep, cmd_well


def _parser_class():
    """Subcommands' parsers with the same help formatter (defaults shown)."""
    class Parser(argparse.ArgumentParser):
        def __init__(self, *args, **kwargs):
            kwargs.setdefault("formatter_class", _Help)
            super().__init__(*args, **kwargs)
    return Parser


def _friction_option(p):
    p.add_argument("--friction", default=None, metavar="MU,RADIUS",
                   help="Coulomb friction in every joint: coefficient MU in each pin and slide, pins of RADIUS m "
                        "(docs/friction.md); then --set mu_joints=... and r_pins=... change them")


def _scenario_command(sub, name: str, func, help: str):
    """A subcommand on one scenario: SCENARIO, --out DIR and --set NAME=VALUE (repeatable)."""
    p = sub.add_parser(name, help=help, description=help[0].upper() + help[1:] + ".")
    p.add_argument("scenario", help="packaged scenario name (e.g. seed000) or path to a .toml file")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="override a scenario parameter (SI units), repeatable")
    p.set_defaults(func=func)
    return p


DESCRIPTION = """Planar crank mechanisms with their motor, flywheel and loads, from first principles:
simulate them, study them as the papers do, and build FMUs of them (Python: FMI 2.0 Co-Simulation;
native: FMI 2.0 or 3.0, Co-Simulation and Model Exchange) that the validation harness proves against
an in-process reference. Each command takes a packaged
scenario name (seed000 ... seed004, pumpjack, engine1, engine4, jansen) or the path of your own scenario file;
crankfmu COMMAND --help tells more."""


class _Help(argparse.RawDescriptionHelpFormatter):
    """Every option's default in its help (unless the help says it already, or there is none to
    say: a flag, a required option, an empty list); descriptions kept as written."""

    def _get_help_string(self, action):
        text = action.help or ""
        if ("default" in text or action.required or action.default in (None, argparse.SUPPRESS, [])
                or isinstance(action.default, bool) or not action.option_strings):
            return text
        return text + " (default: %(default)s)"


def build_parser() -> argparse.ArgumentParser:
    from importlib.metadata import PackageNotFoundError, version

    parser = argparse.ArgumentParser(prog="crankfmu", description=DESCRIPTION, formatter_class=_Help)
    try:
        parser.add_argument("--version", action="version", version=f"crankfmu {version('crankfmu')}")
    except PackageNotFoundError:            # run from a source tree that was never installed
        parser.add_argument("--version", action="version", version="crankfmu (not installed)")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_parser_class())
    p = sub.add_parser("simulate", help="run a scenario and write timeseries.csv, summary.json and plots")
    p.add_argument("scenario", help="packaged scenario name (e.g. seed000) or path to a .toml file")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--method", default="reference", choices=METHODS,
                   help="reference: DOP853 at rtol 1e-12 on the contour engine, every switch located; fast: the C "
                        "kernel on the tabulated model (what the FMUs run); radau, dopri5: scipy on the engine; "
                        "badoiu-eq17, lv-eq3: the papers' crank-angle schemes")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="override a scenario parameter (SI units), repeatable")
    p.add_argument("--t-end", type=float, default=None, help="end time in s (default: the scenario's)")
    p.add_argument("--rtol", type=float, default=None,
                   help="relative (and absolute) tolerance of the time-domain methods (default: each method's "
                        "own: reference 1e-12, fast, radau and dopri5 1e-11)")
    p.add_argument("--angle-step-deg", type=float, default=None,
                   help="angle step of the crank-angle schemes in deg (default 0.1)")
    _friction_option(p)
    p.set_defaults(func=cmd_simulate)

    p = _scenario_command(sub, "schemes", cmd_schemes,
                          "the papers' crank-angle schemes against the reference: "
                          "convergence order and start-up")
    p.add_argument("--steps-deg", default="1,0.1,0.01", help="comma-separated angle steps in deg")
    p = _scenario_command(sub, "kinematics", cmd_kinematics,
                          "exact velocities, accelerations and instant centre at one crank "
                          "angle, time series beside the paper's approximation, velocity plan")
    p.add_argument("--at", type=float, required=True, help="crank angle in deg")
    p.add_argument("--omega", type=float, default=None, help="constant crank speed in rad/s (default: the paper's)")

    p = _scenario_command(sub, "sweep", cmd_sweep,
                          "parameter sweep on Dask: kinematic peaks (peaks.csv, the families' "
                          "plots, the paper's claims) or steady cycles (steady.csv)")
    p.add_argument("--param", action="append", default=[], metavar="NAME=START:STOP:COUNT",
                   help="a swept parameter (repeatable; the grid is every combination)")
    p.add_argument("--restart", action="store_true", help="recompute every design (default: resume the results file)")
    p.add_argument("--study", choices=("kinematic", "steady"), default=None,
                   help="kinematic: peaks over a turn at constant speed (default with a [kinematics] section); "
                        "steady: each design's steady cycle and speed fluctuation (default otherwise)")
    p.add_argument("--scheduler", default="local", metavar="ADDRESS",
                   help="Dask scheduler: 'local' (default: a local cluster, one worker process per core), "
                        "an address such as tcp://host:8786 (an existing cluster), or 'serial' (this process)")
    p.add_argument("--chunk", type=int, default=None, help="designs per Dask task (default 4 kinematic, 500 steady)")

    p = _scenario_command(sub, "equilibrium", cmd_equilibrium,
                          "equilibrium moment over a cycle at constant crank speeds, with "
                          "and without inertia, and the joint reactions (seed 001 Figs. 2-5)")
    p.add_argument("--omega", default=None, help="comma-separated crank speeds in rad/s (default: the "
                                                 "scenario's [equilibrium] omega1)")
    p.add_argument("--angles", type=int, default=None, help="crank angles per crank turn, times cycle_turns over a "
                                                          "machine cycle of several turns (default 360)")
    _friction_option(p)

    p = _scenario_command(sub, "flywheel", cmd_flywheel,
                          "flywheel for a target speed fluctuation: eqs. 16-17 and by simulation "
                          "of the steady cycle; J_e, the movement from the start, eq. 3 stability")
    p.add_argument("--delta", type=float, required=True, help="target coefficient of speed fluctuation, in (0, 1)")
    p.add_argument("--steps-deg", default=None, help="comma-separated eq. 3 angle steps in deg (default: the "
                                                     "scenario's [flywheel] eq3_steps_deg)")

    p = sub.add_parser("draw", help="the mechanism at one crank angle (PNG/SVG): links, joints, ground, mass "
                                     "centres; optionally velocities, instant centres, joint reactions")
    p.add_argument("scenario", help="packaged scenario name or path to a .toml file")
    p.add_argument("--at", type=float, default=None, help="crank angle in deg (default: the scenario's [drawing] at_deg, else 0)")
    p.add_argument("--out", required=True, help="FILE.png, .svg or .pdf")
    p.add_argument("--velocities", action="store_true", help="velocity vectors of the points (at --omega)")
    p.add_argument("--instant-centres", dest="instant_centres", action="store_true",
                   help="the instant centres of the turning links")
    p.add_argument("--reactions", action="store_true", help="the joint reactions of crankfmu equilibrium "
                                                             "at this angle (constant crank speed --omega)")
    p.add_argument("--plain", action="store_true", help="no overlays, even those of the scenario's [drawing] show")
    p.add_argument("--omega", type=float, default=None, help="crank speed in rad/s for velocities and reactions "
                   "(default: the scenario's [drawing], [kinematics] or [equilibrium] speed, else omega1_start)")
    p.add_argument("--trace", default=None, metavar="P,Q", help="points whose path over a turn is drawn")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="override a scenario parameter (SI units), repeatable")
    p.set_defaults(func=cmd_draw)

    p = sub.add_parser("animate", help="the mechanism moving (GIF, or MP4 with ffmpeg): a crank turn at constant "
                                        "speed or a simulated run, traced points, omega1 with a cursor")
    p.add_argument("scenario", help="packaged scenario name or path to a .toml file")
    p.add_argument("--out", required=True, help="FILE.gif or FILE.mp4")
    p.add_argument("--result", default=None, metavar="DIR", help="a run of crankfmu simulate (DIR/timeseries.csv) "
                                                                   "to animate instead of a constant-speed turn")
    p.add_argument("--trace", default=None, metavar="P,Q", help="points whose paths are traced (default: the "
                                                                  "scenario's [drawing] trace)")
    p.add_argument("--frames", type=int, default=120, help="frames, spread evenly over the motion (default 120)")
    p.add_argument("--fps", type=int, default=20, help="frames per second (default 20)")
    p.add_argument("--omega", type=float, default=None, help="constant crank speed in rad/s without --result")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="override a scenario parameter (SI units), repeatable")
    p.set_defaults(func=cmd_animate)

    p = sub.add_parser("check", help="check a scenario and its mechanism file before building anything: names, "
                                      "degree of freedom, Grashof, assembly, dead points, masses, J_red (exit 0/1/2)")
    p.add_argument("scenario", help="packaged scenario name or path to a .toml scenario file")
    p.set_defaults(func=cmd_check)

    from ..schema import SCHEMAS
    p = sub.add_parser("schema", help="print the JSON Schema of a data file kind, for an editor that validates and "
                                       "completes TOML against it (docs/your-mechanism.md)")
    p.add_argument("kind", choices=list(SCHEMAS), help="the kind of data file")
    p.set_defaults(func=cmd_schema)

    p = sub.add_parser("fmu", help="build the FMU of a scenario (Python: FMI 2.0 Co-Simulation; --native: FMI 2.0 or "
                                    "3.0, Co-Simulation and Model Exchange): packaged, or your own scenario file with "
                                    "its mechanism file beside it")
    p.add_argument("source", metavar="SCENARIO", help="packaged scenario name (seed000) or path to a .toml scenario "
                                                      "file (with --drive: a drive file)")
    p.add_argument("--out", required=True, help="folder for NAME.fmu and its cross-check files NAME_ref.csv/.opt")
    p.add_argument("--name", default=None, help="the FMU's model identifier (default: the file's fmu key)")
    p.add_argument("--drive", action="store_true", help="SCENARIO is a drive file (Drive.fmu: drives/dc_pi.toml)")
    p.add_argument("--well", action="store_true",
                   help="SCENARIO is a well file (RodString.fmu: wells/rp11l_guo.toml)")
    p.add_argument("--cushion", action="store_true",
                   help="SCENARIO is a cushion file (DieCushion.fmu: elements/die_cushion.toml)")
    p.add_argument("--shaft", action="store_true",
                   help="SCENARIO is a shaft file (ElasticShaft.fmu, a torsion spring-damper between a drive and a "
                        "crank: shafts/elastic_shaft.toml)")
    p.add_argument("--native", action="store_true",
                   help="a native FMU (C, no Python needed on the host; Co-Simulation and Model Exchange): every "
                        "parameter, geometry, masses, loads and gravity included, is set by the host before "
                        "initialisation")
    p.add_argument("--fmi-version", choices=("2", "3"), default="2",
                   help="with --native: FMI 2.0 (linux64, win64), or FMI 3.0 (x86_64 Linux and Windows, aarch64 "
                        "Linux; a mechanism's with event mode and early return, terminals and icon); default 2")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="with --native and a scenario: a parameter's start value in the FMU (SI units, repeatable); "
                        "a host may still set it before initialisation")
    p.add_argument("--causality", choices=("torque", "speed"), default=None,
                   help="what the crank takes: a torque (tau_ext, the default) or the speed omega1 (the FMU then "
                        "outputs tau_drive, the torque the drive must apply); default: the file's [crank] causality")
    p.set_defaults(func=cmd_fmu)


    # validate and hosts parse their own options (crankfmu validate --help): building this parser
    # then imports neither harness, whose cases and references take 0.4 s to import
    p = sub.add_parser("validate", add_help=False, help="every FMU against the in-process reference and the "
                                                        "papers: PASS/FAIL lines and DIR/report.md")
    p.set_defaults(delegate="crankfmu.validation.harness")

    p = sub.add_parser("ssp", help="FourBarDrive.ssp (FourBar.fmu driven by Drive.fmu: DC motor, PI speed control) "
                                    "and FourBarDriveSpeed.ssp (the same in speed causality), for third-party masters")
    p.add_argument("--fmus", default=None, help="folder with the FMUs (make fmu; default build/fmus, or "
                                                "build/fmus/native with --native)")
    p.add_argument("--out", required=True, help="output folder for the SSP files")
    p.add_argument("--native", action="store_true",
                   help="native FMUs only (no Python on the host): each must be built for the values the SSP sets")
    p.add_argument("--system", action="append", choices=("FourBarDrive", "FourBarDriveSpeed", "DriveShaftFourBar",
                                                         "PressCushion", "PumpingWell", "well"),
                   help="which SSP (default: FourBarDrive and FourBarDriveSpeed; DriveShaftFourBar needs DriveSpeed.fmu, "
                        "ElasticShaft.fmu and FourBar.fmu; PressCushion needs TogglePress.fmu, "
                        "built from validation/data/togglepress_scenario.toml, and DieCushion.fmu; PumpingWell, or well: PumpJack.fmu "
                        "and RodString.fmu)")
    p.set_defaults(func=cmd_ssp)

    p = sub.add_parser("well", help="a beam pumping well (wells/*.toml: rod string, pump, surface unit) run to "
                                     "steady state: cards.png, torque.png, summary.json, well.gif")
    p.add_argument("well", help="a packaged well (rp11l_guo) or a .toml well file")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--max-strokes", type=int, default=40, help="give up on steady state after this many strokes")
    p.add_argument("--frames", type=int, default=60, help="frames of the animation")
    p.add_argument("--no-animation", action="store_true", help="skip well.gif")
    p.add_argument("--reference-loop", action="store_true",
                   help="step the unit and the string in Python (crankfmu.well.CoupledWell.step), the reference the C "
                        "loop is tested against: the same numbers, about three times slower end to end")
    p.set_defaults(func=cmd_well)

    p = sub.add_parser("page", help="the results page: FOLDER/index.html shows every figure and animation under "
                                     "FOLDER by data file, with captions, the paper's figures they reproduce, the "
                                     "published numbers beside ours and the validation report")
    p.add_argument("folder", help="a folder of results (make demo's build/demo)")
    p.add_argument("--validation", default=None, metavar="DIR",
                   help="a crankfmu validate --out folder (its checks.json and report.html) to show with them")
    p.add_argument("--out", default=None, help="the page's file (default: FOLDER/index.html)")
    p.set_defaults(func=cmd_page)

    p = sub.add_parser("hosts", add_help=False, help="the drop-in check: third-party masters (fmpy, ecos, "
                                                     "ecospy, libcosim) on FourBar.fmu and FourBarDrive.ssp; "
                                                     "PASS/FAIL lines")
    p.set_defaults(delegate="crankfmu.validation.hosts")
    return parser
