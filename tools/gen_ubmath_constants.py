"""Prints the constants of native/src/ubmath.h (C99 hex floats, exact), from mpmath and exact
fractions, so that every digit there can be re-derived:
    PYTHONPATH=<dir with mpmath> python3 tools/gen_ubmath_constants.py
Splits of pi/2 and ln 2 keep few enough significant bits that n * part is exact for the reduction's
largest n; Taylor coefficients are the exact rationals rounded once; 2/pi's bits feed the
Payne-Hanek reduction of large sin/cos arguments."""
from fractions import Fraction
from math import factorial

import mpmath

mpmath.mp.prec = 2000


def rounded(value, bits):
    """value (mpf) rounded to `bits` significant bits, as a Python float (exact)."""
    m, e = mpmath.frexp(value)
    return float(mpmath.ldexp(mpmath.nint(mpmath.ldexp(m, bits)), e - bits))


def parts(value, bits, count):
    out, rest = [], value
    for i in range(count):
        part = rounded(rest, bits if i < count - 1 else 53)
        out.append(part)
        rest -= mpmath.mpf(part)
    return out


def show(name, x):
    print("#define %s %s /* %r */" % (name, float(x).hex(), float(x)))


for i, p in enumerate(parts(mpmath.pi / 2, 33, 4)):
    show("UB__PIO2_%d" % (i + 1), p)
hi, lo = parts(mpmath.pi / 2, 53, 2)
show("UB__PIO2_HI", hi)
show("UB__PIO2_LO", lo)
show("UB__2_OVER_PI", rounded(2 / mpmath.pi, 53))
ln2 = parts(mpmath.log(2), 32, 2)
show("UB__LN2_HI", ln2[0])
show("UB__LN2_LO", ln2[1])
show("UB__INV_LN2", rounded(1 / mpmath.log(2), 53))
show("UB__SQRT2", rounded(mpmath.sqrt(2), 53))

print("/* log: 2/(2n+1), n = 1..12 */")
print(", ".join(float(Fraction(2, 2 * n + 1)).hex() for n in range(1, 13)))
print("/* sin: (-1)^n/(2n+1)!, n = 1..9 */")
print(", ".join(float(Fraction((-1) ** n, factorial(2 * n + 1))).hex() for n in range(1, 10)))
print("/* cos: (-1)^n/(2n)!, n = 2..10 */")
print(", ".join(float(Fraction((-1) ** n, factorial(2 * n))).hex() for n in range(2, 11)))
print("/* asin: (2n)!/(4^n n!^2 (2n+1)), n = 1..28 */")
print(", ".join(float(Fraction(factorial(2 * n), 4 ** n * factorial(n) ** 2 * (2 * n + 1))).hex()
                for n in range(1, 29)))
print("/* 2/pi: bits 1..1216 after the binary point, 64 per word */")
words = int(mpmath.floor(2 / mpmath.pi * mpmath.mpf(2) ** 1216))
print(", ".join("0x%016xu" % ((words >> (64 * (18 - i))) & (2 ** 64 - 1)) for i in range(19)))
print("/* exp: 2^(j/32) = hi + lo, j = 0..31 */")
for j in range(32):
    hi, lo = parts(mpmath.power(2, mpmath.mpf(j) / 32), 53, 2)
    print("{%s, %s}," % (hi.hex(), lo.hex()))
print("/* exp: 1/n!, n = 2..7 */")
print(", ".join(float(Fraction(1, factorial(n))).hex() for n in range(2, 8)))
