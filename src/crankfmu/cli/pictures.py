"""The commands that draw: ``crankfmu draw``, ``animate`` and ``page``."""

from __future__ import annotations

from pathlib import Path

from ..errors import CrankfmuError
from .arguments import parse_points, parse_sets


def cmd_draw(args) -> int:
    from ..pictures.draw import OVERLAYS, draw_figure, drawing_section, save
    from ..scenario import load_scenario

    scenario = load_scenario(args.scenario).with_params(**parse_sets(args.set))
    section = drawing_section(scenario)
    at = args.at if args.at is not None else float(section.get("at_deg", 0.0))
    chosen = [o for o in OVERLAYS if getattr(args, o)]
    show = chosen or ([] if args.plain else list(section.get("show", [])))
    trace = parse_points(args.trace) if args.trace is not None else section.get("trace", [])
    out = Path(args.out)
    if out.suffix.lower() not in (".png", ".svg", ".pdf"):
        raise CrankfmuError(f"--out {out}: a drawing is written as .png, .svg or .pdf")
    fig = draw_figure(scenario, at, show, args.omega, trace, section.get("caption", ""))
    cite = section.get("caption", "")
    save(fig, out, scenario.name, (f"{cite}. " if cite else "") + f"{scenario.title}, drawn from its data files at phi1 = {at:g} deg"
         + (f" with {', '.join(show)}" if show else "") + (f"; traced: {', '.join(trace)}" if trace else "") + ".")
    print(f"{scenario.name}: the mechanism at phi1 = {at:g} deg" + (f" with {', '.join(show)}" if show else "")
          + f": wrote {out}")
    return 0


def cmd_animate(args) -> int:
    from ..pictures.animate import animate
    from ..progress import ProgressBar
    from ..scenario import load_scenario

    scenario = load_scenario(args.scenario).with_params(**parse_sets(args.set))
    bar = ProgressBar(args.frames, label=f"{scenario.name} animation")
    try:
        path = animate(scenario, args.out, args.result, parse_points(args.trace), args.frames, args.fps, args.omega,
                       progress=bar)
    finally:
        bar.close()
    print(f"{scenario.name}: {args.frames} frames at {args.fps} per s: wrote {path}")
    return 0


def cmd_page(args) -> int:
    from ..pages.results import write_page

    out = write_page(args.folder, args.validation, args.out)
    print(f"wrote {out}: open it in a browser")
    return 0
