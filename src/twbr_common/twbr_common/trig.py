"""sin and cos of one angle together, in plain arithmetic that the compiler vectorises.

libm's sin and cos are calls the compiler cannot vectorise (numba's SVML path is inoperative in the
numba we ship: benchmarks/README.md), and they were a quarter of a robot-step. `sincos` is Cephes'
sin.c/cos.c: Cody-Waite reduction by pi/2 in three parts, then the minimax polynomials on
[-pi/4, pi/4]; the quadrant is chosen by selects, not branches. It is within 2 ulp of libm for
|x| < 1e5 rad (test_trig) and returns NaN for NaN and +-inf. The reduction's integer is rounded by the
2^52 + 2^51 trick, so the whole function is arithmetic and comparisons: it runs interpreted too.
"""

from __future__ import annotations

from twbr_common.jit import lane_kernel

_ROUND = 6755399441055744.0  # 1.5 * 2^52: x + _ROUND - _ROUND rounds x to an integer (|x| < 2^51)
_TWO_OVER_PI = 0.63661977236758134308
_DP1 = 7.85398125648498535156e-1  # pi/4 = _DP1 + _DP2 + _DP3, the first two exact in few bits
_DP2 = 3.77489470793079817668e-8
_DP3 = 2.69515142907905952645e-15
_S0 = 1.58962301576546568060e-10
_S1 = -2.50507477628578072866e-8
_S2 = 2.75573136213857245213e-6
_S3 = -1.98412698295895385996e-4
_S4 = 8.33333333332211858878e-3
_S5 = -1.66666666666666307295e-1
_C0 = -1.13585365213876817300e-11
_C1 = 2.08757008419747316778e-9
_C2 = -2.75573141792967388112e-7
_C3 = 2.48015872888517045348e-5
_C4 = -1.38888888888730564116e-3
_C5 = 4.16666666666665929218e-2


@lane_kernel
def sincos(x: float) -> tuple[float, float]:
    """(sin x, cos x) [x in rad]."""
    n = (x * _TWO_OVER_PI + _ROUND) - _ROUND  # the nearest multiple of pi/2
    y = 2.0 * n  # in multiples of pi/4
    r = ((x - y * _DP1) - y * _DP2) - y * _DP3
    z = r * r
    s = r + r * z * (((((_S0 * z + _S1) * z + _S2) * z + _S3) * z + _S4) * z + _S5)
    c = 1.0 - 0.5 * z + z * z * (((((_C0 * z + _C1) * z + _C2) * z + _C3) * z + _C4) * z + _C5)
    q = n - 4.0 * ((n * 0.25 + _ROUND) - _ROUND)  # the quadrant: 0, 1, +-2 or -1 (n mod 4 = 3)
    half_turn = q == 2.0 or q == -2.0
    sin_x = c if q == 1.0 or q == -1.0 else s
    cos_x = s if q == 1.0 or q == -1.0 else c
    if half_turn or q == -1.0:
        sin_x = -sin_x
    if half_turn or q == 1.0:
        cos_x = -cos_x
    return sin_x, cos_x
