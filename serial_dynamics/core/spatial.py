"""Small inline helpers of the compiled core: sine and cosine, and
carrying 3-vectors and spatial forces between body frames (joint frames; spatial vectors
angular first, docs/conventions.md). Plain IEEE arithmetic, no fast-math: the same inputs
give the same bits whatever was compiled or inlined where."""
import math

from numba import njit

from .signatures import internal


def _pio2_parts():
    """pi/2 = C1 + C2 + C3 with C1, C2 of 26 significant bits, so that k*C1 and k*C2 are
    exact for |k| < 2^27 (Cody-Waite argument reduction)."""
    from decimal import Decimal, getcontext
    getcontext().prec = 60
    pio2 = Decimal("3.14159265358979323846264338327950288419716939937510582097494459") / 2

    def hi(x):                                  # x rounded down to 26 significant bits
        m, e = math.frexp(x)
        return math.ldexp(math.floor(math.ldexp(m, 26)), e - 26)

    c1 = hi(float(pio2))
    c2 = hi(float(pio2 - Decimal(c1)))
    return c1, c2, float(pio2 - Decimal(c1) - Decimal(c2)), float(1 / pio2)


_C1, _C2, _C3, _TWO_OVER_PI = _pio2_parts()
# Taylor coefficients (-1)^k / (2k+1)! (sine, r^3..r^17) and (-1)^k / (2k)! (cosine, r^4..r^18):
# on |r| <= pi/4 the first omitted terms are below 1e-19.
_S1, _S2, _S3, _S4, _S5, _S6, _S7, _S8 = [(-1.0) ** k / math.factorial(2 * k + 1) for k in range(1, 9)]
_K2, _K3, _K4, _K5, _K6, _K7, _K8, _K9 = [(-1.0) ** k / math.factorial(2 * k) for k in range(2, 10)]
SMALL_ANGLE = 1e5       # |q| below this: sincos; above (or NaN/Inf): libm


@njit(cache=True, inline="always")
def sincos(x):
    """(sin x, cos x) together, to ~1 ulp, for |x| < 1e5: x = k pi/2 + r, |r| <= pi/4,
    Taylor series in r (Estrin's scheme), quadrant by compares and selects (no branches).
    About half the cost of libm's sin and cos here, and vectorizable (rnea_lanes.py)."""
    k = math.floor(x * _TWO_OVER_PI + 0.5)
    r = ((x - k * _C1) - k * _C2) - k * _C3
    z = r * r
    z2 = z * z
    z4 = z2 * z2
    ps = ((_S1 + z * _S2) + z2 * (_S3 + z * _S4)) + z4 * ((_S5 + z * _S6) + z2 * (_S7 + z * _S8))
    pc = ((_K2 + z * _K3) + z2 * (_K4 + z * _K5)) + z4 * ((_K6 + z * _K7) + z2 * (_K8 + z * _K9))
    s = r + r * z * ps
    c = 1.0 - 0.5 * z + z2 * pc
    j = k - 4.0 * math.floor(0.25 * k)   # k mod 4, as a float
    odd = k - 2.0 * math.floor(0.5 * k) == 1.0
    ss = c if odd else s                 # sin(r + k pi/2): s, c, -s, -c for k = 0, 1, 2, 3
    cc = s if odd else c                 # cos(r + k pi/2): c, -s, -c, s
    return (-ss if j >= 2.0 else ss), (-cc if abs(j - 1.5) < 1.0 else cc)


@njit(cache=True, inline="always")
def rotation(R, i):
    """R_i as a tuple of nine numbers (row-major), to keep in registers through a loop."""
    return (R[i, 0, 0], R[i, 0, 1], R[i, 0, 2], R[i, 1, 0], R[i, 1, 1], R[i, 1, 2],
            R[i, 2, 0], R[i, 2, 1], R[i, 2, 2])


@njit(cache=True, inline="always")
def rotate_t(r, x, y, z):
    """R^T (x, y, z), R given by ``rotation``: a 3-vector into the child's frame."""
    return (r[0] * x + r[3] * y + r[6] * z, r[1] * x + r[4] * y + r[7] * z,
            r[2] * x + r[5] * y + r[8] * z)


@njit(cache=True, inline="always")
def rotate(r, x, y, z):
    """R (x, y, z), R given by ``rotation``: a 3-vector into the parent's frame."""
    return (r[0] * x + r[1] * y + r[2] * z, r[3] * x + r[4] * y + r[5] * z,
            r[6] * x + r[7] * y + r[8] * z)


@njit(cache=True, inline="always")
def force_to_parent(r, px, py, pz, nx, ny, nz, fx, fy, fz):
    """A spatial force (n_O; f) carried into the parent's frame by R (``rotation``) and p:
    f' = R f, n' = R n + p x f'  (Xup^T f, Featherstone 2008, eq. 2.24)."""
    gx, gy, gz = rotate(r, fx, fy, fz)
    mx, my, mz = rotate(r, nx, ny, nz)
    return mx + py * gz - pz * gy, my + pz * gx - px * gz, mz + px * gy - py * gx, gx, gy, gz


@internal
def to_child(R, i, x, y, z):
    """R_i^T (x, y, z): a 3-vector from body i-1's frame into body i's."""
    return rotate_t(rotation(R, i), x, y, z)


@internal
def to_parent(R, p, i, nx, ny, nz, fx, fy, fz):
    """A spatial force (n_O; f) of body i, in its frame, carried into body i-1's frame."""
    return force_to_parent(rotation(R, i), p[i, 0], p[i, 1], p[i, 2], nx, ny, nz, fx, fy, fz)


@internal
def finite(x):
    """0.0 for a finite x, NaN for NaN or Inf: summed into an entry point's check."""
    return x * 0.0
