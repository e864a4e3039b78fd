"""The core's own elementary functions (native/src/ubmath.h): exp, log, pow, sin, cos, acos,
hypot, expf and fmaf, reached through the private probe unbound_core._native._math_probe.

Two promises, two kinds of test:
  * accuracy: each within 1 ulp of the true value (mpmath at 200 bits is the referee; the measured
    figures are far below, and the tolerances below are set near them so that a regression shows),
    fmaf correctly rounded (exact rational arithmetic, and the CPU's own FMA where there is one);
  * the same bits on every platform: ubmath_vectors.json holds inputs and outputs as hex bit
    patterns, asserted bit for bit. Only the standard library is needed for that check, so that it
    runs under wine (Windows) and qemu (arm64) too, as a script:
        python tests/native/test_ubmath.py [directory holding unbound_core]
    Re-record (only for a change meant to alter bits): UNBOUND_RECORD_GOLDEN=1 pytest this file."""
import json
import math
import os
import pathlib
import platform
import random
import shutil
import struct
import subprocess
import sys
from fractions import Fraction

VECTORS = pathlib.Path(__file__).with_name("ubmath_vectors.json")
RECORD = bool(os.environ.get("UNBOUND_RECORD_GOLDEN"))
ARITY = {"exp": 1, "log": 1, "sin": 1, "cos": 1, "acos": 1, "expf": 1, "pow": 2, "hypot": 2, "fmaf": 3}
INF, NAN = float("inf"), float("nan")


def probe(name, values):
    import unbound_core._native as native
    return native._math_probe(name, values)


def f32(x):
    """x rounded to float32 (struct's conversion is IEEE round to nearest; it refuses to overflow)."""
    try:
        return struct.unpack("<f", struct.pack("<f", x))[0]
    except OverflowError:
        return math.copysign(INF, x)


def f32_from_bits(bits):
    return struct.unpack("<f", struct.pack("<I", bits))[0]


def hex64(x):
    return "%016x" % struct.unpack("<Q", struct.pack("<d", x))[0]


def from_hex64(h):
    return struct.unpack("<d", struct.pack("<Q", int(h, 16)))[0]


# ------------------------------------------------------------------------- the inputs

# The ranges the core uses: fog exp(-density t) over (-inf, 0], glow expf(-steps/64) over
# [-max_steps/64, 0], normal_alpha t^delta with t >= 0 and delta in [0, 4], the sea's sin of
# 2 pi D / lambda (any size: tiny wavelengths, far points), the slice rotation's cos/sin of
# theta mod 2 pi, acos and cos of the symmetric 3x3 eigenvalues, hypot of c-path points within
# 1e3, the spot's cos(size/2) in [0, pi/2]; then everything else a double can be.
SPECIALS = [0.0, -0.0, INF, -INF, NAN, 5e-324, -5e-324, 2.2250738585072014e-308, 1.0, -1.0, 0.5, -0.5,
            2.0, math.pi / 4, math.pi / 2, math.pi, 709.782712893384, 709.79, -745.1332191019411,
            -745.1332191019412, -708.4, 1e-300, 1e300, 1.7976931348623157e308, 2.0 ** 20, 2.0 ** 20 - 1e-10,
            6381956970095103 * 2.0 ** 797, -6381956970095103 * 2.0 ** 797]  # the last: closest to k pi/2


def accuracy_inputs(rng, n):
    """name -> list of (range label, inputs)."""
    u = rng.uniform
    huge = [math.ldexp(u(1, 2), rng.randint(20, 1023)) * rng.choice((-1, 1)) for _ in range(n)]
    return {
        "exp": [("fog, glow: [-50, 0]", [u(-50, 0) for _ in range(n)]),
                ("[-708, 709.7]", [u(-708, 709.7) for _ in range(n)]),
                ("near 0", [u(-1e-6, 1e-6) for _ in range(n // 4)])],
        "exp subnormal": [("[-745, -708.4]", [u(-745, -708.4) for _ in range(n // 4)])],
        "log": [("[1e-300, 1e300]", [math.exp(u(-690, 690)) for _ in range(n)]),
                ("[0.5, 2]", [u(0.5, 2) for _ in range(n)]),
                ("near 1", [1 + u(-1e-6, 1e-6) for _ in range(n // 4)]),
                ("subnormal", [5e-324 * rng.randint(1, 2 ** 52) for _ in range(n // 4)])],
        "sin": [("[-2 pi, 2 pi]", [u(-7, 7) for _ in range(n)]),
                ("sea: [-1e6, 1e6]", [u(-1e6, 1e6) for _ in range(n)]),
                ("huge: 2^20 .. 2^1024", huge),
                ("tiny", [u(-1e-8, 1e-8) for _ in range(n // 4)])],
        "cos": [("[-2 pi, 2 pi]", [u(-7, 7) for _ in range(n)]),
                ("sea: [-1e6, 1e6]", [u(-1e6, 1e6) for _ in range(n)]),
                ("huge: 2^20 .. 2^1024", huge)],
        "acos": [("[-1, 1]", [u(-1, 1) for _ in range(n)]),
                 ("near +-1", [rng.choice((-1, 1)) * (1 - u(0, 1e-6)) for _ in range(n // 4)])],
        "hypot": [("c-path: [-2e3, 2e3]^2", [(u(-2e3, 2e3), u(-2e3, 2e3)) for _ in range(n)]),
                  ("any exponents", [(math.ldexp(u(-1, 1), rng.randint(-1074, 1023)),
                                      math.ldexp(u(-1, 1), rng.randint(-1074, 1023))) for _ in range(n)])],
        "pow": [("normals: t in [0, 1e3], delta in [0, 4]", [(u(0, 1e3), u(0, 4)) for _ in range(n)]),
                ("t in [e^-60, e^60], delta in [0, 4]", [(math.exp(u(-60, 60)), u(0, 4)) for _ in range(n)])],
        "pow |y| <= 64": [("x in [1/2, 2], y in [-64, 64]", [(u(0.5, 2), u(-64, 64)) for _ in range(n // 2)]),
                          ("x in [e^-700, e^700], y in [-1, 1]", [(math.exp(u(-700, 700)), u(-1, 1))
                                                                   for _ in range(n // 2)])],
    }


def accuracy_tolerance():
    """Largest error allowed (ulps of the double nearest the true value): the measured maxima
    plus a margin, all within the 1 ulp promised."""
    return {"exp": 0.55, "exp subnormal": 1.0, "log": 0.52, "sin": 0.6, "cos": 0.6, "acos": 0.6,
            "hypot": 0.51, "pow": 0.55, "pow |y| <= 64": 1.0}


def vector_inputs():
    """name -> inputs of the committed bit patterns: special values and a seeded spread over the
    ranges above (Python's random is the same on every platform, and the inputs are stored too)."""
    rng = random.Random(20240611)
    u = rng.uniform
    out = {}
    finite = [x for x in SPECIALS if math.isfinite(x)]
    out["exp"] = SPECIALS + [u(-50, 0) for _ in range(60)] + [u(-745, 709.7) for _ in range(40)]
    out["log"] = SPECIALS + [math.exp(u(-700, 700)) for _ in range(60)] + [u(0.5, 2) for _ in range(40)]
    for name in ("sin", "cos"):
        out[name] = SPECIALS + [u(-7, 7) for _ in range(40)] + [u(-1e6, 1e6) for _ in range(30)] + [
            math.ldexp(u(1, 2), rng.randint(20, 1023)) * rng.choice((-1, 1)) for _ in range(30)]
    out["acos"] = SPECIALS + [u(-1, 1) for _ in range(80)] + [1 - u(0, 1e-6) for _ in range(10)] + [
        u(-1e-6, 0) - 1 + 1e-6 for _ in range(10)]
    out["expf"] = [f32(x) for x in SPECIALS] + [f32(-rng.randint(0, 5000) / 64) for _ in range(60)] + [
        f32(u(-103, 88.7)) for _ in range(40)]
    out["hypot"] = [(x, y) for x in finite[:8] + [INF, NAN] for y in (0.0, -3.0, 1e300, NAN)] + [
        (u(-2e3, 2e3), u(-2e3, 2e3)) for _ in range(60)] + [
        (math.ldexp(u(-1, 1), rng.randint(-1074, 1023)), math.ldexp(u(-1, 1), rng.randint(-1074, 1023)))
        for _ in range(30)]
    out["pow"] = [(x, y) for x in (0.0, 5e-324, 0.5, 1.0, 2.0, 1e300, INF, NAN)
                  for y in (0.0, 0.5, 1.0, 4.0, -1.0, 1024.0, -1075.0, INF, -INF, NAN)] + [
        (u(0, 1e3), u(0, 4)) for _ in range(60)] + [(math.exp(u(-60, 60)), u(0, 4)) for _ in range(40)]
    out["fmaf"] = fmaf_triples(rng, 120)
    return out


def fmaf_triples(rng, n):
    """Float triples: random bits, subnormals, c cancelling a b, and double-rounding traps (a b +
    c rounded to double lands on a float halfway point the exact sum misses)."""
    def any_float():
        kind = rng.randrange(4)
        if kind == 0:
            return f32_from_bits(rng.getrandbits(32))
        if kind == 1:
            return f32_from_bits(rng.getrandbits(23) | rng.getrandbits(1) << 31)
        return f32(math.ldexp(rng.uniform(1, 2), rng.randint(-30, 30)) * rng.choice((-1, 1)))

    out = []
    for i in range(n):
        a, b = any_float(), any_float()
        kind = i % 4
        if kind == 0:
            c = any_float()
        elif kind == 1:
            c = -f32(a * b) if math.isfinite(a * b) else any_float()
        elif kind == 2:
            p = a * b  # exact in double
            c = -f32(p - f32(p)) if math.isfinite(p) and abs(p) < 1e38 else any_float()
        else:
            c = f32(math.ldexp(rng.uniform(1, 2), rng.randint(-60, 60)))
            spacing = f32(math.ldexp(1.0, math.frexp(c)[1] - 24))
            j = rng.randint(1, 255)
            a, b = f32(1 + j * 2.0 ** -23), f32(spacing / 2 * (1 - j * 2.0 ** -23))
        out.append((a, b, c))
    return out


# ------------------------------------------------------------------------- bits on every platform

def current_vectors(inputs):
    """name -> [[input hex..., output hex]] computed by the core."""
    out = {}
    for name, values in inputs.items():
        results = probe(name, values)
        rows = []
        for value, result in zip(values, results):
            args = value if ARITY[name] > 1 else (value,)
            rows.append([hex64(a) for a in args] + [hex64(result)])
        out[name] = rows
    return out


def recorded_vectors():
    """name -> (inputs, recorded outputs as hex), from the committed file."""
    data = json.loads(VECTORS.read_text())
    out = {}
    for name, rows in data["vectors"].items():
        args = [[from_hex64(h) for h in row[:-1]] for row in rows]
        out[name] = ([a if len(a) > 1 else a[0] for a in args], [row[-1] for row in rows])
    return out


def differences():
    """(name, input hex, recorded hex, current hex) of every output whose bits changed."""
    bad = []
    for name, (inputs, expected) in recorded_vectors().items():
        got = [hex64(y) for y in probe(name, inputs)]
        for x, e, g in zip(inputs, expected, got):
            if e != g:
                bad.append((name, [hex64(a) for a in (x if isinstance(x, list) else [x])], e, g))
    return bad


def test_same_bits_as_recorded():
    """Every function's output bits on the committed inputs equal the recorded ones (x86-64 Linux)."""
    if RECORD:
        data = dict(note="ubmath.h outputs: [input hex..., output hex] rows, doubles as IEEE bits "
                         "(expf, fmaf: float values widened exactly); see test_ubmath.py",
                    vectors=current_vectors(vector_inputs()))
        VECTORS.write_text(json.dumps(data, indent=0, sort_keys=True) + "\n")
        import pytest
        pytest.skip("recorded %s" % VECTORS.name)
    bad = differences()
    assert not bad, "%d outputs changed bits, e.g. %s" % (len(bad), bad[:5])


# ------------------------------------------------------------------------- accuracy (mpmath)

def mp_reference(mpmath, name, x):
    if name.startswith("exp"):
        return mpmath.exp(x)
    if name == "log":
        return mpmath.log(x)
    if name in ("sin", "cos", "acos"):
        return getattr(mpmath, name)(x)
    if name == "hypot":
        return mpmath.sqrt(mpmath.mpf(x[0]) ** 2 + mpmath.mpf(x[1]) ** 2)
    return mpmath.power(mpmath.mpf(x[0]), mpmath.mpf(x[1]))


def ulps(mpmath, y, exact):
    """|y - exact| in units of the last place of the double nearest `exact` (subnormal spacing
    below 2^-1022)."""
    nearest = float(exact)
    if nearest == 0.0 and exact != 0:
        nearest = 5e-324
    spacing = math.ldexp(1.0, max(math.frexp(abs(nearest))[1] - 53, -1074))
    return float(abs(mpmath.mpf(y) - exact) / spacing)


def test_accuracy_against_mpmath():
    """Within the tolerance of accuracy_tolerance() (under 1 ulp) over the core's ranges and the
    whole double range."""
    import pytest
    mpmath = pytest.importorskip("mpmath")
    mpmath.mp.prec = 200
    tolerance = accuracy_tolerance()
    report = []
    for name, groups in accuracy_inputs(random.Random(7), 400).items():
        function = name.split(" ")[0]
        worst = 0.0
        for label, xs in groups:
            for x, y in zip(xs, probe(function, xs)):
                e = ulps(mpmath, y, mp_reference(mpmath, function, x))
                assert e <= tolerance[name], (name, label, x, y, e)
                worst = max(worst, e)
        report.append("%s %.3f" % (name, worst))
    print("max ulps:", ", ".join(report))


def test_expf_correctly_rounded_but_at_ties():
    """ub_expf: within 0.5 + 2^-28 float ulp of e^x, over the glow's range and every float."""
    import pytest
    mpmath = pytest.importorskip("mpmath")
    mpmath.mp.prec = 200
    rng = random.Random(11)
    xs = [f32(-rng.randint(0, 2000 * 64) / 64) for _ in range(500)] + [f32(rng.uniform(-103.9, 88.7))
                                                                       for _ in range(1500)]
    for x, y in zip(xs, probe("expf", xs)):
        exact = mpmath.exp(x)
        nearest = f32(float(exact))  # a neighbour of the correctly rounded float: its spacing
        spacing = math.ldexp(1.0, max(math.frexp(nearest or 1e-45)[1] - 24, -149))
        assert float(abs(mpmath.mpf(y) - exact) / spacing) <= 0.5 + 2 ** -28, (x, y)


def test_special_values():
    """IEEE's answers for zeros, infinities, NaN; NaN results are the one canonical quiet NaN."""
    canonical = "7ff8000000000000"
    assert [hex64(y) for y in probe("sin", [-0.0, 0.0, 5e-324, -5e-324])] == [
        hex64(-0.0), hex64(0.0), hex64(5e-324), hex64(-5e-324)]
    assert all(hex64(y) == canonical for name in ("sin", "cos") for y in probe(name, [INF, -INF, NAN]))
    assert probe("cos", [0.0, -0.0]) == [1.0, 1.0]
    assert probe("exp", [0.0, -INF, INF, -746.0, 710.0]) == [1.0, 0.0, INF, 0.0, INF]
    assert probe("log", [0.0, 1.0, INF]) == [-INF, 0.0, INF]
    assert all(hex64(y) == canonical for y in probe("log", [-1.0, -INF, NAN]))
    assert probe("acos", [1.0, -1.0, 0.0]) == [0.0, math.pi, math.pi / 2]
    assert all(hex64(y) == canonical for y in probe("acos", [1.0000000000000002, -2.0, NAN]))
    assert probe("pow", [(0.0, 0.0), (NAN, 0.0), (1.0, NAN), (0.0, 2.0), (0.0, -1.0), (INF, 0.5),
                         (INF, -0.5), (0.5, INF), (2.0, INF), (2.0, -INF), (4.0, 0.5), (2.0, -1074.0),
                         (2.0, 1024.0)]) == [1.0, 1.0, 1.0, 0.0, INF, INF, 0.0, 0.0, INF, 0.0, 2.0, 5e-324, INF]
    assert all(hex64(y) == canonical for y in probe("pow", [(-1.0, 2.0), (NAN, 1.0), (2.0, NAN)]))
    assert probe("hypot", [(INF, NAN), (NAN, -INF), (3.0, -4.0), (-0.0, 0.0), (1e308, 1e308)]) == [
        INF, INF, 5.0, 0.0, math.sqrt(2) * 1e308]
    assert probe("expf", [0.0, -INF, INF, -104.0, 89.0]) == [1.0, 0.0, INF, 0.0, INF]


def test_sincos_is_sin_and_cos_bit_for_bit():
    """ub_sincos (one argument reduction for a sample's direction: world.h, bsdf.h, camera.c)
    returns exactly ub_sin's and ub_cos's bits: every special value, tiny arguments of both signs
    (where sine is x itself), each quadrant, Cody-Waite's and Payne-Hanek's ranges."""
    rng = random.Random(7)
    xs = SPECIALS + [math.ldexp(rng.uniform(-1, 1), rng.randint(-1074, 1023)) for _ in range(400)] + [
        rng.uniform(-20, 20) for _ in range(400)] + [k * math.pi / 4 for k in range(-16, 17)] + [
        rng.choice((-1, 1)) * rng.uniform(2.0 ** -27, 2.0 ** -25) for _ in range(50)]
    for sincos, plain in (("sincos_sin", "sin"), ("sincos_cos", "cos")):
        got, want = probe(sincos, xs), probe(plain, xs)
        assert [hex64(y) for y in got] == [hex64(y) for y in want], plain


def test_probe_rejects_what_it_cannot_compute():
    """The private probe names its misuse instead of guessing."""
    import pytest
    with pytest.raises(ValueError, match="unknown function"):
        probe("tan", [1.0])
    with pytest.raises(TypeError, match="tuples of 2"):
        probe("pow", [1.0])
    with pytest.raises(ValueError, match="not a float32"):
        probe("fmaf", [(0.1, 1.0, 1.0)])
    with pytest.raises(TypeError):
        probe("exp", ["1"])
    assert probe("exp", ()) == []


# ------------------------------------------------------------------------- fmaf

def float32_rounded(q):
    """The exact rational q rounded to float32, ties to even (the referee: integer arithmetic
    only, no double in between)."""
    if q == 0:
        return 0.0
    sign, q = (-1.0 if q < 0 else 1.0), abs(q)
    e = q.numerator.bit_length() - q.denominator.bit_length()
    if Fraction(2) ** e > q:
        e -= 1
    quantum = Fraction(2) ** (max(e, -126) - 23)
    n, rest = divmod(q, quantum)
    n = int(n)
    if rest * 2 > quantum or (rest * 2 == quantum and n % 2):
        n += 1
    value = n * quantum
    return sign * (INF if value >= Fraction(2) ** 128 else float(value))


def test_fmaf_exact_against_rationals():
    """ub_fmaf(a, b, c) is a b + c rounded once, ties to even: random triples, subnormals,
    cancellation and double-rounding traps, against exact rational arithmetic."""
    triples = [t for t in fmaf_triples(random.Random(3), 8000)
               if all(math.isfinite(v) for v in t) and math.isfinite(t[0] * t[1] + t[2])]
    results = probe("fmaf", triples)
    for (a, b, c), y in zip(triples, results):
        exact = float32_rounded(Fraction(a) * Fraction(b) + Fraction(c))
        assert hex64(y) == hex64(exact) or (y == 0.0 == exact), (a, b, c, y, exact)


def test_fmaf_matches_the_cpu_fma():
    """Millions of triples against the CPU's own fused multiply-add (x86-64 FMA3): built from
    ubmath_fmaf_check.c with the system's C compiler."""
    import pytest
    cc = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if cc is None or platform.machine().lower() not in ("x86_64", "amd64"):
        pytest.skip("needs a C compiler on x86-64")
    cpuinfo = pathlib.Path("/proc/cpuinfo")
    if not cpuinfo.exists() or " fma " not in cpuinfo.read_text():
        pytest.skip("the CPU has no FMA instruction (or does not say so in /proc/cpuinfo)")
    root = pathlib.Path(__file__).resolve().parents[2]
    exe = pathlib.Path(os.environ.get("TMPDIR", "/tmp")) / ("ubmath_fmaf_check_%d" % os.getpid())
    # Not the sanitizer runtime that tools/sanitize.sh preloads into this process: under it the
    # compiler never finished. The check is of the header, built here on its own.
    env = {k: v for k, v in os.environ.items() if k not in ("LD_PRELOAD", "ASAN_OPTIONS", "LSAN_OPTIONS")}
    try:
        subprocess.run([cc, "-O2", "-std=c11", "-ffp-contract=off", "-I", str(root / "native" / "src"),
                        str(pathlib.Path(__file__).with_name("ubmath_fmaf_check.c")), "-o", str(exe), "-lm"],
                       check=True, capture_output=True, env=env, timeout=300)
        r = subprocess.run([str(exe), "4000000"], capture_output=True, text=True, env=env, timeout=300)
    finally:
        exe.unlink(missing_ok=True)
    assert r.returncode == 0, r.stdout
    assert " 0 differ" in r.stdout


if __name__ == "__main__":
    # The bit-exact check alone, with the standard library only (wine, qemu): the core from the
    # directory given, else UNBOUND_CORE_PATH, else build/wheel.
    root = pathlib.Path(__file__).resolve().parents[2]
    sys.path.insert(0, sys.argv[1] if len(sys.argv) > 1 else
                    os.environ.get("UNBOUND_CORE_PATH") or str(root / "build" / "wheel"))
    bad = differences()
    for row in bad[:20]:
        print("changed:", *row)
    total = sum(len(rows) for rows in json.loads(VECTORS.read_text())["vectors"].values())
    print("%s: %d of %d outputs differ from the recorded bits" % (platform.platform(), len(bad), total))
    sys.exit(1 if bad else 0)


def test_same_bits_module_is_the_cores_own_functions():
    """unbound_core.same_bits (what the add-on uses for the slice rotation and a sun's angular
    radius) returns the core's bits, and they are the true values to an ulp or so."""
    import math

    import unbound_core as uc
    for x in (0.0, 0.3, -1.2, 2.5, 1e3, -7.75):
        assert uc.same_bits.sin(x) == uc._native._math_probe("sin", [x])[0]
        assert uc.same_bits.cos(x) == uc._native._math_probe("cos", [x])[0]
        assert abs(uc.same_bits.sin(x) - math.sin(x)) <= 2 * math.ulp(max(abs(math.sin(x)), 1e-300))
        assert abs(uc.same_bits.tan(x) - math.tan(x)) <= 4 * math.ulp(abs(math.tan(x)))
