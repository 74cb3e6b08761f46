#!/usr/bin/env python3
"""The inputs of the method pages' worked examples (docs/src/methods/centreline.md,
volumetric.md, rtest.md, ssm.md), computed from the machines the pages describe with seeded
noise. From the repository root:

    cargo ncgen -- two-step host-tests/tests/data/docs/two_step_setup.toml --stations 3 --out /tmp/two-step.ngc
    python3 host-tests/tests/data/docs/make_inputs.py host-tests/tests/data/docs /tmp/two-step.ngc

writes dial.csv, dial_noiseless.csv, vector.csv, rtest_k4a.csv, rtest_k1.csv and
two_step_stream.csv (the pod's stream of the program's two SSM runs) into the directory. The
files are committed: each page's example is `cargo replay` of them, and host-tests/tests/docs.rs
runs it. The noise is the host tests' SplitMix64 + Box–Muller (host-tests/src/rng.rs), so a run
writes the same files. Standard library only.
"""

import math
import os
import re
import sys

MASK = (1 << 64) - 1


class Rng:
    """SplitMix64 with Box–Muller normals, as host-tests/src/rng.rs."""

    def __init__(self, seed):
        self.state = seed & MASK

    def next_u64(self):
        self.state = (self.state + 0x9E3779B97F4A7C15) & MASK
        z = self.state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
        return z ^ (z >> 31)

    def uniform(self):
        return ((self.next_u64() >> 11) + 0.5) / float(1 << 53)

    def normal(self):
        u1 = self.uniform()
        u2 = self.uniform()
        return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def normalize(a):
    n = math.sqrt(dot(a, a))
    return [x / n for x in a]


def rodrigues(d, t):
    """Right-handed rotation about d by t rad: I + sin t K + (1 − cos t) K²."""
    d = normalize(d)
    k = [[0.0, -d[2], d[1]], [d[2], 0.0, -d[0]], [-d[1], d[0], 0.0]]
    m = [[0.0] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(3):
            k2 = sum(k[i][l] * k[l][j] for l in range(3))
            m[i][j] = (1.0 if i == j else 0.0) + math.sin(t) * k[i][j] + (1.0 - math.cos(t)) * k2
    return m


def mul(m, v):
    return [dot(row, v) for row in m]


def num(x, decimals):
    """A number with `decimals` decimals, never `-0.000…`."""
    s = f"{x:.{decimals}f}"
    return s[1:] if s.startswith("-") and float(s) == 0.0 else s


# --- seed 004 dial gauge (centreline.md) -------------------------------------------------------


def dial(noise_um, seed):
    """The tilting axis normalize(150e-6, 1, −80e-6) (nominal +Y, primed: the table turns by −B),
    the block's top face with normal normalize(0.3e-3, −0.2e-3, 1) at B0, the gauge at five
    points of a 60 × 40 mm face at B 0/30/60/90°, reading along the face's nominal normal (+Z
    at B0, turned with the nominal axis)."""
    y, z = [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]
    d = normalize([150e-6, 1.0, -80e-6])
    n0 = normalize([0.3e-3, -0.2e-3, 1.0])
    rng = Rng(seed)
    out = ["b_deg,u_mm,v_mm,reading_um"]
    for b in (0.0, 30.0, 60.0, 90.0):
        t = -math.radians(b)
        n = mul(rodrigues(d, t), n0)
        w = normalize(mul(rodrigues(y, t), z))
        u = normalize([y[i] - dot(y, w) * w[i] for i in range(3)])
        v = cross(w, u)
        for pu, pv in ((0.0, 0.0), (60.0, 0.0), (0.0, 40.0), (60.0, 40.0), (30.0, 20.0)):
            # the face through the origin: its height along w at (pu, pv)
            h_mm = -(pu * dot(n, u) + pv * dot(n, v)) / dot(n, w)
            reading = h_mm * 1e3 + noise_um * rng.normal()
            out.append(f"{b:g},{pu:g},{pv:g},{num(reading, 4)}")
    return "\n".join(out) + "\n"


# --- seed 001 vector diagonal method (volumetric.md) ----------------------------------------

STEP_MM = [40.0, 30.0, 20.0]
START_MM = [-400.0, 100.0, -250.0]
N_STEPS = 10
# S_xy, S_yz, S_zx, µrad
SQUARENESS_URAD = [20.0, -15.0, 10.0]
# the straightness bows' heights mid-travel, µm: D_y(x), D_z(x), D_x(y), D_z(y), D_x(z), D_y(z)
BOW_UM = {(0, 1): 2.0, (0, 2): -1.5, (1, 0): 1.0, (1, 2): -2.5, (2, 0): 1.5, (2, 1): -1.0}


def d_um(u, i, p_mm):
    """D_i(u) at axis position p_mm, µm: pitch (i = u) 15 µm/m from the low corner plus a 1 µm
    sine wave over the travel; straightness a parabolic bow, zero at both ends (no trend)."""
    s = (p_mm - START_MM[u]) / (N_STEPS * STEP_MM[u])
    if i == u:
        return 15e-3 * (p_mm - START_MM[u]) + math.sin(2.0 * math.pi * s)
    return BOW_UM[(u, i)] * 4.0 * s * (1.0 - s)


def error_um(p):
    """Position error at p (FXYZ, no angular errors), µm: the nine curves with the squareness
    folded in as seed 001 eqs 8.58–8.60 (D_x(y) += S_xy·y, D_x(z) += S_zx·z, D_y(z) += S_yz·z)."""
    e = [sum(d_um(u, i, p[u]) for u in range(3)) for i in range(3)]
    sxy, syz, szx = (s * 1e-3 for s in SQUARENESS_URAD)  # µm per mm
    e[0] += sxy * p[1] + szx * p[2]
    e[1] += syz * p[2]
    return e


def vector(noise_um, seed):
    """Each diagonal's stops from its start corner, X, Y, Z stepped in turn, the deviation
    along the beam (the laser zeroed at the start) plus N(0, σ) per stop."""
    signs = [[1, 1, 1], [-1, 1, 1], [1, -1, 1], [1, 1, -1]]
    names = ["PPP", "NPP", "PNP", "PPN"]
    r = math.sqrt(sum(s * s for s in STEP_MM))
    rng = Rng(seed)
    out = ["diagonal,axis,deviation_um"]
    for s, name in zip(signs, names):
        beam = [s[i] * STEP_MM[i] / r for i in range(3)]
        idx = [0 if s[i] > 0 else N_STEPS for i in range(3)]

        def pos(idx):
            return [START_MM[i] + idx[i] * STEP_MM[i] for i in range(3)]

        e0 = error_um(pos(idx))

        def dev(idx):
            e = error_um(pos(idx))
            return sum(beam[i] * (e[i] - e0[i]) for i in range(3))

        out.append(f"{name},,{num(dev(idx) + noise_um * rng.normal(), 4)}")
        for _ in range(N_STEPS):
            for axis, letter in enumerate("XYZ"):
                idx[axis] += s[axis]
                out.append(f"{name},{letter},{num(dev(idx) + noise_um * rng.normal(), 4)}")
    return "\n".join(out) + "\n"


# --- seed 003 R-test (rtest.md) ---------------------------------------------------------------

# Table 3 geometry, mm
XW, YW, ZW, ZC = -217.504, -0.279, 211.537, 29.794
# Table 4: XOW YOW ZOW YOA ZOA (µm) BOA COA (″) XOC YOC (µm) AOC BOC (″)
TABLE4 = [-3.2, -21.6, -33.9, 20.5, 32.5, 12.3, -7.2, 1.4, -15.9, -6.5, -4.6]
ANGULAR = [False, False, False, False, False, True, True, False, False, True, True]
ARCSEC_RAD = math.pi / 648000.0


def table2_gains(a_deg, c_deg):
    """Seed 003 Table 2 (X_c = Y_c = 0): rows ΔX_p, ΔY_p, ΔZ_p; columns a1…a11 in mm per mm
    (offsets) and mm per rad (tilts)."""
    ca, sa = math.cos(math.radians(a_deg)), math.sin(math.radians(a_deg))
    cc, sc = math.cos(math.radians(c_deg)), math.sin(math.radians(c_deg))
    return [
        [-cc, sc, 0.0, 0.0, 0.0,
         -ca * (ZW + ZC) - sa * sc * XW - sa * cc * YW,
         -sa * (ZW + ZC) + ca * sc * XW + ca * cc * YW,
         -1.0, 0.0, 0.0, -ZW],
        [-ca * sc, -ca * cc, sa, -1.0, 0.0, 0.0, -cc * XW + sc * YW, 0.0, -ca,
         sc * sa * XW + cc * sa * YW + ca * ZW,
         -cc * sa * XW + sc * sa * YW],
        [-sa * sc, -sa * cc, -ca, 0.0, -1.0, -sc * YW + cc * XW, 0.0, 0.0, -sa,
         -cc * ca * YW + sa * ZW - sc * ca * XW,
         -sc * ca * YW + cc * ca * XW],
    ]


def rtest(poses, noise_um, seed):
    """The readings q = H·a (µm, probe − ball) of the Table 4 errors at each (A, C) pose, plus
    N(0, σ) per axis."""
    # µm of reading per µm (offsets) or per arc-second (tilts)
    per_unit = [ARCSEC_RAD * 1e3 if ang else 1.0 for ang in ANGULAR]
    rng = Rng(seed)
    out = ["a_deg,c_deg,dx_um,dy_um,dz_um"]
    for a, c in poses:
        h = table2_gains(a, c)
        q = [sum(h[k][j] * per_unit[j] * TABLE4[j] for j in range(11)) for k in range(3)]
        q = [x + noise_um * rng.normal() for x in q]
        out.append(f"{a + 0.0:.6g},{c + 0.0:.6g}," + ",".join(num(x, 4) for x in q))
    return "\n".join(out) + "\n"


# --- seed 000 two-step on an RRTTT head (ssm.md) --------------------------------------------

# the machine of scenario seed000_two_step_rrttt.toml
PIVOT_MM = [-50.0, -15.0, 500.0]
TOOL_Z_MM = -250.0
ALPHA_DEG, BETA_DEG = 30.0, 20.0
D_ALPHA_URAD, D_BETA_URAD = 120.0, -80.0
DV1_UM = [5.0, -3.0, 2.0]
BAR_MM = 150.0


def rx(a):
    c, s = math.cos(a), math.sin(a)
    return [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]


def ry(b):
    c, s = math.cos(b), math.sin(b)
    return [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def ball_mm(alpha, beta):
    """The tool ball from the pivot: Rx(α)·Ry(β)·(0, 0, z_r) (seed 000 eqs 2/4)."""
    return mul(matmul(rx(alpha), ry(beta)), [0.0, 0.0, TOOL_Z_MM])


def two_step_stream(program, noise_um, seed, rate_hz):
    """The pod's stream of the program's two SSM runs (`ncgen two-step`, LinuxCNC dialect): the
    machine follows its blocks at the feed without acceleration, sampled at rate_hz; a run from
    the first dwell to the end of the last (the blocks between `arm and start` and `stop the
    run`); the encoders read the programmed X Y Z to 0.1 µm, A and B as programmed; the ball is
    off by ΔV1 in run 1 and by ΔV1 + (R(α + Δα, β + Δβ) − R(α, β))·t in run 2; the socket stays
    where run 1's header puts it; the bar reads the distance to it with N(0, σ) per sample."""
    a, b = math.radians(ALPHA_DEG), math.radians(BETA_DEG)
    da, db = D_ALPHA_URAD * 1e-6, D_BETA_URAD * 1e-6
    c0 = ball_mm(0.0, 0.0)
    moved = [x - y for x, y in zip(ball_mm(a, b), c0)]  # c(α, β) − c(0)
    e2_um = [DV1_UM[i] + (ball_mm(a + da, b + db)[i] - ball_mm(a, b)[i]) * 1e3 for i in range(3)]
    rng = Rng(seed)
    dt = 1.0 / rate_hz
    runs, at, feed, rotary, run = [], None, None, [0.0, 0.0], None
    for line in program.splitlines():
        words = dict(re.findall(r"([A-Z])(-?[0-9.]+)", line)) if not line.startswith("(") else {}
        if "arm and start" in line:
            xyz = [float(v) for v in re.findall(r"ssm_socket X(-?[0-9.]+) Y(-?[0-9.]+) Z(-?[0-9.]+)", line)[0]]
            run = {"socket": xyz, "rotary": list(rotary), "segments": []}
        elif "stop the run" in line:
            runs.append(run)
            run = None
        elif line.startswith(("G0 ", "G1 ")):
            to = [float(words.get(k, at[i] if at else 0.0)) for i, k in enumerate("XYZ")]
            rotary = [float(words.get(k, rotary[i])) for i, k in enumerate("AB")]
            feed = float(words.get("F", feed or 0.0))
            if run is not None:
                run["segments"].append((at, to, feed))
            at = to
        elif line.startswith("G4 ") and run is not None:
            run["segments"].append((at, at, float(words["P"])))  # a dwell: P seconds
    out = []
    seq, t0 = 1000, 1.0
    for k, r in enumerate(runs):
        e_um = DV1_UM if k == 0 else e2_um
        # the socket where run 1's header puts it, in this run's programmed coordinates (the
        # ball at zero angles: after the rotation it is c(α, β) − c(0) from it)
        socket = [runs[0]["socket"][i] - (moved[i] if k == 1 else 0.0) for i in range(3)]
        # the positions at each sample time
        timeline, t = [], 0.0
        for p, q, f in r["segments"]:
            length = math.dist(p, q)
            duration = f if p == q else length / (f / 60.0)
            timeline.append((t, t + duration, p, q))
            t += duration
        n = int(t / dt + 1e-9) + 1
        header = [
            "# ballpod run v2", f"# run={k + 1}", "# pattern=SSM", "# direction=CCW",
            f"# bar_length={BAR_MM:g}", f"# sample_rate={rate_hz:g}",
            *(f"# ssm_socket_{a}={v:.4f}" for a, v in zip("xyz", r["socket"])),
            "# ts_machine=RRTTT", f"# ts_tool_z={TOOL_Z_MM:g}",
            *(f"# ts_origin_{a}={v:g}" for a, v in zip("xyz", PIVOT_MM)),
            f"# ts_angle_1={ALPHA_DEG:g}", f"# ts_angle_2={BETA_DEG:g}",
            "# axis_name3=A", "# axis_name4=B",
            "# source=stream",
            "seq,t_s,dl_um,x_mm,y_mm,z_mm,a_deg,b_deg,temp_c,flags",
        ]
        out += header
        seg = 0
        for j in range(n):
            tj = min(j * dt, t)
            while seg < len(timeline) - 1 and tj > timeline[seg][1]:
                seg += 1
            s0, s1, p, q = timeline[seg]
            w = 0.0 if s1 == s0 else (tj - s0) / (s1 - s0)
            pos = [p[i] + w * (q[i] - p[i]) for i in range(3)]
            ball = [pos[i] + e_um[i] * 1e-3 for i in range(3)]
            dl_um = (math.dist(ball, socket) - BAR_MM) * 1e3 + noise_um * rng.normal()
            enc = [num(round(v * 1e4) / 1e4, 4) for v in pos]
            out.append(
                f"{seq},{t0 + j * dt:.6f},{num(dl_um, 4)},{','.join(enc)},"
                f"{r['rotary'][0]:g},{r['rotary'][1]:g},20.00,0"
            )
            seq += 1
        out += ["# end=DONE", "# reason=NONE", f"# seen={n}", f"# used={n}"]
        out += [f"# {c}=0" for c in ("skipped_lvdt_open", "skipped_lvdt_over_range",
                                     "skipped_quadrature", "skipped_jump", "skipped_overrun",
                                     "lost", "temperature_faults", "after_overrun")]
        out.append("# stream_dropped=0")
        # the bar off, the rotation, the bar on again: a minute
        seq += int(60 * rate_hz)
        t0 += (n - 1) * dt + 60.0
    return "\n".join(out) + "\n"


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    out, program = sys.argv[1], sys.argv[2]
    with open(program) as f:
        program_text = f.read()
    files = {
        "dial.csv": dial(0.2, 27),
        "dial_noiseless.csv": dial(0.0, 27),
        "vector.csv": vector(0.2, 1),
        # K4a: A 0 → −90° while C turns 0 → 360°, 241 poses
        "rtest_k4a.csv": rtest([(-90.0 * i / 240, 360.0 * i / 240) for i in range(241)], 0.3, 26),
        # K1: A = 0, C 0 … 360° in 1° steps
        "rtest_k1.csv": rtest([(0.0, float(c)) for c in range(361)], 0.3, 126),
        # the pod's 1 kHz, 0.1 µm of bar noise
        "two_step_stream.csv": two_step_stream(program_text, 0.1, 28, 1000.0),
    }
    for name, text in files.items():
        with open(os.path.join(out, name), "w", newline="\n") as f:
            f.write(text)


if __name__ == "__main__":
    main()
