"""Lanes of commands run side by side with one live line each (make demo's two lines of work: the
papers' studies and the pumping well). ``make -j2 --output-sync`` holds a target's output back and
replays it, progress bars and all, when the target ends; here each lane's output goes to its log
and the terminal shows, per lane, the command running and its last line, redrawn in place. Where
the output is not a terminal (a CI log), each command prints one line when it ends.

    python -m crankfmu.cli.lanes --logs DIR [--make-var NAME=VALUE ...] LANE:TARGET ...

reads each lane's commands from ``make -n TARGET`` (the Makefile stays the one list of them) and
runs them in order in bash; a failed command stops its lane, the other lane finishes, the log's
tail is printed, and the exit status is 1.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from ..progress import is_terminal


@dataclass
class Lane:
    name: str                         # padded to the longest lane's name, so the columns line up
    commands: list[str]
    log: Path
    done: int = 0
    current: str = ""
    failed: str = ""
    started: float = field(default_factory=time.perf_counter)
    finished: float | None = None


def commands_of(target: str, make_vars: list[str]) -> list[str]:
    """The shell lines ``make`` would run for ``target`` (comments dropped)."""
    listed = subprocess.run(["make", "-n", "--no-print-directory", target, *make_vars], capture_output=True,
                            text=True, check=True).stdout
    return [line for line in listed.splitlines() if line.strip() and not line.lstrip().startswith("#")]


def last_line(path: Path) -> str:
    """The log's last line of text (a progress bar's latest state)."""
    try:
        with open(path, "rb") as f:
            f.seek(0, 2)
            f.seek(max(0, f.tell() - 400))
            tail = f.read().decode("utf-8", "replace")
    except OSError:
        return ""
    parts = [p.strip() for p in tail.replace("\r", "\n").split("\n") if p.strip()]
    return parts[-1] if parts else ""


def short(command: str) -> str:
    """A command as a person reads it: crankfmu's subcommand and arguments, no venv path."""
    words = command.split()
    if words and words[0].endswith("/crankfmu"):
        words[0] = "crankfmu"
    return " ".join(words)


def run_lane(lane: Lane, announce) -> None:
    with open(lane.log, "w") as log:
        for command in lane.commands:
            lane.current = short(command)
            log.write(f"$ {lane.current}\n")
            log.flush()
            began = time.perf_counter()
            done = subprocess.run(["bash", "-c", command], stdout=log, stderr=subprocess.STDOUT)
            if done.returncode:
                lane.failed = lane.current
                break
            lane.done += 1
            announce(lane, time.perf_counter() - began)
    lane.finished = time.perf_counter()


def status(lane: Lane, width: int) -> str:
    elapsed = (lane.finished or time.perf_counter()) - lane.started
    head = f"{lane.name} [{lane.done:>2}/{len(lane.commands)}] {elapsed:5.0f} s  "
    if lane.failed:
        text = f"FAILED: {lane.failed}"
    elif lane.finished is not None:
        text = "done"
    else:
        progress = last_line(lane.log)
        text = lane.current + (f"  | {progress}" if progress and not progress.startswith("$ ") else "")
    return (head + text)[: max(20, width - 1)]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m crankfmu.cli.lanes", description=__doc__.split("\n\n")[0])
    parser.add_argument("lanes", nargs="+", metavar="LANE:TARGET", help="a lane's name and its make target")
    parser.add_argument("--logs", type=Path, required=True, help="the folder of the lanes' logs (LANE.log)")
    parser.add_argument("--make-var", action="append", default=[], metavar="NAME=VALUE",
                        help="passed to make -n (e.g. OUT=build/demo)")
    args = parser.parse_args(argv)
    args.logs.mkdir(parents=True, exist_ok=True)
    lanes = []
    pad = max(len(spec.partition(":")[0]) for spec in args.lanes)
    for spec in args.lanes:
        name, _, target = spec.partition(":")
        lanes.append(Lane(f"{name:<{pad}}", commands_of(target or name, args.make_var), args.logs / f"{name}.log"))
    live = is_terminal(sys.stdout)
    lock = threading.Lock()

    def announce(lane: Lane, seconds: float) -> None:
        if not live:                      # a log: one whole line per finished command
            with lock:
                print(f"{lane.name} [{lane.done:>2}/{len(lane.commands)}] {seconds:5.1f} s  {lane.current}",
                      flush=True)

    threads = [threading.Thread(target=run_lane, args=(lane, announce), daemon=True) for lane in lanes]
    for t in threads:
        t.start()
    drawn = False

    def draw() -> None:                   # every lane's line, over the ones drawn before
        nonlocal drawn
        width = shutil.get_terminal_size((100, 20)).columns
        with lock:
            sys.stdout.write((f"\x1b[{len(lanes)}F" if drawn else "")
                             + "".join(f"\x1b[2K{status(lane, width)}\n" for lane in lanes))
            sys.stdout.flush()
        drawn = True

    while any(t.is_alive() for t in threads):
        if live:
            draw()
        time.sleep(0.25)
    if live:
        draw()                            # the lanes' last state: done, or where one failed
    failed = [lane for lane in lanes if lane.failed or lane.done < len(lane.commands)]
    for lane in failed:
        print(f"\n{lane.name.strip()}: {lane.failed or 'stopped'} failed; the end of {lane.log}:")
        print("\n".join(lane.log.read_text(errors="replace").splitlines()[-15:]))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
