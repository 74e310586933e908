"""Which physics explains the UFSC beam's bending frequencies? (docs/studies/real_beam.md)

A 2-D Euler-Bernoulli FE beam (32 elements, consistent mass, the hammer test's 6 g accelerometer at
x = 0.1 m) fitted by least squares to the hammer test's AutoEMA frequencies, once per candidate
term. Needs numpy and scipy: `python3 docs/studies/real_beam_physics.py` prints the table;
`--pitch` adds the frame that also pitches, against one more free parameter of other kinds.
A rolling frame (rotation about the beam axis) acts on torsion only: by the section's symmetry it
leaves every bending frequency of this model where it is.
"""
import sys

import numpy as np
import scipy.linalg as sl
import scipy.optimize as so

L, b, h, rho = 0.8, 0.05, 0.005, 7880.0
A, I, NE = b * h, b * h**3 / 12, 32
HAMMER = [17.13, 69.19, 155.64, 265.55, 414.50, 567.61]  # B1..B6, AutoEMA (hammer)
AUTHOR = [17.212, 68.840, 155.391, 265.219, 414.118, 567.539]  # the author's report
F118 = 118.56  # the mode whose ends move


HAMMER_SET_UP = ((0.1, 0.006),)  # (x m, kg): the accelerometer fixed at point 3
SHAKER_SET_UP = ((0.05, 0.010),)  # the force gauge's beam-side mass at point 2, no fixed accelerometer


def frequencies(E, kz, kry, N=0.0, frame=None, under=None, nm=9, masses=HAMMER_SET_UP, mend=0.0,
                pitch=None, vectors=False):
    """Lowest nm frequencies, Hz. kz, kry: per end (left, right). N: axial force, tension > 0
    (geometric stiffness N/(30 l)[...]). frame = (mass, mount k): both ends on one z-only body;
    under = (mass, k): a z-only mass on a spring under each end; masses: point masses (x, kg) on
    the beam; mend: a point mass at each end, above its spring. pitch = (J_y, mount k_theta): the
    frame also pitches about its cg at mid-span (seats at z -+ (L/2) phi, k_ry then acts between
    beam end and frame). vectors: also return the mode shapes (columns) and M."""
    extra = (2 if pitch else 1) if frame else (2 if under else 0)
    n0 = 2 * (NE + 1)
    K, M, l = np.zeros((n0 + extra,) * 2), np.zeros((n0 + extra,) * 2), L / NE
    ke = E * I / l**3 * np.array([[12, 6*l, -12, 6*l], [6*l, 4*l*l, -6*l, 2*l*l],
                                  [-12, -6*l, 12, -6*l], [6*l, 2*l*l, -6*l, 4*l*l]])
    kg = N / (30 * l) * np.array([[36, 3*l, -36, 3*l], [3*l, 4*l*l, -3*l, -l*l],
                                  [-36, -3*l, 36, -3*l], [3*l, -l*l, -3*l, 4*l*l]])
    me = rho * A * l / 420 * np.array([[156, 22*l, 54, -13*l], [22*l, 4*l*l, 13*l, -3*l*l],
                                       [54, 13*l, 156, -22*l], [-13*l, -3*l*l, -22*l, 4*l*l]])
    for e in range(NE):
        s = slice(2 * e, 2 * e + 4)
        K[s, s] += ke + kg
        M[s, s] += me
    for end, (w, th) in enumerate([(0, 1), (n0 - 2, n0 - 1)]):
        K[th, th] += kry[end]
        seat = n0 if frame else (n0 + end if under else None)
        K[w, w] += kz[end]
        if seat is not None:
            K[seat, seat] += kz[end]
            K[w, seat] -= kz[end]
            K[seat, w] -= kz[end]
        if pitch:  # seat z = z_f + a phi, a = -+ L/2; k_ry on theta - phi
            a, f = (-L / 2, L / 2)[end], n0 + 1
            K[f, f] += kz[end] * a * a + kry[end]
            K[w, f] -= kz[end] * a
            K[f, w] -= kz[end] * a
            K[n0, f] += kz[end] * a
            K[f, n0] += kz[end] * a
            K[th, f] -= kry[end]
            K[f, th] -= kry[end]
    if frame:
        M[n0, n0] += frame[0]
        K[n0, n0] += frame[1]
    if pitch:
        M[n0 + 1, n0 + 1] += pitch[0]
        K[n0 + 1, n0 + 1] += pitch[1]
    if under:
        for s in (n0, n0 + 1):
            M[s, s] += under[0]
            K[s, s] += under[1]
    for x, m in masses:
        M[2 * round(x / l), 2 * round(x / l)] += m
    M[0, 0] += mend
    M[n0 - 2, n0 - 2] += mend
    w2, v = sl.eigh(K, M, subset_by_index=[0, nm - 1])
    f = np.sqrt(np.maximum(w2, 0)) / (2 * np.pi)
    return (f, v, M) if vectors else f


def errors(f, targets):
    """% error of the model mode nearest each target, each model mode used once."""
    used, out = set(), []
    for t in targets:
        k = min((i for i in range(len(f)) if i not in used), key=lambda i: abs(f[i] - t))
        used.add(k)
        out.append(100 * (f[k] / t - 1))
    return np.array(out)


def fit(model, x0, lo, hi, targets):
    """Least squares from x0 and three moved starts (support springs softer, stiffer; k_ry
    larger); the best of the four."""
    starts = []
    for i, d in [(None, 0), (1, -1), (1, 1), (2, 2)]:
        s = np.array(x0, float)
        if i is not None:
            s[i] += d
        starts.append(np.clip(s, lo, hi))
    best = min((so.least_squares(lambda x: errors(model(x), targets), s, bounds=(lo, hi))
                for s in starts), key=lambda r: r.cost)
    return best.x, errors(model(best.x), targets)


CASES = {
    "elastic ends (k_z, k_ry)": (lambda x: frequencies(10**x[0], [10**x[1]] * 2, [10**x[2]] * 2),
                                 [11.28, 6.3, 0.0], [11, 4, -3], [11.5, 10, 4], HAMMER),
    "+ axial force N": (lambda x: frequencies(10**x[0], [10**x[1]] * 2, [10**x[2]] * 2, N=x[3]),
                        [11.28, 6.3, 0.0, 0.0], [11, 4, -3, -700], [11.5, 10, 4, 700], HAMMER),
    "the author's frequencies, + N": (lambda x: frequencies(10**x[0], [10**x[1]] * 2, [10**x[2]] * 2, N=x[3]),
                                      [11.28, 6.3, 0.0, 0.0], [11, 4, -3, -700], [11.5, 10, 4, 700], AUTHOR),
    "+ a mass on a spring under each end": (
        lambda x: frequencies(10**x[0], [10**x[1]] * 2, [10**x[2]] * 2, under=(10**x[3], 10**x[4])),
        [11.28, 6.3, 0.0, 0.7, 6.5], [11, 4, -3, -2, 4], [11.5, 11, 4, 1.5, 9], HAMMER + [F118]),
    "ends on one bouncing frame, 10 kg": (
        lambda x: frequencies(10**x[0], [10**x[1]] * 2, [10**x[2]] * 2, frame=(10.0, 10**x[3])),
        [11.28, 6.3, 0.0, 6.7], [11, 4, -3, 5], [11.5, 11, 4, 8], HAMMER + [F118]),
}

def strip_factor(n, nu=0.29):
    """Kirchhoff plate strip (width b, free long edges, simply supported ends) against the
    Euler-Bernoulli beam: f_plate/f_beam of mode n (Levy solution w = Y(y) sin(n pi x/L),
    Y = A cosh(s1 y) + B cosh(s2 y), s^2 = k^2 +- mu^2; free edges M_y = V_y = 0). Tends to 1 as
    kb -> 0 (anticlastic bending free), to 1/sqrt(1 - nu^2) as kb -> inf."""
    k, c = n * np.pi / L, b / 2

    def det(mu):
        s1, s2 = np.sqrt(k * k + mu * mu), np.sqrt(k * k - mu * mu)
        return ((s1**2 - nu * k * k) * np.cosh(s1 * c) * (s2**3 - (2 - nu) * k * k * s2) * np.sinh(s2 * c)
                - (s2**2 - nu * k * k) * np.cosh(s2 * c) * (s1**3 - (2 - nu) * k * k * s1) * np.sinh(s1 * c))
    mu = so.brentq(det, (1 - nu**2) ** 0.25 * k * (1 + 1e-9), k * (1 - 1e-9))
    return np.sqrt(mu**4 / ((1 - nu**2) * k**4))


SHAKER_VS_HAMMER = [2.80, 2.05, 0.35, 0.29, -0.12, -0.14]  # AutoEMA, shaker/hammer - 1, %


def set_ups():
    """The documented differences of the shaker set-up (force gauge at point 2 instead of the
    accelerometer at point 3) on the frame model fitted to the hammer test: % per bending mode."""
    model, x0, lo, hi, targets = CASES["ends on one bouncing frame, 10 kg"]
    x, _ = fit(model, x0, lo, hi, targets)
    args = (10**x[0], [10**x[1]] * 2, [10**x[2]] * 2)
    f_h = frequencies(*args, frame=(10.0, 10**x[3]))
    f_s = frequencies(*args, frame=(10.0, 10**x[3]), masses=SHAKER_SET_UP)
    bending = [i for i in range(8) if abs(f_h[i] - F118) > 5][:6]
    return 100 * (f_s[bending] / f_h[bending] - 1)


FRAME = CASES["ends on one bouncing frame, 10 kg"]
PITCH_J = (0.02, 0.1, 0.5, 1.0)  # kg m^2 scanned; a 10 kg bar of the beam's length: 0.53


def pitch_fit(J):
    """The bouncing frame that also pitches (inertia J about y through mid-span, mount k_theta):
    E, k_z, k_ry, frame k_z, k_theta fitted (five), J fixed. The errors jump where modes swap
    partners, so k_theta is profiled (the other four fitted at each k_theta from 1e4 to 1e9
    N m/rad, tenth decades, each from the last and from the frame fit) and the best point refined
    with all five free. Returns x, errors, the frequencies and each mode's share of kinetic energy
    in the frame's pitch."""
    model = lambda x: frequencies(10**x[0], [10**x[1]] * 2, [10**x[2]] * 2, frame=(10.0, 10**x[3]),
                                  pitch=(J, 10**x[4]))
    _, x0, lo, hi, targets = FRAME
    x4, _ = fit(FRAME[0], x0, lo, hi, targets)
    profile, prev = [], x4
    for k in np.arange(4, 9.01, 0.1):  # continuation in k_theta, and a restart from the frame fit
        prev = min((so.least_squares(lambda x: errors(model(np.r_[x, k]), targets), s, bounds=(lo, hi))
                    for s in (prev, x4)), key=lambda r: r.cost).x
        profile.append((k, prev, np.sum(errors(model(np.r_[prev, k]), targets) ** 2)))
    k, x4, _ = min(profile, key=lambda p: p[2])
    best = so.least_squares(lambda x: errors(model(x), targets), np.r_[x4, k], bounds=(lo + [2], hi + [10]))
    f, v, M = frequencies(10**best.x[0], [10**best.x[1]] * 2, [10**best.x[2]] * 2, frame=(10.0, 10**best.x[3]),
                          pitch=(J, 10**best.x[4]), nm=12, vectors=True)
    kinetic = np.einsum("ij,ik,kj->j", v, M, v)
    return best.x, errors(model(best.x), targets), f, J * v[2 * (NE + 1) + 1] ** 2 / kinetic


def one_more(kind):
    """The frame model with one more free parameter of another kind (five fitted, as with pitch):
    'mass' the frame's mass, 'kz' the two ends' k_z apart, 'mend' a mass at each end."""
    _, x0, lo, hi, targets = FRAME
    x4, _ = fit(FRAME[0], x0, lo, hi, targets)
    if kind == "mass":
        model, extra, b = (lambda x: frequencies(10**x[0], [10**x[1]] * 2, [10**x[2]] * 2,
                                                 frame=(10**x[4], 10**x[3]))), (0.5, 1, 1.5), (-1, 2)
    elif kind == "kz":
        model, extra, b = (lambda x: frequencies(10**x[0], [10**x[1], 10**x[4]], [10**x[2]] * 2,
                                                 frame=(10.0, 10**x[3]))), (x4[1] - 0.5, x4[1], x4[1] + 0.5), (4, 11)
    else:
        model, extra, b = (lambda x: frequencies(10**x[0], [10**x[1]] * 2, [10**x[2]] * 2,
                                                 frame=(10.0, 10**x[3]), mend=10**x[4])), (-3, -2, -1.5), (-4, -0.5)
    best = min((so.least_squares(lambda x: errors(model(x), targets), np.r_[x4, e],
                                 bounds=(lo + [b[0]], hi + [b[1]])) for e in extra), key=lambda r: r.cost)
    return best.x, errors(model(best.x), targets)


if __name__ == "__main__":
    n = np.arange(1, 7)
    f = frequencies(186e9, [1e14] * 2, [0] * 2, N=-0.1 * np.pi**2 * 186e9 * I / L**2)[:6]
    f0 = frequencies(186e9, [1e14] * 2, [0] * 2)[:6]
    # Known answer: pinned-pinned under compression P = 0.1 P_Euler, f_n ∝ n sqrt(n² - P).
    print("preload check, f(P)/f(0) / sqrt(1 - P/n²):", np.round(f / f0 / np.sqrt(1 - 0.1 / n**2), 4))
    for name, (model, x0, lo, hi, targets) in CASES.items():
        x, e = fit(model, x0, lo, hi, targets)
        print(f"{name:40s} E {10**x[0] / 1e9:5.1f} GPa  x {np.round(x[1:], 2)}  B1..B6 % {np.round(e[:6], 2)}"
              + (f"  118.6 Hz {e[6]:+.2f} %" if len(e) > 6 else ""))
    # The beam as a plate strip: smooth in n, so the support springs absorb it (a fit with it
    # leaves the errors within 0.05 % of the beam's).
    print("plate strip f/f_beam, B1..B6 %:", np.round([100 * (strip_factor(n) - 1) for n in range(1, 7)], 2))
    # A mass above each end's spring (clamp, bolt): the scan, hammer frequencies.
    for mend in (0.01, 0.024):
        model = lambda x: frequencies(10**x[0], [10**x[1]] * 2, [10**x[2]] * 2, frame=(10.0, 10**x[3]), mend=mend)
        x, e = fit(model, [11.28, 6.3, 0.0, 6.7], [11, 4, -3, 5], [11.5, 11, 4, 8], HAMMER + [F118])
        print(f"frame 10 kg + {1000 * mend:.0f} g at each end {'':12s} B1..B6 % {np.round(e[:6], 2)}")
    print("shaker set-up vs hammer set-up, model, B1..B6 %:", np.round(set_ups(), 2),
          " measured:", SHAKER_VS_HAMMER)
    # The frame also pitches (docs/studies/real_beam.md, "Which physics"): five fitted parameters
    # and J scanned, against the frame model with one more free parameter of another kind (1 min).
    if "--pitch" not in sys.argv:
        sys.exit()
    rms = lambda e: np.sqrt(np.mean(e[:6] ** 2))
    x, e = fit(*FRAME)
    print(f"frame (four fitted) {'':18s} x {np.round(x, 2)}  B1..B6 % {np.round(e[:6], 2)}  max {np.abs(e[:6]).max():.2f}"
          f"  rms {rms(e):.2f}")
    for kind, name in (("mass", "frame mass free"), ("kz", "k_z left, right apart"), ("mend", "a mass at each end free")):
        x, e = one_more(kind)
        print(f"frame + {name:29s} x {np.round(x, 2)}  B1..B6 % {np.round(e[:6], 2)}  max {np.abs(e[:6]).max():.2f}"
              f"  rms {rms(e):.2f}")
    for J in PITCH_J:
        x, e, f, share = pitch_fit(J)
        p = int(np.argmax(share))
        print(f"frame + pitch, J {J:4.2f} kg m2 E {10**x[0] / 1e9:5.1f} GPa  x {np.round(x[1:], 2)}  B1..B6 % {np.round(e[:6], 2)}"
              f"  max {np.abs(e[:6]).max():.2f}  rms {rms(e):.2f}  118.6 Hz {e[6]:+.2f} %  pitch mode {f[p]:.0f} Hz"
              f" ({100 * share[p]:.0f} % pitch), largest pitch share of a paired mode {100 * share[:7].max():.0f} %")
