"""SI units as data files write them, read into their base-unit exponents: the one home of every
unit crankfmu declares (a parameter's, an output's, the contract's) and of the exponents written
into an FMU's ``UnitDefinitions``.

The grammar is Modelica's unit syntax (Modelica Language Specification, section 19.1), which FMI
2.0 uses for its unit names, with ``*`` and ``^`` also accepted::

    unit        = numerator [ "/" denominator ]
    numerator   = "1" | factors | "(" unit ")"
    denominator = factor | "(" unit ")"
    factors     = factor { ("." | "*") factor }
    factor      = symbol [ ["^"] exponent ] | "(" unit ")" [ ["^"] exponent ]
    exponent    = [ "+" | "-" ] digits

so ``N.m/rad``, ``N/m``, ``kg.m2``, ``m/s2``, ``1/s``, ``N.m.s/rad`` and ``V/(rad/s)`` read as
written. One ``/`` at most, its denominator a single factor: ``J/kg.K`` is refused (Modelica reads
neither ``(J/kg).K`` nor ``J/(kg.K)`` from it) with the parenthesised spelling suggested.

The symbols are the SI base units and the coherent derived units with special names; ``rad`` is
kept as its own dimension because FMI 2.0 declares it as a base unit (a torque N.m and a
stiffness N.m/rad stay apart). Decimal prefixes (``mm``, ``kN``, ``g``) are refused: crankfmu's
files are SI by design, so a value is written in the coherent unit instead.
"""

from __future__ import annotations

import math
import re
from functools import lru_cache

from .errors import DefinitionError

#: FMI 2.0's BaseUnit exponents (fmi2ModelDescription, UnitDefinitions), in its order
BASE = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")


def _dims(**exponents) -> tuple[int, ...]:
    return tuple(exponents.get(b, 0) for b in BASE)


#: each symbol's exponents of BASE: the SI base units, then the derived units with special names
#: (SI Brochure, 9th edition, tables 2 and 4), each from its definition
SYMBOLS: dict[str, tuple[int, ...]] = {
    "kg": _dims(kg=1), "m": _dims(m=1), "s": _dims(s=1), "A": _dims(A=1), "K": _dims(K=1),
    "mol": _dims(mol=1), "cd": _dims(cd=1), "rad": _dims(rad=1),
    "sr": _dims(),                                  # steradian: m2/m2
    "Hz": _dims(s=-1),                              # 1/s
    "N": _dims(kg=1, m=1, s=-2),                    # kg.m/s2
    "Pa": _dims(kg=1, m=-1, s=-2),                  # N/m2
    "J": _dims(kg=1, m=2, s=-2),                    # N.m
    "W": _dims(kg=1, m=2, s=-3),                    # J/s
    "C": _dims(A=1, s=1),                           # A.s
    "V": _dims(kg=1, m=2, s=-3, A=-1),              # W/A
    "F": _dims(kg=-1, m=-2, s=4, A=2),              # C/V
    "Ohm": _dims(kg=1, m=2, s=-3, A=-2),            # V/A
    "S": _dims(kg=-1, m=-2, s=3, A=2),              # A/V
    "Wb": _dims(kg=1, m=2, s=-2, A=-1),             # V.s
    "T": _dims(kg=1, s=-2, A=-1),                   # Wb/m2
    "H": _dims(kg=1, m=2, s=-2, A=-2),              # Wb/A
}

#: decimal prefixes, for the refusal's message only (SI Brochure, table 7)
PREFIXES = {"Y": "1e24", "Z": "1e21", "E": "1e18", "P": "1e15", "T": "1e12", "G": "1e9", "M": "1e6",
            "k": "1e3", "h": "1e2", "da": "1e1", "d": "1e-1", "c": "1e-2", "m": "1e-3", "u": "1e-6",
            "\u00b5": "1e-6", "n": "1e-9", "p": "1e-12", "f": "1e-15", "a": "1e-18"}

#: common non-SI units a user may try, with what to write instead
NOT_SI = {"g": "kg", "deg": "rad", "rpm": "rad/s", "min": "s", "h": "s", "l": "m3", "L": "m3",
          "bar": "Pa", "psi": "Pa", "lbf": "N", "lb": "kg", "in": "m", "ft": "m", "hp": "W",
          "degC": "K", "Nm": "N.m", "ohm": "Ohm"}

_TOKEN = re.compile(r"\s*(?:(?P<symbol>[A-Za-z\u00b5]+)|(?P<number>[+-]?\d+)|(?P<op>\*\*|[.*/^()]))")


class UnitError(DefinitionError):
    """A unit that cannot be read: the message says where in the text and what is valid."""


def _tokens(text: str) -> list[tuple[str, str, int]]:
    out, i = [], 0
    while i < len(text):
        m = _TOKEN.match(text, i)
        if not m or m.end() == i:
            if text[i:].strip() == "":
                break
            raise UnitError(f"unit {text!r}: unexpected {text[i:].strip()[0]!r} at position {i + 1}; "
                            "write products with '.', one '/', powers as digits (m2, s-1)")
        kind = m.lastgroup
        out.append((kind, m.group(kind), m.start(kind)))
        i = m.end()
    return out


def _symbol(name: str, text: str) -> tuple[int, ...]:
    if name in SYMBOLS:
        return SYMBOLS[name]
    if name in NOT_SI:
        raise UnitError(f"unit {text!r}: {name!r} is not an SI unit: write the value in {NOT_SI[name]}")
    for prefix in sorted(PREFIXES, key=len, reverse=True):
        rest = name[len(prefix):]
        if name.startswith(prefix) and (rest in SYMBOLS or rest == "g"):
            coherent = "kg" if rest == "g" else rest
            raise UnitError(f"unit {text!r}: {name!r} has the decimal prefix {prefix!r} ({PREFIXES[prefix]}); "
                            f"crankfmu's files are SI by design: write the value in {coherent}")
    raise UnitError(f"unit {text!r}: unknown symbol {name!r}; the symbols are {', '.join(SYMBOLS)} "
                    "(and 1 for a number)")


class _Parser:
    def __init__(self, text: str):
        self.text = text
        self.tokens = _tokens(text)
        self.i = 0

    def peek(self):
        return self.tokens[self.i] if self.i < len(self.tokens) else (None, None, len(self.text))

    def take(self):
        token = self.peek()
        self.i += 1
        return token

    def fail(self, what: str):
        kind, value, at = self.peek()
        found = f"{value!r} at position {at + 1}" if kind else "the end"
        raise UnitError(f"unit {self.text!r}: expected {what}, found {found}")

    def unit(self) -> tuple[int, ...]:
        num = self.numerator()
        if self.peek()[1] == "/":
            self.take()
            den = self.denominator()
            num = tuple(a - b for a, b in zip(num, den))
            if self.peek()[1] in (".", "*", "/"):
                op = self.peek()[1]
                raise UnitError(f"unit {self.text!r}: after '/' comes one factor; put a product or a second "
                                f"quotient of the denominator in parentheses (e.g. J/(kg.K)), found {op!r}")
        return num

    def numerator(self) -> tuple[int, ...]:
        kind, value, _ = self.peek()
        if kind == "number" and value == "1":
            self.take()
            return _dims()
        dims = self.factor()
        while self.peek()[1] in (".", "*"):
            self.take()
            dims = tuple(a + b for a, b in zip(dims, self.factor()))
        return dims

    def denominator(self) -> tuple[int, ...]:
        return self.factor()

    def factor(self) -> tuple[int, ...]:
        kind, value, _ = self.peek()
        if kind == "symbol":
            self.take()
            dims = _symbol(value, self.text)
        elif value == "(":
            self.take()
            dims = self.unit()
            if self.peek()[1] != ")":
                self.fail("')'")
            self.take()
        else:
            self.fail("a unit symbol or '('")
        power = self.exponent()
        return tuple(d * power for d in dims)

    def exponent(self) -> int:
        kind, value, _ = self.peek()
        if value in ("^", "**"):
            self.take()
            if self.peek()[0] != "number":
                self.fail("an integer exponent")
            return int(self.take()[1])
        if kind == "number":
            self.take()
            return int(value)
        return 1


@lru_cache(maxsize=512)
def exponents(text: str) -> tuple[int, ...]:
    """The exponents of BASE of ``text`` (``"N.m/rad"`` -> kg 1, m 2, s -2, rad -1), or UnitError."""
    if not isinstance(text, str) or not text.strip():
        raise UnitError(f"unit {text!r}: empty; write 1 for a number without unit")
    parser = _Parser(text.strip())
    dims = parser.unit()
    if parser.i != len(parser.tokens):
        parser.fail("the end of the unit (a product is written with '.': N.m)")
    return dims


def fmi_name(text: str) -> str:
    """``text`` in Modelica's spelling, which FMI hosts parse: products with '.', powers as bare
    digits (``kg*m^2`` -> ``kg.m2``); a unit already so written is returned as it is."""
    exponents(text)
    return re.sub(r"\s+", "", text).replace("**", "").replace("^", "").replace("*", ".")


def base_units(text: str) -> dict[str, int]:
    """FMI 2.0's ``<BaseUnit>`` attributes of ``text``: the nonzero exponents of BASE."""
    return {b: e for b, e in zip(BASE, exponents(text)) if e}


def check_unit(text, where: str) -> str:
    """``text`` if it reads as a unit, else UnitError naming ``where`` (a file and parameter)."""
    try:
        exponents(text)
    except UnitError as exc:
        raise UnitError(f"{where}: {exc}") from None
    return text


_PREFIXES = {-3: "n", -2: "µ", -1: "m", 0: "", 1: "k", 2: "M", 3: "G"}


def engineering(value: float, unit: str, digits: int = 3) -> str:
    """``value`` with an SI prefix and ``digits`` significant digits, for people to read (figures'
    labels and titles; data files stay in coherent units): 1234 N -> "1.23 kN", 0.0315 m ->
    "31.5 mm", 1 m/s -> "1.00 m/s" (a reader compares magnitudes without exponents)."""
    value = float(value)
    if value == 0.0 or not math.isfinite(value):
        return f"{value:g} {unit}"
    value = float(f"{value:.{digits - 1}e}")          # rounded first: 999.7 N is 1.00 kN, not 1000 N
    power = max(-3, min(3, math.floor(math.log10(abs(value)) / 3)))
    scaled = value / 1000.0 ** power
    decimals = max(0, digits - 1 - math.floor(math.log10(abs(scaled))))
    return f"{scaled:.{decimals}f} {_PREFIXES[power]}{unit}"
