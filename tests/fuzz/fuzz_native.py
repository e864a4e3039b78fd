"""Coverage-guided fuzzing of the native core's whole Python API (atheris + libFuzzer).

Each input becomes one random call sequence: a camera (any size, degenerate and non-finite
matrices), 0-4 objects, a random pass selection (sometimes with wrong shapes, dtypes, strides or
read-only buffers), a window, threads, tile size, SIMD path, shading with lights, and cancellation
at a random poll (by the progress callback, an Event, or an exception raised in the callback); then
estimate(), normals(), describe() and camera_ray() on the same object.

The values of the camera, object, shading, light and render-keyword keys come from the core's own
parameter table, unbound_core.PARAMETERS: a key added to the table is fuzzed the day it is added.
For every row the input picks: absent, the default, an ordinary value inside [min, max], an edge
(min, max), just outside the range, non-finite, a wrong type, a wrong shape, for choices one of them
or a bad name; lists get counts from 0 to beyond max_items, their items made from the row's shape
or its item section. Any value may also be hostile (issue 16): a number whose __float__/__index__
mutates or clears the containers it came from, raises, or returns NaN or huge values; a sequence
whose __len__/__getitem__ lie or mutate.

What counts as a finding (atheris reports it and saves the input):
- a crash, an ASan or UBSan report (the build of tools/sanitize.sh aborts on both);
- an exception other than ValueError / TypeError naming the problem (or the callback's own, or a
  hostile object's own; MemoryError/OverflowError only where a sequence's __len__ lied huge, as
  Python's own tuple() answers that);
- a finished, uncancelled render that leaves a pixel of a requested pass NaN or infinite
  (the passes start out NaN, so every pixel must have been written, and written finite);
- an estimate that is NaN for a finite point, or not positive and finite outside the bounding ball.

Run through tools/sanitize.sh (fuzz: a campaign; replay FILE: one saved input). Without atheris's
instrumentation (plain `python fuzz_native.py FILE`) it replays inputs against any build.
"""
import gc
import math
import os
import sys
import threading
import time

import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.environ.get("UNBOUND_CORE_PATH") or os.path.join(ROOT, "build", "wheel"))

import atheris  # noqa: E402
import unbound_core as uc  # noqa: E402

TABLE = uc.PARAMETERS
SPECIAL = [0.0, -0.0, 1.0, -1.0, 0.5, 2.0, 4.0, 1e-7, 1e-30, 1e30, -1e30, 1e300, 3.4e38, 5e-324,
           math.nan, math.inf, -math.inf]
NONFINITE = [math.nan, math.inf, -math.inf, -math.nan, np.float32("nan"), np.float64("inf")]
HUGE_INTS = [2 ** 31, 2 ** 31 - 1, -2 ** 31 - 1, 2 ** 63, 2 ** 63 - 1, -2 ** 63 - 1, 2 ** 64, 10 ** 40, -10 ** 40]
BAD_TYPES = [None, "x", [1.0], {"a": 1}, object()]
# Wrong types for the table's values (the parser's, which must answer each with TypeError/ValueError).
WRONG_TYPES = BAD_TYPES + ["", b"1", (), {}, 1 + 2j, 10 ** 400, {1.0}]
BAD_NAMES = ["x", "", " ", "\0", "\ud800", "%s%n", "é" * 40, "y" * 64, "z" * 300]
# Per-input work is bounded by a time budget: the progress callback cancels after it (which
# exercises cancellation on every slow input, too).
BUDGET_S = 0.05


class CallbackError(Exception):
    """Raised from the progress callback: must come back out of render() unchanged."""


class HostileError(Exception):
    """Raised by a hostile value's own method: may come back out of the call unchanged."""


# ---------------------------------------------------------------- hostile values (issue 16)

def _attack(mode, victims):
    """A hostile method's side effect on the containers its value came from."""
    for v in victims:
        try:
            if mode == "clear":
                v.clear()
            elif mode == "replace":
                if isinstance(v, dict):
                    for k in list(v):
                        v[k] = "replaced"
                    v["bogus_key"] = 1
                else:
                    v[:] = [None] * 3
            elif mode == "shrink":
                if isinstance(v, dict):
                    if v:
                        v.pop(next(iter(v)))
                elif v:
                    del v[0]
            elif mode == "grow":
                if isinstance(v, dict):
                    v["grown"] = list(range(50))
                else:
                    v.extend([1e300] * 50)
        except Exception:  # noqa: BLE001 - a container that refuses (a tuple): nothing happens
            pass
    if mode == "gc":
        gc.collect()


class HostileNumber:
    """A number (not an int/float) whose conversions attack the containers it came from."""

    def __init__(self, value, mode, result, victims):
        self.value, self.mode, self.result, self.victims = value, mode, result, victims
        self.calls = 0

    def _convert(self, kind):
        self.calls += 1
        if self.calls > 1000:
            return kind(self.value)
        _attack(self.mode, self.victims)
        if self.mode == "raise":
            raise HostileError("hostile __float__")
        if self.mode == "raise_type":
            raise TypeError("hostile")
        r = self.result
        if r == "nan":
            return math.nan if kind is float else 0
        if r == "huge":
            return 1e308 if kind is float else 10 ** 40
        if r == "inf":
            return -math.inf if kind is float else -(10 ** 40)
        if r == "wrong":
            return "not a number"
        if r == "flip" and self.calls % 2 == 0:
            return math.nan if kind is float else -1
        return kind(self.value)

    def __float__(self):
        return self._convert(float)

    def __index__(self):
        return self._convert(int)

    def __int__(self):
        return self._convert(int)

    def __repr__(self):
        return f"HostileNumber({self.value!r}, {self.mode}, {self.result})"


class HostileInt(int):
    """An int (passes PyLong_Check) whose __float__/__index__ attack like HostileNumber's."""

    def __new__(cls, value, mode, result, victims):
        self = super().__new__(cls, int(value) if math.isfinite(value) else 0)
        self.h = HostileNumber(value, mode, result, victims)
        return self

    def __float__(self):
        return self.h.__float__()

    def __index__(self):
        return self.h.__index__()

    def __repr__(self):
        return f"HostileInt({self.h!r})"


class HostileSequence:
    """A sequence (by __len__/__getitem__ only) whose length lies and whose reads mutate."""

    def __init__(self, items, mode, victims, length, stop):
        self.items, self.mode, self.victims, self.length, self.stop = list(items), mode, victims, length, stop
        self.reads = 0

    def __len__(self):
        if self.mode == "len_raise":
            raise HostileError("hostile __len__")
        if self.mode == "len_type":
            raise TypeError("hostile __len__")
        return self.length

    def __getitem__(self, i):
        if isinstance(i, slice):
            return self.items[i]
        self.reads += 1
        if i >= self.stop or self.reads > 400:
            raise IndexError(i)
        if self.mode == "self":
            self.items.append(self.items[-1] if self.items else 0.0)
            if self.items and self.reads % 2:
                del self.items[0]
        elif self.mode == "raise" and i == len(self.items) // 2:
            raise HostileError("hostile __getitem__")
        elif self.mode not in ("len_raise", "len_type"):
            _attack(self.mode, self.victims)
        if i < len(self.items):
            return self.items[i]
        return self.items[-1] if self.items and self.mode != "none" else 1.0

    def __repr__(self):
        return f"HostileSequence({self.items!r}, {self.mode}, len={self.length}, stop={self.stop})"


class Gen:
    """Values drawn from the fuzzer's bytes."""

    def __init__(self, data):
        self.f = atheris.FuzzedDataProvider(data)
        # How hostile this input is: a table value is other than ordinary with probability
        # about 1/bad (bytes run out: 0, the most benign), so inputs reach deep as well as wide.
        self.bad = [60, 16, 6, 2][self.f.ConsumeIntInRange(0, 3)]
        self.hostile = False  # a hostile value was made (results of repeated calls may differ)
        self.lied_huge = False  # a sequence's __len__ claimed more than memory holds

    def pick(self, items):
        return items[self.f.ConsumeIntInRange(0, len(items) - 1)]

    # Exhausted bytes read as 0: every draw is arranged so that 0 means the ordinary case.
    def chance(self, n):
        """True with probability about 1/n."""
        return self.f.ConsumeIntInRange(0, n - 1) == n - 1

    def uniform(self, lo, hi):
        return lo + (hi - lo) * self.f.ConsumeProbability()

    def real(self, lo=-2.0, hi=2.0):
        c = self.f.ConsumeIntInRange(0, 15)
        if c == 12:
            return self.pick(SPECIAL)
        if c == 13:
            return self.f.ConsumeRegularFloat()
        if c == 14 and self.chance(4):
            return self.pick(BAD_TYPES)
        if c == 15:
            return self.f.ConsumeIntInRange(-3, 3)
        return self.uniform(lo, hi)

    def count(self, lo, hi, extreme=(0, -1, 10 ** 6, 2 ** 31, 2 ** 63, 10 ** 40)):
        c = self.f.ConsumeIntInRange(0, 19)
        if c == 18:
            return self.pick(list(extreme))
        if c == 19:
            return self.pick([3.5, "7", None, True])
        return self.f.ConsumeIntInRange(lo, hi)

    def length(self, lo, hi, extreme=()):
        """A list length: usually in [lo, hi], sometimes one of the extremes."""
        if extreme and self.chance(20):
            return self.pick(list(extreme))
        return self.f.ConsumeIntInRange(lo, hi)

    def vector(self, n, lo=-2.0, hi=2.0):
        if self.chance(40):
            n = self.f.ConsumeIntInRange(0, 5)
        return [self.real(lo, hi) for _ in range(n)]

    def matrix(self, rows, cols, lo=-2.0, hi=2.0):
        return [self.vector(cols, lo, hi) for _ in range(rows)]

    # ------------------------------------------------------------ hostile values

    def hostile_number(self, value, victims):
        self.hostile = True
        mode = self.pick(["none", "clear", "replace", "shrink", "grow", "gc", "raise", "raise_type"])
        result = self.pick(["value", "value", "nan", "huge", "inf", "wrong", "flip"])
        if self.chance(2) and (value is None or math.isfinite(value)):
            return HostileInt(value if value is not None else 0.0, mode, result, victims)
        return HostileNumber(value if value is not None else 0.0, mode, result, victims)

    def hostile_sequence(self, items, victims):
        self.hostile = True
        n = len(items)
        mode = self.pick(["none", "self", "clear", "replace", "shrink", "grow", "gc", "raise", "len_raise",
                          "len_type"])
        length = self.pick([n, n, 0, n + 1, max(n - 1, 0), 2 ** 62, -1])
        if length == 2 ** 62:
            self.lied_huge = True
        stop = self.pick([n, n, max(n - 1, 0), n + 1, n + 7])
        return HostileSequence(items, mode, victims, length, stop)


def expected_error(exc, g):
    """ValueError/TypeError with a message: the documented answer to bad input. A hostile
    object's own exception, and what Python's tuple() answers to a __len__ beyond memory."""
    if isinstance(exc, HostileError):
        return True
    if isinstance(exc, (MemoryError, OverflowError)) and g.lied_huge:
        return True
    return isinstance(exc, (ValueError, TypeError)) and str(exc).strip() != ""


# ---------------------------------------------------------------- values from the parameter table

def _finite(x):
    return x is not None and math.isfinite(x)


def _components(default, shape):
    """The default as a flat list of len prod(shape) numbers (zeros where it has none)."""
    n = math.prod(shape) if shape else 1
    if default is None or isinstance(default, (str, bool)) and not shape:
        return [0.0] * n
    flat = np.ravel(np.asarray(default, dtype=np.float64)).tolist() if shape else [float(default)]
    return flat if len(flat) == n else [0.0] * n


def ordinary_real(g, lo, hi, center):
    """A finite value in [lo, hi] (either may be infinite), mostly near center."""
    lo_f = lo if _finite(lo) else -1e30
    hi_f = hi if _finite(hi) else 1e30
    center = min(max(center, lo_f), hi_f)
    c = g.f.ConsumeIntInRange(0, 7)
    if c == 6 and _finite(lo) and _finite(hi):
        return g.uniform(lo, hi)
    if c == 7 and hi_f > 0:  # log-uniform magnitudes: the range's small and large scales
        a = max(lo_f, 1e-9 * hi_f, 1e-12) if lo_f > 0 else 1e-6
        v = math.exp(g.uniform(math.log(a), math.log(hi_f)))
        return -v if lo_f < 0 and g.chance(2) and -v >= lo_f else v
    a, b = max(lo_f, center - 2.0), min(hi_f, center + 2.0)
    return g.uniform(a, b)


def ordinary_int(g, lo, hi, default):
    """An integer in [lo, hi], mostly small (the costs of the kernels grow with them)."""
    lo_i = int(lo) if _finite(lo) else -100
    hi_i = int(hi) if _finite(hi) else 100
    span = max(2, int(default or 0) + 2)
    return g.f.ConsumeIntInRange(lo_i, max(lo_i, min(hi_i, lo_i + span)))


def outside(g, lo, hi, is_int):
    """Just outside [lo, hi] (or far outside)."""
    cands = []
    for bound, sign in ((lo, -1), (hi, 1)):
        if not _finite(bound):
            continue
        if is_int:
            cands += [int(bound) + sign, int(bound) + sign * 1000]
        else:
            cands += [math.nextafter(bound, sign * math.inf), bound + sign * max(1.0, abs(bound)),
                      bound * 10 if bound * sign > 0 else bound + sign]
    return g.pick(cands) if cands else g.pick(NONFINITE if not is_int else HUGE_INTS)


def represent(g, flat, shape, victims):
    """Numbers laid out in `shape`: nested lists mostly, sometimes tuples or numpy arrays; items
    sometimes hostile (holding the containers they came from)."""
    if not shape:
        return flat[0]
    c = g.f.ConsumeIntInRange(0, 15)
    if c == 13:
        try:
            return np.array(flat, dtype=g.pick([np.float64, np.float32, np.int64, object])).reshape(shape)
        except (ValueError, TypeError, OverflowError):
            pass
    rows = shape[0] if len(shape) > 1 else 1
    cols = shape[-1]
    out = []
    for r in range(rows):
        vec = []
        for v in flat[r * cols:(r + 1) * cols]:
            if g.chance(64):
                num = v if type(v) in (int, float) and math.isfinite(v) else None
                v = g.hostile_number(num, victims + (vec, out))
            vec.append(v)
        if c == 14:
            vec = tuple(vec)
        out.append(vec)
    if len(shape) == 1:
        out = out[0]
    if c == 15:
        out = g.hostile_sequence(out, victims + (out,))
    return out


def wrong_shape(g, flat, shape):
    """The numbers in another shape: a scalar for a vector, short, long, ragged, flat matrices."""
    n = len(flat)
    fill = flat[0] if flat else 0.0
    c = g.f.ConsumeIntInRange(0, 7)
    if not shape:
        return [fill] * g.f.ConsumeIntInRange(0, 4) if c < 6 else np.full(g.f.ConsumeIntInRange(0, 3), fill)
    if c == 0:
        return fill  # a scalar
    if c == 1:
        return flat[:max(0, shape[-1] - 1)] if len(shape) == 1 else [r[:-1] for r in _rows(flat, shape)]
    if c == 2:
        return flat + [fill] if len(shape) == 1 else [r + [fill] for r in _rows(flat, shape)]
    if c == 3:
        return _rows(flat, shape)[:-1] if len(shape) == 2 else []
    if c == 4:
        return flat if len(shape) == 2 else [flat]  # a matrix flattened, a vector nested
    if c == 5:
        rows = _rows(flat, shape) if len(shape) == 2 else [flat]
        return rows + [rows[-1][:1]]  # ragged
    if c == 6:
        return np.zeros(tuple(s + 1 for s in shape))
    return range(n + g.f.ConsumeIntInRange(-1, 1))


def _rows(flat, shape):
    cols = shape[-1]
    return [list(flat[i:i + cols]) for i in range(0, len(flat), cols)]


# Ordinary values where the table's range is too wide to be useful (a camera that sees something,
# images small enough to render, windows inside the image); every other variant still comes from
# the row. A key missing here is fuzzed from its row alone.
ORDINARY = {}


def value(g, row, victims, ordinary=None):
    """A value for table row `row` (absent is the caller's choice); `ordinary` makes the ordinary
    value where the row's own range is too wide to be useful."""
    t, shape = row["type"], tuple(row["shape"])
    lo, hi, default = row["min"], row["max"], row["default"]
    if t == "list":
        return list_value(g, row, victims)
    if t == "custom":
        return g.pick(WRONG_TYPES) if g.chance(4) else None
    c = 0 if not g.chance(g.bad) else g.f.ConsumeIntInRange(12, 19)
    if c == 12:  # the default, given explicitly
        return default
    if c == 13:  # wrong type
        return g.pick(WRONG_TYPES + [math.nan, 3, 2.5, True] if t in ("bool", "choice", "string") else
                      WRONG_TYPES + ([2.5, True, np.int64(2), "3"] if t == "int" else ["1.0", b"\0"]))
    if c == 14:  # hostile
        if t in ("float", "int") and not shape:
            return g.hostile_number(float(default) if isinstance(default, (int, float)) else 1.0, victims)
        return g.hostile_sequence(list(default) if isinstance(default, (tuple, list)) else [default], victims)
    if t == "bool":
        return g.pick([True, False]) if c < 15 else g.pick([1, 0, np.bool_(True), "True", None])
    if t == "choice":
        choices = list(row["choices"])
        if c < 15:
            return g.pick(choices)
        s = g.pick(choices)
        return g.pick(BAD_NAMES + [s.upper(), s + "\0", s + " ", s[:-1], type("S", (str,), {})(s)])
    if t == "string":
        if c == 0:
            if ordinary is not None:
                return ordinary()
            return g.pick(["", "Mandel", "fractal 'x'", "%s%d", "é" * 10, "n" * 63])
        return g.pick(BAD_NAMES + ["n" * 64, "a\0b", "1 2", "1e9999 0 0", "0 0 0 0", "-" * 600])
    is_int = t == "int"
    flat_default = _components(default, shape)
    n = len(flat_default)
    if c < 12:  # ordinary
        if ordinary is not None and not g.chance(8):
            return ordinary()
        if is_int:
            flat = [ordinary_int(g, lo, hi, d) for d in flat_default]
        else:
            flat = [ordinary_real(g, lo, hi, d) for d in flat_default]
    elif c == 15:  # the edges
        flat = [g.pick([lo, hi]) for _ in range(n)] if g.chance(2) else [g.pick([lo, hi])] * n
        if is_int:
            flat = [int(v) if _finite(v) else v for v in flat]
    elif c == 16:  # just outside, in one component
        flat = [ordinary_int(g, lo, hi, d) if is_int else ordinary_real(g, lo, hi, d) for d in flat_default]
        flat[g.f.ConsumeIntInRange(0, n - 1)] = outside(g, lo, hi, is_int)
    elif c == 17:  # non-finite (or, for integers, beyond every C type)
        flat = list(flat_default)
        flat[g.f.ConsumeIntInRange(0, n - 1)] = g.pick(NONFINITE if not is_int or g.chance(2) else HUGE_INTS)
    elif c == 18:
        return wrong_shape(g, flat_default, shape)
    else:  # extreme numbers of every kind in every component
        flat = [g.pick(SPECIAL + HUGE_INTS[:3]) for _ in range(n)]
    return represent(g, flat, shape, victims)


def list_value(g, row, victims):
    """A list row: counts from 0 to beyond max_items, items from the item section or the shape."""
    lo_n, hi_n = row["min_items"], row["max_items"]
    c = 0 if not g.chance(g.bad) else g.f.ConsumeIntInRange(12, 15)
    if c == 12:
        return row["default"]
    if c == 13:
        return g.pick(WRONG_TYPES + [3, "abc", {"0": 1}])
    if c == 14:
        n = g.pick([0, lo_n, max(lo_n - 1, 0), hi_n, hi_n + 1, hi_n * 4 + 1])
    else:
        n = g.f.ConsumeIntInRange(lo_n, max(lo_n, min(hi_n, lo_n + 4)))
    out = []
    inner = victims + (out,)
    section = row["items"]
    item_row = dict(row, type="float", default=None)
    for i in range(n):
        if section:
            out.append(section_dict(g, section, inner) if not g.chance(40) else g.pick(BAD_TYPES))
        elif i < 20 or c != 14:
            out.append(value(g, item_row, inner) if g.chance(6) else
                       represent(g, [ordinary_real(g, row["min"], row["max"], 0.0)
                                     for _ in range(math.prod(row["shape"]))], tuple(row["shape"]), inner))
        else:  # long lists: cheap copies
            out.append(out[-1] if out else [0.0] * math.prod(row["shape"]))
    if c == 15:
        return g.hostile_sequence(out, victims + (out,))
    return out


def section_dict(g, section, victims, present=3, skip=()):
    """A dict of `section`'s keys, each present with probability about 1/present; a key of none."""
    d = {}
    inner = victims + (d,)
    for key, row in TABLE[section].items():
        if key in skip or not g.chance(present):
            continue
        make = ORDINARY.get((section, key))
        d[key] = value(g, row, inner, (lambda make=make: make(g)) if make else None)
    if g.chance(50):
        d[g.pick(["colour", "sea", "epsilon_mode", "", "KIND"])] = 1
    if g.chance(80):
        d[g.pick([1, None, ("kind",)])] = 1
    return d


def _look_at(g):
    eye = [g.real(-4, 4) for _ in range(3)]
    try:
        return uc.look_at(eye, [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    except (ValueError, TypeError, ZeroDivisionError, OverflowError):
        return [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 3], [0, 0, 0, 1]]


def _projection(g):
    c = g.f.ConsumeIntInRange(0, 5)
    try:
        if c == 5:
            return g.matrix(4, 4)
        if c == 4:
            return uc.orthographic(g.real(0.01, 5), 1.0, abs(g.real(0.01, 1)) + 1e-3, g.real(2, 100))
        return uc.perspective(g.real(0.1, 2.5), g.real(0.5, 2), abs(g.real(0.01, 1)) + 1e-3, g.real(2, 100))
    except (ValueError, TypeError, ZeroDivisionError, OverflowError):
        return uc.perspective(0.7, 1.0, 0.1, 100.0)


ORDINARY.update({
    ("camera", "matrix"): lambda g: g.matrix(4, 4, -4.0, 4.0) if g.chance(6) else _look_at(g),
    ("camera", "projection"): _projection,
    ("camera", "width"): lambda g: g.count(1, 16, extreme=(0, -1, 65536, 65537, 2 ** 31)),
    ("camera", "height"): lambda g: g.count(1, 16, extreme=(0, -1, 65536, 65537, 2 ** 31)),
    ("object", "kind"): lambda g: g.pick(list(TABLE["object"]["kind"]["choices"])),
    ("object", "mu"): lambda g: g.vector(4, -1.2, 1.2),
    ("object", "matrix"): lambda g: [[1, 0, 0, g.real()], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],
    ("render", "poll_interval"): lambda g: g.uniform(1e-4, 0.01),
    # Deep zoom: mostly off (a zoom on the other kinds is refused), else up to the table's 60; the
    # anchor as decimals, sometimes long or with an exponent.
    ("object", "zoom"): lambda g: g.uniform(0.0, 60.0) if g.chance(3) else 0.0,
    ("object", "zoom_anchor"): lambda g: " ".join(
        g.pick(["%r" % g.real(-2.0, 2.0), "0." + "7" * g.f.ConsumeIntInRange(1, 120), "-1.5e-3", "0"])
        for _ in range(3)),
})


def random_camera(g):
    camera = {}
    for key, row in TABLE["camera"].items():
        if g.chance(4 * g.bad):
            continue  # a required key missing
        make = ORDINARY.get(("camera", key))
        camera[key] = value(g, row, (camera,), (lambda make=make: make(g)) if make else None)
    return camera


def random_object(g, victims=()):
    obj = section_dict(g, "object", victims, skip=("kind",))
    if not g.chance(10):  # kind first: the keys of its family follow
        kind = value(g, TABLE["object"]["kind"], victims + (obj,))
        obj = {"kind": kind, **obj}
    return obj


def random_passes(g, w, h):
    """Pass buffers for a w x h film, NaN-filled; sometimes deliberately wrong."""
    names = [n for n in uc.PASSES if g.chance(3)] or ["combined"]
    passes = {}
    for n in names:
        shape = (h, w, uc.PASS_CHANNELS[n])
        c = g.f.ConsumeIntInRange(0, 39)
        if c == 39:
            passes[n] = np.full(shape, np.nan, np.float64)
        elif c == 38:
            passes[n] = np.full((h + 1, w, shape[2]), np.nan, np.float32)
        elif c == 37:
            passes[n] = np.full((h, 2 * w, shape[2]), np.nan, np.float32)[:, ::2]
        elif c == 36:
            a = np.full(shape, np.nan, np.float32)
            a.flags.writeable = False
            passes[n] = a
        elif c == 35:
            passes[n] = g.pick(BAD_TYPES)
        else:
            passes[n] = np.full(shape, np.nan, np.float32)
    if g.chance(40):
        passes["beauty"] = np.zeros((h, w, 4), np.float32)
    return passes


def _plain_int(v):
    return type(v) is int


class _NoIsSet:
    pass


class _BadCancel:
    """cancel= objects whose is_set misbehaves."""

    def __init__(self, mode):
        self.mode = mode

    def is_set(self):
        if self.mode == "raise":
            raise HostileError("hostile is_set")
        if self.mode == "bool_raise":
            return HostileBool()
        return self.mode


class HostileBool:
    def __bool__(self):
        raise HostileError("hostile __bool__")


def fuzz_render(g):
    camera = random_camera(g)
    objects = []
    for _ in range(g.length(0, 3, (64, 65))):
        objects.append(random_object(g, (objects,)))
    width, height = camera.get("width"), camera.get("height")
    render_rows = TABLE["render"]
    kw = {}
    # The render keywords from the table: each given about half the time (custom ones below).
    for key, row in render_rows.items():
        if row["type"] == "custom" or key in ("window", "sample_range", "stride") or not g.chance(2):
            continue
        make = ORDINARY.get(("render", key))
        kw[key] = value(g, row, (kw,), (lambda make=make: make(g)) if make else None)
    # The window: for big images always (the buffers stay small), ordinarily inside the image.
    if _plain_int(width) and _plain_int(height) and width > 0 and height > 0 and \
            (width * height > 16 * 16 or g.chance(4)):
        def ordinary_window():
            x = g.f.ConsumeIntInRange(0, max(0, min(width, 2 ** 20) - 1))
            y = g.f.ConsumeIntInRange(0, max(0, min(height, 2 ** 20) - 1))
            return (x, y, g.count(1, 16, extreme=(0, -1, 2 ** 31)), g.count(1, 16, extreme=(0, -1, 2 ** 31)))
        kw["window"] = value(g, render_rows["window"], (kw,), ordinary_window)
    # The viewport's interleaved sub-grids: every stride-th pixel of every stride-th row.
    if g.chance(3):
        kw["stride"] = value(g, render_rows["stride"], (kw,),
                             lambda: g.count(1, 9, extreme=(0, -1, 4096, 4097)))
    window, stride = kw.get("window"), kw.get("stride")
    if isinstance(window, (tuple, list)) and len(window) == 4 and all(_plain_int(v) for v in window):
        fw, fh = window[2], window[3]
    elif _plain_int(stride) and stride > 0 and _plain_int(width) and _plain_int(height):
        fw, fh = -(-width // stride), -(-height // stride)
    else:
        fw, fh = width, height
    if not (_plain_int(fw) and _plain_int(fh) and 0 < fw <= 64 and 0 < fh <= 64):
        fw, fh = 4, 4  # nonsense size: the call must refuse the buffers (or the camera) anyway
    passes = random_passes(g, fw, fh)
    if g.chance(2):
        kw["shading"] = section_dict(g, "shading", (kw,)) if not g.chance(30) else g.pick(BAD_TYPES)
    if g.chance(4):  # samples a range at a time into running sums
        kw["sample_range"] = value(g, render_rows["sample_range"], (kw,), lambda: (
            g.count(0, 4, extreme=(-1, 2 ** 31)), g.count(1, 4, extreme=(0, -1, 2 ** 31))))
    sample_range = kw.get("sample_range")
    # Later samples add to the caller's running sums: then the buffers' contents are theirs.
    overwrites = sample_range is None or (isinstance(sample_range, (tuple, list)) and len(sample_range) == 2
                                          and type(sample_range[0]) in (int, float) and sample_range[0] == 0)
    # Cancellation: by the callback's return value, an exception in it, or an Event set from a
    # thread; and always by the time budget.
    cancel_mode = g.pick(["none", "return", "raise", "event"])
    cancel_at = g.f.ConsumeIntInRange(0, 5)
    calls = [0]
    start = time.perf_counter()
    event = threading.Event()
    timer = None

    def progress(fraction):
        calls[0] += 1
        if cancel_mode == "raise" and calls[0] > cancel_at:
            raise CallbackError("stop")
        return (cancel_mode == "return" and calls[0] > cancel_at) or time.perf_counter() - start > BUDGET_S

    # The custom rows: progress is always the budget's callback (or something not callable, which
    # must be refused); cancel an Event, None, or an object whose is_set misbehaves.
    kw["progress"] = progress if not g.chance(40) else g.pick(["x", 3, {"a": 1}, object()])
    if cancel_mode == "event":
        kw["cancel"] = event
        timer = threading.Timer(cancel_at * 0.002, event.set)
        timer.start()
    elif g.chance(10):
        kw["cancel"] = g.pick([None, _NoIsSet(), _BadCancel("raise"), _BadCancel("bool_raise"),
                               _BadCancel(3), _BadCancel(None)])
    for key, row in render_rows.items():  # a custom row the fuzzer does not know: bad values
        if row["type"] == "custom" and key not in kw and key not in ("progress", "cancel") and g.chance(2):
            kw[key] = value(g, row, (kw,))
    try:
        stats = uc.render(camera, objects, passes, **kw)
    except CallbackError:
        return
    except Exception as exc:  # noqa: BLE001 - anything unexpected is the finding
        if not expected_error(exc, g):
            raise
        return
    finally:
        if timer is not None:
            timer.cancel()
    if stats["cancelled"] or not overwrites:
        return
    for name, buf in passes.items():
        if isinstance(buf, np.ndarray) and not np.all(np.isfinite(buf)):
            raise AssertionError(f"finished render left non-finite values in pass {name!r}: "
                                 f"camera={camera!r} objects={objects!r} kw={ {k: v for k, v in kw.items() if k != 'progress'} !r}")


def fuzz_point_queries(g):
    obj = random_object(g)
    n = g.count(0, 9, extreme=(0,))
    n = n if type(n) is int and 0 <= n <= 64 else 3
    pts = np.array([[g.real(-3, 3) for _ in range(3)] for _ in range(n)], dtype=object)
    try:
        pts = pts.astype(np.float32).reshape(n, 3)
    except (TypeError, ValueError, OverflowError):
        pts = np.zeros((n, 3), np.float32)
    est = np.full(n, np.nan, np.float32)
    its = np.full(n, np.nan, np.float32)
    simd = value(g, TABLE["render"]["simd"], ()) if g.chance(8) else g.pick(["auto", "portable", "avx2"])
    try:
        info = uc.describe(obj)
        uc.estimate(obj, pts, est, its, simd=simd)
    except Exception as exc:  # noqa: BLE001
        if not expected_error(exc, g):
            raise
        return
    # A slice that misses the bounding ball is an empty object: radius -1 (a zero extent: 0).
    assert info["bound_radius"] == -1.0 or 0 <= info["bound_radius"] < math.inf, info
    finite = np.all(np.isfinite(pts), axis=1)
    if np.any(np.isnan(est[finite])):
        raise AssertionError(f"estimate is NaN at a finite point: object={obj!r} points={pts[finite]!r}")
    # Outside the bounding ball there is no set: the estimate is positive and finite there. (Not
    # with hostile values: describe() and estimate() may each have read a different object.)
    if info["bound_radius"] >= 0 and not g.hostile:
        gap = np.linalg.norm(pts.astype(np.float64) - np.array(info["bound_center"]), axis=1) - info["bound_radius"]
        bad = finite & (gap > 1e-3 * (1 + info["bound_radius"])) & ~((est > 0) & (est < np.inf))
        if np.any(bad):
            raise AssertionError(f"estimate {est[bad]!r} outside the bounding ball: object={obj!r} "
                                 f"points={pts[bad]!r}")
    t = np.full(n, 0.5 * g.f.ConsumeProbability(), np.float32)
    normals = np.full((n, 3), np.nan, np.float32)
    try:
        uc.normals(obj, pts, t, normals, simd=simd)
    except Exception as exc:  # noqa: BLE001
        if not expected_error(exc, g):
            raise


def fuzz_camera_ray(g):
    camera = random_camera(g)
    try:
        coordinate = (lambda: g.pick(WRONG_TYPES)) if g.chance(8) else (lambda: g.real(-10, 30))
        uc.camera_ray(camera, coordinate(), coordinate())
    except Exception as exc:  # noqa: BLE001
        if not expected_error(exc, g):
            raise


def test_one_input(data):
    g = Gen(data)
    which = g.f.ConsumeIntInRange(0, 7)
    if which <= 4:
        fuzz_render(g)
    elif which <= 6:
        fuzz_point_queries(g)
    else:
        fuzz_camera_ray(g)


def main():
    warnings.simplefilter("ignore")  # numpy's cast warnings on the deliberately odd values
    atheris.Setup(sys.argv, test_one_input)
    atheris.Fuzz()


if __name__ == "__main__":
    main()
