"""Elementary functions with the same bits on every platform: the core's own (native/src/ubmath.h),
not the C library's, whose last bit differs between glibc, Apple's libm and Windows' UCRT on a few
per cent of inputs. For what the add-on computes on the way to pixels (the slice rotation, a sun's
angular radius), so that a frame rendered on Windows or macOS equals the Linux one."""
from ._native import _math_probe


def sin(x):
    return _math_probe("sin", [float(x)])[0]


def cos(x):
    return _math_probe("cos", [float(x)])[0]


def tan(x):
    """sin / cos: within about 1.5 ulp, identical everywhere (IEEE division)."""
    s, c = _math_probe("sin", [float(x)])[0], _math_probe("cos", [float(x)])[0]
    return s / c
