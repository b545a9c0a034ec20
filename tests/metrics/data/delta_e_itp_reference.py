#!/usr/bin/python3
"""Independent Delta E_ITP values for tests/metrics/delta_e_itp_test.cpp (run once, printed).

Written apart from metrics/src/delta_e_itp.cpp and deliberately by another route where the
standards allow one: the Rec. 709 -> Rec. 2020 matrix is derived here from the primaries' and
D65's chromaticities (ITU-R BT.709-6 Table 1 item 1.3, BT.2020-2 Table 3, SMPTE RP 177 normalised
primary matrices) instead of typed from BT.2087's four-decimal table; LMS and ICtCp (BT.2100-2
Tables 6 and 7) and PQ (SMPTE ST 2084) are definitions, typed again from the standards.
Usage: /usr/bin/python3 tests/metrics/data/delta_e_itp_reference.py
"""
import numpy as np


def npm(primaries, white):
    """RP 177: the RGB -> XYZ matrix whose columns are the primaries scaled to give the white."""
    xyz = np.array([[x / y, 1.0, (1.0 - x - y) / y] for x, y in primaries]).T
    w = np.array([white[0] / white[1], 1.0, (1.0 - white[0] - white[1]) / white[1]])
    return xyz * np.linalg.solve(xyz, w)


D65 = (0.3127, 0.3290)
REC709 = [(0.640, 0.330), (0.300, 0.600), (0.150, 0.060)]
REC2020 = [(0.708, 0.292), (0.170, 0.797), (0.131, 0.046)]
M709_TO_2020 = np.linalg.solve(npm(REC2020, D65), npm(REC709, D65))

LMS = np.array([[1688, 2146, 262], [683, 2951, 462], [99, 309, 3688]]) / 4096.0
ICTCP = np.array([[2048, 2048, 0], [6610, -13613, 7003], [17933, -17390, -543]]) / 4096.0


def pq(cd_m2):
    m1, m2 = 2610 / 16384, 2523 / 4096 * 128
    c1, c2, c3 = 3424 / 4096, 2413 / 4096 * 32, 2392 / 4096 * 32
    y = np.clip(np.asarray(cd_m2, dtype=float) / 10000.0, 0.0, 1.0) ** m1
    return ((c1 + c2 * y) / (1 + c3 * y)) ** m2


def itp(rgb709_cd_m2):
    i, ct, cp = ICTCP @ pq(np.maximum(LMS @ (M709_TO_2020 @ np.asarray(rgb709_cd_m2)), 0.0))
    return np.array([i, 0.5 * ct, cp])  # BT.2124: T = 0.5 Ct, P = Cp.


def delta_e_itp(a, b):
    return 720.0 * np.linalg.norm(itp(a) - itp(b))


# Pairs in linear Rec. 709 relative units; 1.0 = 100 cd/m^2 (the metric's default).
PAIRS = [
    ((0.8, 0.2, 0.1), (0.7, 0.25, 0.1)),   # saturated red vs an orange shift
    ((0.1, 0.3, 0.9), (0.1, 0.3, 0.6)),    # blue, less blue
    ((0.5, 0.5, 0.5), (0.5, 0.45, 0.55)),  # grey vs a slight purple
    ((4.0, 3.0, 1.0), (3.0, 3.0, 1.5)),    # HDR highlight, 400 cd/m^2 red channel
]
if __name__ == "__main__":
    print("709 -> 2020 matrix from chromaticities:\n", np.array2string(M709_TO_2020, precision=6))
    print("PQ(100 cd/m^2) =", repr(float(pq(100.0))), " PQ(50) =", repr(float(pq(50.0))))
    for a, b in PAIRS:
        print(a, b, "%.6f" % delta_e_itp(100.0 * np.array(a), 100.0 * np.array(b)))
