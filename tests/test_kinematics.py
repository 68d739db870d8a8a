"""The contour engine against the paper's numbers and against independent methods."""

import math
from importlib.resources import files

import numpy as np
import pytest

from crankfmu.dynamics import rocker_extremes
from crankfmu.errors import AssemblyError
from crankfmu.mechanisms import Mechanism, load_mechanism

GEOMETRY = dict(l0=0.75, l1=0.2, l2=0.5, l3=0.55, q1=5.5, q2=4.0, q3=3.75)
ANGLES = np.radians(np.arange(360) + 0.5)   # 360 angles, none exactly on a grid point of the engine


@pytest.fixture(scope="module")
def fourbar():
    return Mechanism(load_mechanism("fourbar"), GEOMETRY)


def independent_fourbar(phi1, l0=0.75, l1=0.2, l2=0.5, l3=0.55):
    """B as the intersection of two circles, written here without the engine."""
    ax, ay = l1 * np.cos(phi1), l1 * np.sin(phi1)
    dx, dy = l0 - ax, -ay
    d = np.hypot(dx, dy)
    a = (l2**2 - l3**2 + d**2) / (2 * d)          # distance from A along A->C to the chord
    h = np.sqrt(l2**2 - a**2)
    # B on the left of A->C: rotate the unit vector A->C by +90 deg
    bx = ax + a * dx / d - h * dy / d
    by = ay + a * dy / d + h * dx / d
    phi2 = np.arctan2(by - ay, bx - ax)
    phi3 = np.arctan2(0 - by, l0 - bx)
    return phi2, phi3, (bx, by)


def test_rocker_extremes_match_the_paper(fourbar):
    phi1d, phi1a = rocker_extremes(fourbar, "rocker")
    assert math.degrees(phi1d) == pytest.approx(44.415, abs=1e-3)
    assert math.degrees(phi1a) == pytest.approx(218.942, abs=1e-3)


def test_rocker_extremes_are_where_crank_and_coupler_are_collinear(fourbar):
    """The paper's definition: AB prolongs OA at phi1d and overlaps it at phi1a."""
    phi1d, phi1a = rocker_extremes(fourbar, "rocker")
    for angle, same_direction in ((phi1d, True), (phi1a, False)):
        phi2 = fourbar.kinematics(angle).q["phi2"][0]
        cross = math.sin(phi2 - angle)
        dot = math.cos(phi2 - angle)
        assert abs(cross) < 1e-12
        assert (dot > 0) == same_direction


def test_closed_form_matches_independent_geometry(fourbar):
    phi2, phi3, (bx, by) = independent_fourbar(ANGLES)
    kin = fourbar.kinematics(ANGLES)
    wrap = lambda a: (a + np.pi) % (2 * np.pi) - np.pi  # noqa: E731
    assert np.max(np.abs(wrap(kin.q["phi2"] - phi2))) < 1e-13
    assert np.max(np.abs(wrap(kin.q["phi3"] - phi3))) < 1e-13
    B = kin.point("B")
    assert np.max(np.hypot(B[0] - bx, B[1] - by)) < 1e-14
    # the branch: B on the left of A->C at every angle, above the x axis at phi1 = 0
    A, C = kin.point("A"), (0.75, 0.0)
    cross = (C[0] - A[0]) * (B[1] - A[1]) - (C[1] - A[1]) * (B[0] - A[0])
    assert np.all(cross > 0)
    assert fourbar.kinematics(0.0).point("B")[1][0] > 0


def _central(f, x, h):
    """4th-order central differences of f: (first, second) derivative."""
    fm2, fm1, f0, fp1, fp2 = (f(x + k * h) for k in (-2, -1, 0, 1, 2))
    d1 = (fm2 - 8 * fm1 + 8 * fp1 - fp2) / (12 * h)
    d2 = (-fm2 + 16 * fm1 - 30 * f0 + 16 * fp1 - fp2) / (12 * h * h)
    return d1, d2


def test_transfer_functions_against_finite_differences(fourbar):
    """Analytic first and second derivatives (linear solves) against 4th-order central differences
    of the independent circle-intersection positions, at 360 angles.

    Tolerance 1e-7 relative to each function's amplitude over the turn: with h = 1e-3 the
    truncation error is ~h^4 |f^(5)| ~ 1e-11 and round-off ~ 1e-16/h^2 ~ 1e-10, well inside it.
    """
    kin = fourbar.kinematics(ANGLES)
    h = 1e-3
    checks = {
        "phi2": lambda x: independent_fourbar(x)[0],
        "phi3": lambda x: independent_fourbar(x)[1],
    }
    for name, f in checks.items():
        # difference the angle relative to its value at x to avoid the +-pi wrap
        g = lambda x, f=f: np.angle(np.exp(1j * (f(x) - f(ANGLES))))  # noqa: E731
        d1, d2 = _central(g, ANGLES, h)
        for analytic, numeric in ((kin.dq[name], d1), (kin.ddq[name], d2)):
            scale = np.max(np.abs(analytic))
            assert np.max(np.abs(analytic - numeric)) < 1e-7 * scale, name
    # mass centres: C2 = A + AB/2, C3 = B + BC/2 written independently
    def centres(x):
        phi2, phi3, (bx, by) = independent_fourbar(x)
        ax, ay = 0.2 * np.cos(x), 0.2 * np.sin(x)
        return {"C1": (0.1 * np.cos(x), 0.1 * np.sin(x)),
                "C2": (ax + 0.25 * np.cos(phi2), ay + 0.25 * np.sin(phi2)),
                "C3": (bx + 0.275 * np.cos(phi3), by + 0.275 * np.sin(phi3))}
    for point in ("C1", "C2", "C3"):
        x, y, t, p, tt, pp = kin.point(point)
        for axis, (d, dd) in ((0, (t, tt)), (1, (p, pp))):
            d1, d2 = _central(lambda a: centres(a)[point][axis], ANGLES, h)
            for analytic, numeric in ((d, d1), (dd, d2)):
                scale = np.max(np.abs(analytic))
                assert np.max(np.abs(analytic - numeric)) < 1e-7 * scale, point


def test_newton_path_equals_closed_form():
    """The engine without the file's closed form (Newton continuation from the assembly guess)
    lands on the same branch and the same transfer functions."""
    definition = load_mechanism("fourbar")
    closed = Mechanism(definition, GEOMETRY).kinematics(ANGLES)
    newton = Mechanism(definition, GEOMETRY, use_closed_form=False).kinematics(ANGLES)
    wrap = lambda a: (a + np.pi) % (2 * np.pi) - np.pi  # noqa: E731
    for u in ("phi2", "phi3"):
        assert np.max(np.abs(wrap(closed.q[u] - newton.q[u]))) < 1e-12
        assert np.max(np.abs(closed.dq[u] - newton.dq[u])) < 1e-10
        assert np.max(np.abs(closed.ddq[u] - newton.ddq[u])) < 1e-9


def test_conditioning_is_the_transmission_angle_sine(fourbar):
    kin = fourbar.kinematics(ANGLES)
    expected = np.abs(np.sin(kin.q["phi3"] - kin.q["phi2"]))
    assert np.max(np.abs(fourbar.conditioning(ANGLES) - expected)) < 1e-12


def test_worst_conditioning_matches_a_dense_independent_scan(fourbar):
    """check_assembly's worst conditioning (0.25 deg scan, one refinement between scan angles) is the
    smallest |sin(phi3 - phi2)| of the independent geometry on 200,000 angles; its error is the
    refinement's, about half the curvature times (step / 2)^2, 3e-9."""
    worst, at = fourbar.check_assembly()
    phi1 = np.linspace(0.0, 2 * np.pi, 200_000, endpoint=False)
    phi2, phi3, _ = independent_fourbar(phi1)
    dense = np.abs(np.sin(phi3 - phi2))
    assert worst == pytest.approx(dense.min(), abs=1e-8)
    assert abs(at - phi1[np.argmin(dense)]) < 1e-3


def test_a_closed_form_that_jumps_between_branches_is_refused_where_it_jumps(tmp_path):
    """Both assembly branches satisfy the contour equations, so only the conditioning's change of
    sign shows a closed form that swaps them mid-turn (here at 100.1 deg, between scan angles)."""
    text = ((files("crankfmu.mechanisms") / "files" / "fourbar.toml").read_text()
            .replace("branch*acos", "sign(radians(100.1) - phi1)*acos"))
    (tmp_path / "jumping.toml").write_text(text)
    with pytest.raises(AssemblyError, match=r"at phi1 = 100\.100 deg the mechanism passes a dead point"):
        Mechanism(load_mechanism(str(tmp_path / "jumping.toml")), GEOMETRY).check_assembly()
