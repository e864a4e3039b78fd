/* Quaternion algebra in double precision (set-up code and references; the kernels inline
 * their own single-precision squaring). Components are (1, i, j, k). */
#ifndef UNBOUND_QUAT_H
#define UNBOUND_QUAT_H

/* Product a*b with ij = k, jk = i, ki = j and ji = -k, kj = -i, ik = -j (eq. 2-4). */
static inline void ub_quat_mul(const double a[4], const double b[4], double out[4])
{
    double r0 = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
    double r1 = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
    double r2 = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
    double r3 = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
    out[0] = r0; out[1] = r1; out[2] = r2; out[3] = r3;
}

static inline double ub_quat_norm2(const double a[4])
{
    return a[0] * a[0] + a[1] * a[1] + a[2] * a[2] + a[3] * a[3];
}

#endif
