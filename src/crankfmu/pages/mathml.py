"""Equations as MathML, which browsers render without any script or font from the network.

An equation is written once, as the expression text crankfmu's data files use (``l1*u(phi1) +
l2*u(phi2) - l0*u(0)``), or as the documentation's own statement of a model equation
(``J(phi1)*der(omega1) + 0.5*J_prime(phi1)*omega1**2 == M_motor + Q + tau_e``), and turned into
MathML here: names become symbols (``phi1`` is phi with subscript 1, ``omega_switch`` is omega
with subscript switch), ``der(x)`` the time derivative, ``dx(f)`` the partial derivative along x, ``a/b`` a fraction, ``a**b`` a power.
"""

from __future__ import annotations

import ast
import html
import re

GREEK = {"alpha": "α", "beta": "β", "gamma": "γ", "delta": "δ", "epsilon": "ε", "eps": "ε", "theta": "θ",
         "lambda": "λ", "mu": "μ", "nu": "ν", "rho": "ρ", "sigma": "σ", "tau": "τ", "phi": "φ", "psi": "ψ", "omega": "ω",
         "pi": "π", "Delta": "Δ", "Omega": "Ω"}
RELATIONS = {ast.Eq: "=", ast.LtE: "≤", ast.GtE: "≥", ast.Lt: "<", ast.Gt: ">", ast.NotEq: "≠"}
OPERATORS = {ast.Add: "+", ast.Sub: "−", ast.Mult: "\u2062"}         # invisible times between factors
PRECEDENCE = {ast.Add: 1, ast.Sub: 1, ast.Mult: 2, ast.Div: 2, ast.Pow: 3}


def is_word(name: str) -> bool:
    """A name written as a word (``pitman``, ``crank_R``, ``I_dist``'s ``I`` is a letter): its base
    is neither one letter nor a Greek letter's name, so it is set upright as written, without a
    subscript (``crank`` sub R reads as a product of letters)."""
    base = name[:-6] if name.endswith("_prime") else name
    base = re.sub(r"\d+$", "", base.partition("_")[0])
    return len(base) > 1 and base not in GREEK


def symbol(name: str) -> str:
    """``phi1`` -> phi sub 1, ``omega_switch`` -> omega sub switch, ``J_prime`` -> J', ``A_low`` ->
    A sub low; a word (``is_word``) as written: ``crank_R``, ``pitman``."""
    if is_word(name):
        return f'<mi mathvariant="normal">{html.escape(name)}</mi>'
    if name.endswith("_prime"):
        return f"<msup>{symbol(name[:-6])}<mo>′</mo></msup>"
    base, _, sub = name.partition("_")
    if not sub:
        m = re.fullmatch(r"([A-Za-z]+?)(\d+)", name)
        if m:
            base, sub = m.groups()
    letters = GREEK.get(base, base)
    head = f"<mi>{html.escape(letters)}</mi>"
    if sub:
        sub_text = "".join(GREEK.get(part, part) for part in re.split(r"(_)", sub) if part != "_")
        sub_el = f"<mn>{sub_text}</mn>" if sub_text.isdigit() else f"<mi>{html.escape(sub_text)}</mi>"
        return f"<msub>{head}{sub_el}</msub>"
    return head


def _node(n, parent: int = 0) -> str:
    if isinstance(n, ast.Expression):
        return _node(n.body)
    if isinstance(n, ast.Name):
        return symbol(n.id)
    if isinstance(n, ast.Constant):
        return f"<mn>{html.escape(repr(n.value))}</mn>"
    if isinstance(n, ast.UnaryOp) and isinstance(n.op, ast.USub):
        return f"<mrow><mo>−</mo>{_node(n.operand, 3)}</mrow>"
    if isinstance(n, ast.BinOp):
        op, level = type(n.op), PRECEDENCE.get(type(n.op), 3)
        if op is ast.Div:
            return f"<mfrac><mrow>{_node(n.left)}</mrow><mrow>{_node(n.right)}</mrow></mfrac>"
        if op is ast.Pow:
            return f"<msup><mrow>{_node(n.left, 4)}</mrow><mrow>{_node(n.right)}</mrow></msup>"
        # a product's factor that is a sum needs brackets; so does a subtrahend that is a sum
        right_level = level + 1 if op is ast.Sub else level
        sign = OPERATORS[op]
        if op is ast.Mult and any(isinstance(f, ast.Name) and is_word(f.id) for f in (n.left, n.right)):
            sign = "⋅"             # a word beside a factor needs a visible product: pitman u(phi_p) read "pitmanu"
        inner = f"{_node(n.left, level)}<mo>{sign}</mo>{_node(n.right, right_level)}"
        return f"<mrow><mo>(</mo>{inner}<mo>)</mo></mrow>" if level < parent else f"<mrow>{inner}</mrow>"
    if isinstance(n, ast.Call) and isinstance(n.func, ast.Name):
        name, args = n.func.id, n.args
        if name == "der" and len(args) == 1:
            return f"<mfrac><mrow><mi>d</mi>{_node(args[0], 3)}</mrow><mrow><mi>d</mi><mi>t</mi></mrow></mfrac>"
        if name == "dx" and len(args) == 1:          # a partial derivative along x
            return f"<mrow><mfrac><mo>∂</mo><mrow><mo>∂</mo><mi>x</mi></mrow></mfrac><mo>(</mo>{_node(args[0])}<mo>)</mo></mrow>"
        if name == "sqrt" and len(args) == 1:
            return f"<msqrt>{_node(args[0])}</msqrt>"
        if name == "abs" and len(args) == 1:
            return f"<mrow><mo>|</mo>{_node(args[0])}<mo>|</mo></mrow>"
        if name == "sum" and len(args) == 1:
            return f"<mrow><munder><mo>∑</mo><mi>j</mi></munder>{_node(args[0], 2)}</mrow>"
        inner = "<mo>,</mo>".join(_node(a) for a in args)
        return f"<mrow>{symbol(name)}<mo>\u2061</mo><mo>(</mo>{inner}<mo>)</mo></mrow>"
    if isinstance(n, ast.Compare):
        parts = [_node(n.left)]
        for op, right in zip(n.ops, n.comparators):
            parts.append(f"<mo>{RELATIONS[type(op)]}</mo>{_node(right)}")
        return f"<mrow>{''.join(parts)}</mrow>"
    raise ValueError(f"no MathML for {ast.dump(n)}")


def math(text: str, display: bool = True) -> str:
    """The expression or equation ``text`` as one MathML ``<math>`` element."""
    tree = ast.parse(text.strip(), mode="eval")
    mode = ' display="block"' if display else ""
    return f'<math{mode}><semantics>{_node(tree)}<annotation encoding="text/plain">{html.escape(text.strip())}' \
           f"</annotation></semantics></math>"
