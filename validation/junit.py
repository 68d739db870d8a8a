"""The harness's checks as JUnit XML, the format CI systems (GitLab, Jenkins, GitHub's test
reporters) show: one test suite per FMU build, one test case per check. A failed check is a
``<failure>``; a skipped one, and a published number that disagrees (explained), is fitted or is
not comparable, is a ``<skipped>`` whose ``type`` says which, so none of them reads as a pass."""

from __future__ import annotations

from collections import OrderedDict
from xml.etree import ElementTree as ET

from crankfmu.atomic import write_text

from .checks import count


def _suite_of(name: str) -> str:
    """The FMU and build a check belongs to: its name's first two parts (FourBar.native)."""
    return ".".join(name.split(".")[:2])


def junit_xml(checks, elapsed: float) -> str:
    suites: OrderedDict[str, list] = OrderedDict()
    for c in checks:
        suites.setdefault(_suite_of(c.name), []).append(c)
    counts = count(checks)
    root = ET.Element("testsuites", name="crankfmu validate", tests=str(len(checks)),
                      failures=str(counts["failed"]), errors="0",
                      skipped=str(len(checks) - counts["passed"] - counts["failed"]), time=f"{elapsed:.3f}")
    for suite, items in suites.items():
        c_suite = count(items)
        node = ET.SubElement(root, "testsuite", name=suite, tests=str(len(items)), failures=str(c_suite["failed"]),
                             errors="0", skipped=str(len(items) - c_suite["passed"] - c_suite["failed"]))
        for c in items:
            case = ET.SubElement(node, "testcase", classname=suite, name=c.name[len(suite) + 1:] or c.name)
            text = c.line() + (f"\n{c.note}" if c.note else "")
            if c.status == "failed":
                ET.SubElement(case, "failure", message=c.line()[:500], type="failed").text = text
            elif c.status != "passed":
                ET.SubElement(case, "skipped", message=f"{c.status}: {(c.note or c.line())[:500]}",
                              type=c.status.replace(" ", "_"))
            if c.note and c.status == "passed":
                ET.SubElement(case, "system-out").text = c.note
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def write_junit(path, checks, elapsed: float):
    return write_text(path, junit_xml(checks, elapsed))
