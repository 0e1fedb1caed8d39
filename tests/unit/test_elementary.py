"""fmu_numerics.elementary: within 1 ulp of the exact value (numpy's 64-bit-mantissa long double as the
reference, 2^-11 ulp of a double), C99's special values, the symmetries, the constants exactly as
docs/elementary_coefficients.py derives them, and the compiled module giving the Python module's bits."""
from __future__ import annotations

import importlib.util
import math
import os
import platform
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, strategies as st

from fmu_numerics import elementary as el
from orchestration.fmu_build import compiled
from support.interpreted import interpreted

ROOT = Path(__file__).resolve().parents[2]
LD = np.longdouble
needs_reference = pytest.mark.skipif(np.finfo(LD).nmant < 63,
                                     reason="numpy's long double is no wider than a double here: no reference")
INF, NAN = math.inf, math.nan

# name -> (reference on long doubles, ranges of arguments)
UNARY = {
    "exp": (np.exp, ((-708.0, 709.7), (-1.0, 1.0))),
    "log": (np.log, ((1e-300, 1e300), (0.5, 2.0))),
    "log1p": (np.log1p, ((-0.999, 3.0), (-1e-3, 1e-3), (3.0, 1e10))),
    "tanh": (np.tanh, ((-25.0, 25.0), (-1.2, 1.2))),
    "sinh": (np.sinh, ((-710.0, 710.0), (-2.0, 2.0))),
    "cosh": (np.cosh, ((-710.0, 710.0), (-2.0, 2.0))),
    "sin": (np.sin, ((-1e4, 1e4), (-4.0, 4.0), (1e6, 1e7))),
    "cos": (np.cos, ((-1e4, 1e4), (-4.0, 4.0), (1e6, 1e7))),
    "atanh": (np.arctanh, ((-0.9999, 0.9999), (-0.6, 0.6))),
    "acos": (np.arccos, ((-1.0, 1.0),)),
}
BINARY = {"atan2": np.arctan2, "hypot": np.hypot}


def points(lo: float, hi: float, n: int) -> np.ndarray:
    """n points spread over [lo, hi] by the golden-ratio (Weyl) sequence: deterministic, no random draw."""
    i = np.arange(1, n + 1, dtype=np.float64)
    return lo + (hi - lo) * ((i * 0.6180339887498949) % 1.0)


def ulp_errors(ours: np.ndarray, exact: np.ndarray) -> np.ndarray:
    """|ours - exact| in ulps of the exact value (the smaller ulp at a power of two). An inf is exact where
    the exact value rounds to it (half an ulp beyond the largest double), else it counts as 2^1024."""
    big = LD(np.finfo(np.float64).max)
    a = np.minimum(np.abs(exact), big).astype(np.float64)
    ulp = np.spacing(np.nextafter(a, 0.0))  # the predecessor's: the smaller ulp at a power of two
    overflows = np.abs(exact) >= big + LD(2.0) ** 970
    ours = np.where(np.isinf(ours), np.where(overflows, exact, np.sign(ours) * LD(2.0) ** 1024), ours.astype(LD))
    with np.errstate(invalid="ignore"):  # inf - inf where both are the same infinity: no error
        error = np.abs(ours - exact) / np.maximum(ulp, np.spacing(0.0)).astype(LD)
    return np.where(ours == exact, 0.0, error).astype(np.float64)


# sin and cos reduce an argument beyond 2^20 (most of this range) in exact integer arithmetic (elementary_big),
# 25 times slower per call than in the other ranges: at a million points per range it gets a tenth (10 s less)
SLOW_RANGE = (1e6, 1e7)


def largest_errors(module, n: int, slow_range: int | None = None) -> dict[str, float]:
    """The largest error in ulps of each function of ``module`` over n points per range (``slow_range`` points,
    if given, in ``SLOW_RANGE``)."""
    out = {}
    for name, (exact, ranges) in UNARY.items():
        f = getattr(module, name)
        x = np.concatenate([points(lo, hi, slow_range if slow_range and (lo, hi) == SLOW_RANGE else n)
                            for lo, hi in ranges])
        out[name] = float(ulp_errors(np.array([f(v) for v in x]), exact(x.astype(LD))).max())
    y, x = points(-5.0, 5.0, n), points(-5.0, 5.0, 7 * n + 3)[:n][::-1]
    for name, exact in BINARY.items():
        f = getattr(module, name)
        out[name] = float(ulp_errors(np.array([f(a, b) for a, b in zip(y, x)]), exact(y.astype(LD), x.astype(LD))).max())
    return out


@needs_reference
def test_within_one_ulp_on_ten_thousand_points():
    errors = largest_errors(el, 10_000)
    assert max(errors.values()) <= 1.0, errors


def _loaded(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def compiled_module(tmp_path: Path):
    """elementary.py compiled by the cores' own compile step (orchestration/fmu_build/compiled.py)."""
    reason = compiled.unavailable()
    if reason:
        pytest.skip(f"cannot compile: {reason}")
    lib = tmp_path / "lib" / "fmu_numerics"
    lib.mkdir(parents=True)
    for package in (lib.parent, lib):
        (package / "__init__.py").write_text("")
    shutil.copy(ROOT / "fmu_numerics/elementary.py", lib)
    pxd = {"fmu_numerics/elementary.pxd": (ROOT / "fmu_numerics/elementary.pxd").read_text()}
    original = compiled.HOT
    compiled.HOT = ("fmu_numerics/elementary.py",)
    try:
        compiled.compile_bundle(tmp_path, "lib", pxd)
    finally:
        compiled.HOT = original
    so = next(lib.glob("elementary.*.so"), None) or next(lib.glob("elementary.*.pyd"))
    return _loaded("lib.fmu_numerics.elementary", so)


def compiled_or_built(tmp_path: Path):
    """The installed compiled module where the package is compiled (as in CI), else one compiled here."""
    return el if not el.__file__.endswith(".py") else compiled_module(tmp_path)


@pytest.mark.slow
@needs_reference
def test_compiled_gives_the_python_bits_and_a_million_points_within_one_ulp(tmp_path):
    """The compiled module against the ``.py`` source's (loaded as such whatever the installed build)."""
    c, (py,) = compiled_or_built(tmp_path), interpreted("fmu_numerics.elementary")
    x = np.concatenate([points(-40.0, 40.0, 20_000), points(-1e7, 1e7, 2_000),
                        [0.0, -0.0, 5e-324, 1e-300, 0.9999999999, -0.5, 709.9, 710.3, -745.0, INF, -INF, NAN]])
    for name in UNARY:
        ours, theirs = np.array([getattr(c, name)(v) for v in x]), np.array([getattr(py, name)(v) for v in x])
        assert ours.tobytes() == theirs.tobytes(), name
    assert np.array([c.sincos(v) for v in x]).tobytes() == np.array([py.sincos(v) for v in x]).tobytes()
    for name in BINARY:
        ours = np.array([getattr(c, name)(a, b) for a, b in zip(x, x[::-1])])
        assert ours.tobytes() == np.array([getattr(py, name)(a, b) for a, b in zip(x, x[::-1])]).tobytes(), name
    errors = largest_errors(c, 1_000_000, slow_range=100_000)
    print("largest error (ulp) over 10^6 points per range:", {k: round(v, 3) for k, v in errors.items()})
    assert max(errors.values()) <= 1.0, errors


DIGEST = """
import hashlib, struct, sys
from fmu_numerics import elementary as el
x = [-20.0 + 40.0 * ((i * 0.6180339887498949) % 1.0) for i in range(1, 20001)]
d = hashlib.sha256()
for name in ("exp", "log1p", "tanh", "sinh", "cosh", "sin", "cos", "atanh", "acos"):
    f = getattr(el, name)
    d.update(struct.pack("20000d", *[f(v / 20.0 if name in ("atanh", "acos") else abs(v) if name == "log1p" else v)
                                       for v in x]))
d.update(struct.pack("20000d", *[el.atan2(v, 1.5) + el.hypot(v, 0.3) for v in x]))
print(d.hexdigest())
"""


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="GLIBC_TUNABLES selects glibc's code paths only")
def test_the_same_bits_when_glibc_takes_its_paths_without_fma():
    """glibc's own exp, sin ... change bits under these tunables (docs/paper-notes.md 2.10b); ours must not."""
    def digest(extra: dict[str, str]) -> str:
        env = {**os.environ, "PYTHONPATH": str(ROOT), **extra}
        return subprocess.run([sys.executable, "-c", DIGEST], env=env, capture_output=True, text=True,
                              check=True, timeout=300).stdout.strip()

    assert digest({}) == digest({"GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX,-AVX512F"})


SPECIAL = [
    ("exp", (NAN,), NAN), ("exp", (INF,), INF), ("exp", (-INF,), 0.0), ("exp", (710.0,), INF),
    ("exp", (-746.0,), 0.0), ("exp", (-0.0,), 1.0),
    ("log", (0.0,), -INF), ("log", (-1.0,), NAN), ("log", (INF,), INF), ("log", (1.0,), 0.0),
    ("log1p", (-1.0,), -INF), ("log1p", (-2.0,), NAN), ("log1p", (-0.0,), -0.0), ("log1p", (INF,), INF),
    ("tanh", (INF,), 1.0), ("tanh", (-INF,), -1.0), ("tanh", (-0.0,), -0.0), ("tanh", (NAN,), NAN),
    ("sinh", (-INF,), -INF), ("sinh", (711.0,), INF), ("sinh", (-0.0,), -0.0),
    ("cosh", (-INF,), INF), ("cosh", (-711.0,), INF), ("cosh", (0.0,), 1.0),
    ("sin", (INF,), NAN), ("sin", (-0.0,), -0.0), ("cos", (-INF,), NAN), ("cos", (-0.0,), 1.0),
    ("atanh", (1.0,), INF), ("atanh", (-1.0,), -INF), ("atanh", (1.5,), NAN), ("atanh", (-0.0,), -0.0),
    ("acos", (1.0,), 0.0), ("acos", (-1.0,), math.pi), ("acos", (1.5,), NAN), ("acos", (NAN,), NAN),
    ("atan2", (0.0, -0.0), math.pi), ("atan2", (-0.0, -0.0), -math.pi), ("atan2", (-0.0, 0.0), -0.0),
    ("atan2", (0.0, 1.0), 0.0), ("atan2", (1.0, 0.0), math.pi / 2), ("atan2", (-1.0, -0.0), -math.pi / 2),
    ("atan2", (INF, INF), math.pi / 4), ("atan2", (-INF, -INF), -3 * math.pi / 4), ("atan2", (1.0, -INF), math.pi),
    ("atan2", (-1.0, INF), -0.0), ("atan2", (NAN, 1.0), NAN),
    ("hypot", (INF, NAN), INF), ("hypot", (NAN, 1.0), NAN), ("hypot", (-0.0, 0.0), 0.0),
    ("hypot", (3e300, 4e300), 5e300), ("hypot", (3e-320, 4e-320), 5e-320),
]


@pytest.mark.parametrize("name, args, expected", SPECIAL)
def test_special_values(name, args, expected):
    got = getattr(el, name)(*args)
    if math.isnan(expected):
        assert math.isnan(got)
    else:
        assert got == expected and math.copysign(1.0, got) == math.copysign(1.0, expected)


FINITE = st.floats(allow_nan=False, allow_infinity=False)


@given(FINITE)
def test_odd_and_even(x):
    for name in ("sin", "tanh", "sinh"):
        f = getattr(el, name)
        assert f(-x) == -f(x)
    assert el.cos(-x) == el.cos(x) and el.cosh(-x) == el.cosh(x)
    assert -1.0 <= el.sin(x) <= 1.0 and -1.0 <= el.cos(x) <= 1.0 and -1.0 <= el.tanh(x) <= 1.0
    assert el.atan2(-x, 1.0) == -el.atan2(x, 1.0) and el.hypot(x, 1.0) == el.hypot(-x, -1.0)


@given(st.one_of(st.floats(), st.floats(-4.0, 4.0), st.sampled_from([math.pi / 4, 2.0**20, 2.0**-27, 2.5e6])))
def test_sincos_is_sin_and_cos_to_the_bit(x):
    """One reduction for both (the plant's right-hand side) gives each function's own bits, nan and inf included."""
    s, c = el.sincos(x)
    assert np.array([s, c]).tobytes() == np.array([el.sin(x), el.cos(x)]).tobytes()


@needs_reference
@given(st.one_of(st.floats(-745.0, 709.78), st.floats(-1e-6, 1e-6), st.sampled_from([709.782712893384, -708.39])))
def test_exp_edges_within_one_ulp(x):
    assert ulp_errors(np.array([el.exp(x)]), np.exp(np.array([x], dtype=LD)))[0] <= 1.0


@needs_reference
@given(st.one_of(st.floats(-1e300, 1e300), st.floats(-1e-300, 1e-300), st.floats(2.0**19, 2.0**21)))
def test_sin_cos_edges_within_one_ulp(x):
    """Across the medium reduction's limit 2^20 and over the whole range (the exact fallback)."""
    a = np.array([x], dtype=LD)
    assert ulp_errors(np.array([el.sin(x)]), np.sin(a))[0] <= 1.0
    assert ulp_errors(np.array([el.cos(x)]), np.cos(a))[0] <= 1.0


@needs_reference
@given(st.floats(5e-324, 1e308), st.floats(-1.0 + 2.0**-53, 1e300))
def test_log_edges_within_one_ulp(x, y):
    """Subnormal to huge arguments of log, and log1p from just above -1."""
    assert ulp_errors(np.array([el.log(x)]), np.log(np.array([x], dtype=LD)))[0] <= 1.0
    assert ulp_errors(np.array([el.log1p(y)]), np.log1p(np.array([y], dtype=LD)))[0] <= 1.0


@needs_reference
@given(FINITE, FINITE)
def test_atan2_and_hypot_within_one_ulp_over_the_whole_range(y, x):
    """Huge and tiny arguments alike (the exact scalings; Veltkamp's split must not overflow)."""
    a, b = np.array([y], dtype=LD), np.array([x], dtype=LD)
    assert ulp_errors(np.array([el.hypot(y, x)]), np.hypot(a, b))[0] <= 1.0
    if y != 0.0 or x != 0.0:
        assert ulp_errors(np.array([el.atan2(y, x)]), np.arctan2(a, b))[0] <= 1.0


def test_constants_are_the_derived_ones():
    """On the ``.py`` itself: where the installed package is compiled, its constants are C variables."""
    derived = _loaded("elementary_coefficients", ROOT / "docs/elementary_coefficients.py").constants()
    source = _loaded("elementary_source", ROOT / "fmu_numerics/elementary.py")
    assert {name: getattr(source, name) for name in derived} == derived
    big = _loaded("elementary_big_source", ROOT / "fmu_numerics/elementary_big.py")
    assert abs(big.PIO2_BIG - big._pi_scaled(big.BIG_BITS + 8) // 512) <= 4  # Machin's truncation: a few units at most
