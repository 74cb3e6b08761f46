"""The generated LinuxCNC part programs through LinuxCNC's own interpreter (`rs274 -g`,
Debian package linuxcnc-uspace): every program is accepted without an error, and the canonical
motion it produces matches the test's nominal geometry within 1 um — plane, centre, radius, the
data arc's start angle, span and direction, the overshoot, the radial feed-in and feed-out, the
feed. The geometry is rebuilt here from the canonical commands alone (LinuxCNC's ARC_FEED: ends
and centre in the selected plane's first and second axes, rotation +1 CCW / -1 CW seen from the
plane normal's positive end).

Run by .ci/run: BALLPOD_NCGEN=<the ncgen binary> python3 -m pytest host-tests/nc
"""
import math
import tomllib
import os
import pathlib
import re
import subprocess

import pytest

NCGEN = os.environ.get("BALLPOD_NCGEN")
TOL_MM = 1e-3  # 1 um
# canon plane -> (first, second, normal) axis indices (0 X, 1 Y, 2 Z)
CANON_PLANES = {"CANON_PLANE_XY": (0, 1, 2), "CANON_PLANE_YZ": (1, 2, 0), "CANON_PLANE_XZ": (2, 0, 1)}
# the pod's circle_plane -> (u, v, normal)
POD_PLANES = {"XY": (0, 1, 2), "YZ": (1, 2, 0), "ZX": (2, 0, 1)}
CANON = re.compile(r"^\s*\d+ N\.\.\.\.\. (\w+)\((.*)\)$")


def ncgen(tmp_path, setup, *args):
    """Writes the set-up file, runs ncgen; returns (exit code, stdout, stderr)."""
    assert NCGEN, "set BALLPOD_NCGEN to the ncgen binary"
    f = tmp_path / "setup.toml"
    f.write_text("[setup]\n" + "".join(f"{k} = {v!r}\n" if isinstance(v, str) else f"{k} = {v}\n"
                                       for k, v in setup.items()))
    p = subprocess.run([NCGEN, "circle", str(f), *args], capture_output=True, text=True, timeout=60)
    return p.returncode, p.stdout, p.stderr


def interpret(tmp_path, program):
    """rs274 -g on the program; every output line must be a canonical command."""
    f = tmp_path / "test.ngc"
    f.write_text(program)
    p = subprocess.run(["rs274", "-g", str(f)], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stdout + p.stderr
    cmds = []
    for line in p.stdout.splitlines():
        if line.strip() in ("", "executing"):
            continue
        m = CANON.match(line)
        assert m, f"rs274 said: {line}"
        args = [a.strip() for a in m.group(2).split(",")] if m.group(2) else []
        cmds.append((m.group(1), args))
    return cmds


def motion(cmds):
    """The moves: (kind, start, end, centre, rotation, feed) in X Y Z, plane from SELECT_PLANE."""
    pos, plane, feed, moves = [0.0, 0.0, 0.0], None, None, []
    for name, a in cmds:
        if name == "SELECT_PLANE":
            plane = a[0]
        elif name == "SET_FEED_RATE":
            feed = float(a[0])
        elif name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            end = [float(x) for x in a[:3]]
            moves.append((name, pos, end, None, 0, feed, plane))
            pos = end
        elif name == "ARC_FEED":
            first, second, normal = CANON_PLANES[plane]
            end, centre = [0.0] * 3, list(pos)
            end[first], end[second], end[normal] = float(a[0]), float(a[1]), float(a[5])
            centre[first], centre[second] = float(a[2]), float(a[3])
            moves.append(("ARC_FEED", pos, end, centre, int(a[4]), feed, plane))
            pos = end
    return moves


def angle(p, c, plane):
    """Angle of p about c in the pod's plane (u towards v), degrees."""
    u, v, _ = POD_PLANES[plane]
    return math.degrees(math.atan2(p[v] - c[v], p[u] - c[u]))


def span(move, plane):
    """Signed angle an arc sweeps, degrees (a full turn when its ends coincide)."""
    _, start, end, centre, rot, _, _ = move
    d = angle(end, centre, plane) - angle(start, centre, plane)
    if rot > 0:
        d = d % 360.0 or 360.0
    else:
        d = -((-d) % 360.0 or 360.0)
    return d


CASES = [
    # plane, centre (x, y, z; None: not set), radius, feed, start, arc
    ("XY", (0.0, 0.0, None), 150.0, 1000.0, 0.0, 360.0),
    ("XY", (12.5, -40.0, -20.0), 100.0, 2000.0, 30.0, 220.0),
    ("YZ", (5.0, 0.0, 300.0), 150.0, 1000.0, 0.0, 360.0),
    ("YZ", (None, 10.0, 250.0), 150.0, 500.0, -45.0, 90.0),
    ("ZX", (0.0, 0.0, 200.0), 150.0, 1000.0, 0.0, 360.0),
    ("ZX", (-30.0, 7.0, 180.0), 300.0, 1500.0, 90.0, 220.0),
]


@pytest.mark.parametrize("plane,centre,radius,feed,start,arc", CASES)
def test_programs_are_accepted_and_trace_the_nominal_circle(tmp_path, plane, centre, radius, feed,
                                                            start, arc):
    setup = {"circle_plane": plane, "circle_radius": radius, "bar_length": radius, "circle_feed": feed}
    for k, c in zip("xyz", centre):
        if c is not None:
            setup[f"circle_centre_{k}"] = c
    rc, program, err = ncgen(tmp_path, setup, "--start-deg", str(start), "--arc-deg", str(arc))
    assert rc == 0, err
    check_circle_program(tmp_path, program, plane, centre, radius, feed, start, arc)


def check_circle_program(tmp_path, program, plane, centre, radius, feed, start, arc):
    """Through rs274: the data arcs and overshoots on the nominal circle in the plane, CCW then
    CW, the feed-ins and feed-outs radial, no rapid once the bar is on."""
    moves = motion(interpret(tmp_path, program))
    u, v, w = POD_PLANES[plane]
    canon_plane = {"XY": "CANON_PLANE_XY", "YZ": "CANON_PLANE_YZ", "ZX": "CANON_PLANE_XZ"}[plane]
    def r_of(m):
        return math.hypot(m[1][u] - m[3][u], m[1][v] - m[3][v])
    arcs = [m for m in moves if m[0] == "ARC_FEED" and abs(r_of(m) - radius) < 0.01]
    assert len(arcs) == 4, "data arc and overshoot, CCW then CW"
    # between the runs: back to the feed-in point along the path just run, at the feed-in
    # radius (never a straight move across the circle, which would crush the bar)
    back = [m for m in moves if m[0] == "ARC_FEED" and abs(r_of(m) - radius) >= 0.01]
    assert len(back) == 1
    assert r_of(back[0]) == pytest.approx(radius + 1.0, abs=TOL_MM)
    assert back[0][4] == -1, "CW: retracing the CCW run"
    assert span(back[0], plane) == pytest.approx(-((arc + 45.0) % 360.0), abs=1e-4)
    assert moves[moves.index(back[0]) - 1][0] == "STRAIGHT_FEED", "after the CCW feed-out"
    assert not any(m[0] == "STRAIGHT_TRAVERSE" for m in moves[moves.index(arcs[0]):]), \
        "no rapid once the bar is on"
    for k, (direction, rot) in enumerate([("CCW", 1), ("CW", -1)]):
        data, over = arcs[2 * k], arcs[2 * k + 1]
        for m in (data, over):
            assert m[6] == canon_plane
            assert m[4] == rot, f"{direction}: rotation"
            assert m[5] == pytest.approx(feed), "feed"
            for axis in (u, v):
                assert m[3][axis] == pytest.approx(centre[axis], abs=TOL_MM), "centre"
            for p in (m[1], m[2]):
                r = math.hypot(p[u] - m[3][u], p[v] - m[3][v])
                assert r == pytest.approx(radius, abs=TOL_MM), "radius"
                if centre[w] is not None:
                    assert p[w] == pytest.approx(centre[w], abs=TOL_MM), "out of plane"
        a0 = angle(data[1], data[3], plane)
        assert (a0 - start + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-4), "start"
        assert span(data, plane) == pytest.approx(rot * arc, abs=1e-4), "data arc"
        assert span(over, plane) == pytest.approx(rot * 45.0, abs=1e-4), "overshoot"
        # the radial feed-in before the data arc and the feed-out after the overshoot
        i = moves.index(data)
        feed_in, feed_out = moves[i - 1], moves[i + 2]
        assert feed_in[0] == feed_out[0] == "STRAIGHT_FEED"
        for m, on_circle, outside in ((feed_in, feed_in[2], feed_in[1]), (feed_out, feed_out[1], feed_out[2])):
            c = data[3]
            assert math.hypot(outside[u] - c[u], outside[v] - c[v]) == pytest.approx(radius + 1.0, abs=TOL_MM)
            assert math.hypot(on_circle[u] - c[u], on_circle[v] - c[v]) == pytest.approx(radius, abs=TOL_MM)
            assert angle(outside, c, plane) == pytest.approx(angle(on_circle, c, plane), abs=1e-4), "radial"


def test_the_three_plane_programs_trace_each_plane_and_name_its_set_up(tmp_path):
    """`ncgen three-planes`: XY full circle, YZ and ZX 220° arcs from −20°, each program through
    rs274 on its nominal circle, each set-up file the pod's fields for that plane."""
    assert NCGEN, "set BALLPOD_NCGEN to the ncgen binary"
    centre, radius, feed = (10.0, -20.0, 250.0), 150.0, 1000.0
    f = tmp_path / "setup.toml"
    f.write_text(f"[setup]\ncircle_centre_x = {centre[0]}\ncircle_centre_y = {centre[1]}\n"
                 f"circle_centre_z = {centre[2]}\ncircle_radius = {radius}\nbar_length = {radius}\n"
                 f"circle_feed = {feed}\n")
    out = tmp_path / "planes"
    p = subprocess.run([NCGEN, "three-planes", str(f), "--out-dir", str(out)],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    for k, (plane, start, arc) in enumerate([("XY", 0.0, 360.0), ("YZ", -20.0, 220.0),
                                             ("ZX", -20.0, 220.0)]):
        check_circle_program(tmp_path, (out / f"{plane}.ngc").read_text(), plane, centre, radius,
                             feed, start, arc)
        fields = tomllib.loads((out / f"ballpod-setup-{1000 + k}.toml").read_text())["setup"]
        assert fields["circle_plane"] == k and fields["circle_arc"] == arc, fields
        if arc < 360.0:
            assert fields["circle_min_arc"] == arc, fields
    # a set-up without the Z of the centre cannot run YZ: refused, nothing written
    f.write_text(f.read_text().replace(f"circle_centre_z = {centre[2]}\n", ""))
    p = subprocess.run([NCGEN, "three-planes", str(f), "--out-dir", str(tmp_path / "none")],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode != 0 and "circle_centre_z" in p.stderr, p.stderr
    assert not (tmp_path / "none").exists()


@pytest.mark.parametrize("setup,field", [
    ({"circle_plane": "XY", "circle_centre_x": 0.0, "circle_centre_y": 0.0, "circle_feed": 1000.0}, "circle_radius"),
    ({"circle_plane": "XY", "circle_centre_x": 0.0, "circle_radius": 150.0, "circle_feed": 1000.0}, "circle_centre_y"),
    ({"circle_plane": "ZX", "circle_centre_x": 0.0, "circle_centre_y": 0.0, "circle_radius": 150.0,
      "circle_feed": 1000.0}, "circle_centre_z"),
    ({"circle_plane": "XY", "circle_centre_x": 0.0, "circle_centre_y": 0.0, "circle_radius": 150.0}, "circle_feed"),
])
def test_a_set_up_the_machine_cannot_run_is_refused_naming_the_field(tmp_path, setup, field):
    out = tmp_path / "never.ngc"
    rc, program, err = ncgen(tmp_path, setup, "--out", str(out))
    assert rc == 1 and program == ""
    assert field in err, err
    assert not out.exists(), "nothing written"


def test_options_out_of_range_are_refused(tmp_path):
    setup = {"circle_plane": "XY", "circle_centre_x": 0.0, "circle_centre_y": 0.0,
             "circle_radius": 150.0, "circle_feed": 1000.0}
    for opt, value in [("--arc-deg", "0"), ("--arc-deg", "361"), ("--overshoot-deg", "-1"),
                       ("--feed-in-mm", "0")]:
        rc, program, err = ncgen(tmp_path, setup, opt, value)
        assert rc == 1 and program == "" and opt in err, (opt, err)


SPHERES = [
    # centre (stylus-ball centre on the sphere), contact radius, B, C
    ((10.0, -20.0, 35.0), 14.2, 0.0, 0.0),
    ((-150.0, 42.5, 310.0), 14.2, 90.0, 0.0),
    ((0.0, 0.0, 0.0), 8.0, 0.0, 270.0),
]


@pytest.mark.parametrize("centre,contact,b,c", SPHERES)
def test_sphere_programs_probe_along_the_normals_and_nothing_else_nears_the_sphere(
        tmp_path, centre, contact, b, c):
    assert NCGEN, "set BALLPOD_NCGEN to the ncgen binary"
    p = subprocess.run([NCGEN, "sphere", "--centre", *map(str, centre), "--contact-radius",
                        str(contact), "--b-deg", str(b), "--c-deg", str(c)],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    cmds = interpret(tmp_path, p.stdout)
    # every canonical move with its start and end (A B C are arguments 4-6)
    pos, moves = [0.0] * 6, []
    for name, a in cmds:
        if name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "STRAIGHT_PROBE"):
            end = [float(x) for x in a[:6]]
            moves.append((name, pos, end))
            pos = end
    probes = [m for m in moves if m[0] == "STRAIGHT_PROBE"]
    assert len(probes) == 9, "nine touches"
    normals = set()
    for _, start, end in probes:
        assert (start[4], start[5]) == (pytest.approx(b), pytest.approx(c)), "B, C held"
        ds = math.dist(start[:3], centre)
        de = math.dist(end[:3], centre)
        assert ds == pytest.approx(contact + 0.5, abs=TOL_MM), "from 0.5 mm outside"
        assert de == pytest.approx(contact - 0.5, abs=TOL_MM), "to 0.5 mm inside"
        n = [(s - k) / ds for s, k in zip(start[:3], centre)]
        m = [(e - k) / de for e, k in zip(end[:3], centre)]
        assert all(abs(x - y) < 1e-5 for x, y in zip(n, m)), "along the normal"
        assert n[2] > -1e-9, "upper hemisphere (the stem blocks the lower)"
        normals.add(tuple(round(x, 4) for x in n))
    assert len(normals) == 9, "nine different normals"
    # no move but a probing one and its retract comes inside the contact sphere plus the
    # clearance (after the first two: the rotary axes turning and the rapid over the sphere,
    # from wherever the program starts)
    assert [m[0] for m in moves[:2]] == ["STRAIGHT_TRAVERSE"] * 2
    assert moves[0][2][:3] == moves[0][1][:3], "the rotary axes turn alone first"
    for k, (name, start, end) in enumerate(moves):
        if k < 2 or name == "STRAIGHT_PROBE":
            continue
        if moves[k - 1][0] == "STRAIGHT_PROBE":
            # the retract from wherever the probe stopped (the interpreter assumes the end
            # point; the stylus stops at the contact): back to that touch's approach point
            assert end[:3] == pytest.approx(moves[k - 1][1][:3], abs=TOL_MM), "retract"
            continue
        d = [e - s for s, e in zip(start[:3], end[:3])]
        dd = sum(x * x for x in d)
        t = 0.0 if dd == 0 else max(0.0, min(1.0, sum((k - s) * x for s, k, x in zip(start[:3], centre, d)) / dd))
        closest = [s + t * x for s, x in zip(start[:3], d)]
        assert math.dist(closest, centre) >= contact + 0.5 - TOL_MM, (name, start, end)


def test_a_sphere_with_no_size_is_refused(tmp_path):
    p = subprocess.run([NCGEN, "sphere", "--centre", "0", "0", "0", "--contact-radius", "0"],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 1 and p.stdout == "" and "--contact-radius" in p.stderr


# The seed 002 set-up of the thesis (Table 4.3), with the model frame moved in the machine.
S002 = {"s002_l_b": 100.0, "s002_r_b": 356.3945, "s002_r_b2": 406.4608, "s002_r_c": 50.0,
        "s002_z_c": 65.5348, "s002_origin_x": -490.0, "s002_origin_y": 12.5, "s002_origin_z": -112.2605}


def pattern_program(tmp_path, pattern, setup, *args):
    assert NCGEN, "set BALLPOD_NCGEN to the ncgen binary"
    f = tmp_path / "setup.toml"
    f.write_text("[setup]\n" + "".join(f"{k} = {v}\n" for k, v in setup.items()))
    return subprocess.run([NCGEN, "pattern", pattern, str(f), *args], capture_output=True,
                          text=True, timeout=60)


def balls(p, pattern):
    """The nominal machine's T-ball and W-ball centres (model frame, mm) at axis position
    p = (X, Y, Z, A, B, C): the spindle head turns about B (its pivot at X Y Z, the T-ball R_B
    below it along the tool at B = 0, R'_B for CR2); the W-ball sits on the C table, at its centre
    for the B patterns and R_C out for the C patterns, and turns with C."""
    x, y, z = (p[0] - S002["s002_origin_x"], p[1] - S002["s002_origin_y"], p[2] - S002["s002_origin_z"])
    b, c = math.radians(p[4]), math.radians(p[5])
    rb = S002["s002_r_b2"] if pattern == "CR2" else S002["s002_r_b"]
    t = (x - rb * math.sin(b), y, z - rb * math.cos(b))
    rc = 0.0 if pattern in ("BX", "BY") else S002["s002_r_c"]
    w = (rc * math.cos(c), rc * math.sin(c), S002["s002_z_c"])
    return t, w


@pytest.mark.parametrize("pattern", ["BX", "BY", "CR", "CA", "CR2"])
def test_pattern_programs_keep_the_bar_at_its_length_through_the_whole_turn(tmp_path, pattern):
    p = pattern_program(tmp_path, pattern, S002)
    assert p.returncode == 0, p.stderr
    cmds = interpret(tmp_path, p.stdout)
    moves = [(n, [float(x) for x in a[:6]]) for n, a in cmds
             if n in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED")]
    assert moves[0][0] == "STRAIGHT_TRAVERSE" and all(n == "STRAIGHT_FEED" for n, _ in moves[1:]), \
        "one rapid to the mounting point, then feed moves only"
    quarter = pattern in ("BX", "BY")
    rotary = 4 if quarter else 5
    # the blocks per run the header states: the thesis's 324 per quarter / 1296 per revolution,
    # or a doubling of it that keeps the joint-space interpolation error within 0.05 um
    steps = int(re.search(r"\((\d+) blocks per run", p.stdout).group(1))
    thesis = 324 if quarter else 1296
    assert steps % thesis == 0 and (steps // thesis) & (steps // thesis - 1) == 0, steps
    # the rapid to the start, then CCW and CW, each run's steps (a run starts where the machine is)
    assert len(moves) == 1 + 2 * steps
    for _, p6 in moves:
        t, w = balls(p6, pattern)
        assert math.dist(t, w) == pytest.approx(S002["s002_l_b"], abs=TOL_MM), p6
        if quarter:
            # the T-ball stays put while the head turns about it
            t0, _ = balls(moves[0][1], pattern)
            assert math.dist(t, t0) < TOL_MM
    angles = [p6[rotary] for _, p6 in moves]
    span = 90.0 if quarter else 360.0
    # B: 90 -> 0 is CCW in the pod's XZ plane; C: 0 -> 360 is CCW; then back
    first, last = (span, 0.0) if quarter else (0.0, span)
    assert (angles[0], angles[steps], angles[2 * steps]) == (
        pytest.approx(first), pytest.approx(last), pytest.approx(first))
    for a, b in zip(angles, angles[1:]):
        assert abs(b - a) == pytest.approx(span / steps, abs=1e-3), "even steps"
    # the other rotary axis does not move
    other = 5 if quarter else 4
    assert all(p6[other] == pytest.approx(0.0) for _, p6 in moves)


def test_a_pattern_set_up_without_a_length_is_refused_naming_the_field(tmp_path):
    setup = dict(S002)
    del setup["s002_r_c"]
    p = pattern_program(tmp_path, "CR", setup)
    assert p.returncode == 1 and p.stdout == "" and "s002_r_c" in p.stderr, p.stderr
    p = pattern_program(tmp_path, "CIRCLE", S002)
    assert p.returncode == 1 and p.stdout == "" and "PATTERN" in p.stderr, p.stderr


SSM_CASES = [
    # socket, target, separation, stations
    ((0.0, 0.0, -150.0), (0.0, 0.0, 0.0), 10.0, 4),
    ((100.0, -50.0, 20.0), (180.0, -50.0, 147.0), 5.0, 3),
    ((-20.0, 30.0, 0.0), (-20.0, 200.0, 30.0), 20.0, 8),
]


@pytest.mark.parametrize("socket,target,separation,stations", SSM_CASES)
def test_ssm_station_sets_dwell_on_the_sphere_and_move_on_it(tmp_path, socket, target, separation,
                                                             stations):
    bar = 150.0
    f = tmp_path / "ssm.toml"
    f.write_text("[setup]\n" + f"bar_length = {bar}\n" + "".join(
        f"ssm_socket_{k} = {v}\n" for k, v in zip("xyz", socket)))
    p = subprocess.run([NCGEN, "ssm", str(f), "--target", *map(str, target),
                        "--separation-deg", str(separation), "--stations", str(stations)],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    cmds = interpret(tmp_path, p.stdout)
    pos, dwells, feeds = None, [], []
    for name, a in cmds:
        if name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            nxt = [float(x) for x in a[:6]]
            assert nxt[3:] == [0.0, 0.0, 0.0], "the rotary axes are not moved"
            if name == "STRAIGHT_FEED":
                feeds.append((pos, nxt[:3]))
            pos = nxt[:3]
        elif name == "DWELL":
            dwells.append((pos, float(a[0])))
    r = lambda q: math.dist(q, socket)
    # the pod's defaults: settle 100 ms + 2 x 100 samples at 1 kHz = 0.3 s
    assert len(dwells) == stations and all(t >= 0.3 for _, t in dwells), dwells
    for q, _ in dwells:
        assert abs(r(q) - bar) < TOL_MM, q
    u = [[(q[k] - socket[k]) / bar for k in range(3)] for q, _ in dwells]
    # the first station towards the target, the others `separation` from it
    def angle(a, b):
        """The angle between two vectors, degrees (atan2: well conditioned near 0)."""
        c = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
        return math.degrees(math.atan2(math.hypot(*c), sum(x * y for x, y in zip(a, b))))
    to = [target[k] - socket[k] for k in range(3)]
    assert angle(u[0], to) < 1e-4
    for d in u[1:]:
        assert abs(angle(u[0], d) - separation) < 1e-4
    # every move on the sphere: its ends within 1 um, its chord's middle within 1 um inside
    for a, b in feeds:
        mid = [(x + y) / 2 for x, y in zip(a, b)]
        assert abs(r(a) - bar) < TOL_MM and abs(r(b) - bar) < TOL_MM
        assert bar - r(mid) < TOL_MM + 1e-4, (a, b)


def docs_block(marker, lang):
    """The first fenced `lang` block after `marker` in the one page of README.md and docs/src/
    that holds it (the docs' examples run)."""
    root = pathlib.Path(__file__).resolve().parents[2]
    pages = [root / "README.md", *sorted((root / "docs" / "src").rglob("*.md"))]
    holding = [p.read_text() for p in pages if marker in p.read_text()]
    assert len(holding) == 1, f"{marker} in {len(holding)} pages"
    rest = holding[0][holding[0].index(marker):]
    start = rest.index("```" + lang + "\n") + len(lang) + 4
    return rest[start:rest.index("```", start)]


def test_a_program_corrected_for_centrelines_moves_as_its_comments_say(tmp_path):
    # seed 004 4.3: a program of X Y Z A B points corrected with the docs' centrelines file
    # is accepted by rs274, moves through as many points, A and B as programmed, X Y Z moved by
    # what each block's comment states (um, to the words' 0.1 um)
    assert NCGEN, "set BALLPOD_NCGEN to the ncgen binary"
    lines = tmp_path / "centrelines.toml"
    lines.write_text(docs_block("**Centrelines file**", "toml"))
    program = tmp_path / "groove.ngc"
    program.write_text("G21 G90 G94\n" + "".join(
        f"G0 X-58.72 Y{-60.71 + 8 * k} Z258.75 A{60 * k} B{25 * k}\n"
        f"G1 X-18.72 F500\n" for k in range(4)) + "M2\n")
    corrected = tmp_path / "groove_corrected.ngc"
    p = subprocess.run([NCGEN, "correct-centrelines", str(program), str(lines), "--out",
                        str(corrected)], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr

    def points(path):
        out = []
        for name, a in interpret(tmp_path, path.read_text()):
            if name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
                out.append([float(x) for x in a[:5]])
        return out

    moved = [[float(v) for v in line.split("(moved X ")[1].split(" um")[0]
              .replace("Y ", "").replace("Z ", "").split()]
             for line in corrected.read_text().splitlines() if "(moved X " in line]
    before, after = points(program), points(corrected)
    assert len(before) == len(after) == len(moved) == 8
    assert max(abs(m) for ms in moved for m in ms) > 100, "the lines move the points"
    for b, a, m in zip(before, after, moved):
        assert a[3:] == b[3:], "A and B as programmed"
        for k in range(3):
            assert abs((a[k] - b[k]) * 1e3 - m[k]) <= 0.06, (b, a, m)


TWO_STEP = {
    # machine: its set-up lines
    "RRTTT": ("ts_origin_x = -50\nts_origin_y = -15\nts_origin_z = 500\nts_tool_z = -250\n"
              "ts_angle_1 = 20\nts_angle_2 = 30\n"),
    "RTTTR_SPINDLE": ("ts_origin_x = -50\nts_origin_y = -15\nts_origin_z = 500\nts_tool_z = -250\n"
                      "ts_angle_1 = 20\n"),
    "TTTRR": ("ts_origin_x = -30\nts_origin_y = 15\nts_origin_z = 120\nts_z_alpha_gamma = 80\n"
              "ts_reference_x = 60\nts_reference_y = -20\nts_reference_z = 30\n"
              "ts_angle_1 = 15\nts_angle_2 = 40\n"),
    "RTTTR_TABLE": ("ts_origin_x = -30\nts_origin_y = 15\nts_origin_z = 120\n"
                    "ts_reference_x = 60\nts_reference_y = -20\nts_reference_z = 30\nts_angle_1 = 15\n"),
}


def rot(axis, deg, v):
    """Right-handed rotation of v about X, Y or Z by deg."""
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    x, y, z = v
    return {"X": (x, c * y - s * z, s * y + c * z), "Y": (c * x + s * z, y, -s * x + c * z),
            "Z": (c * x - s * y, s * x + c * y, z)}[axis]


def chain(machine, a, b, c):
    """The ball from the origin (seed 000 eqs 2/4, 13/15, 8, 14/16) at the words A, B, C."""
    if machine == "RRTTT":
        return rot("X", a, rot("Y", b, (0.0, 0.0, -250.0)))
    if machine == "RTTTR_SPINDLE":
        return rot("Y", b, (0.0, 0.0, -250.0))
    r = (60.0, -20.0, 30.0)
    if machine == "TTTRR":
        q = rot("Z", c, r)
        return rot("X", a, (q[0], q[1], q[2] + 80.0))
    return rot("X", a, r)


@pytest.mark.parametrize("machine", list(TWO_STEP))
def test_two_step_programs_stay_on_the_bar_sphere_through_the_interpreter(tmp_path, machine):
    # seed 000's two-step through rs274: accepted; the operator stops (mount, bar off, mount);
    # every interpreted point of both runs puts the ball (the chain at the rotary words, the
    # programmed point being the ball at zero angles) at the bar's length from the header's
    # socket within 1 um; 2 x 4 dwells; the rotary axes move once, between the runs
    assert NCGEN, "set BALLPOD_NCGEN to the ncgen binary"
    bar = 150.0
    setup = tmp_path / "ts.toml"
    setup.write_text(f'[setup]\nts_machine = "{machine}"\nbar_length = {bar}\n' + TWO_STEP[machine])
    p = subprocess.run([NCGEN, "two-step", str(setup)], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    program = p.stdout
    head = program.splitlines()[2]
    socket = [float(w[1:].rstrip(",)")) for w in head.split("socket ")[1].split()[:3]]
    cmds = interpret(tmp_path, program)
    assert sum(1 for n, _ in cmds if n == "PROGRAM_STOP") == 3
    assert sum(1 for n, _ in cmds if n == "DWELL") == 8
    c0 = chain(machine, 0.0, 0.0, 0.0)
    rotations, last_rot = 0, None
    for name, a in cmds:
        if name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            x, y, z, aa, bb, cc = (float(v) for v in a[:6])
            if last_rot is not None and (aa, bb, cc) != last_rot:
                rotations += 1
            last_rot = (aa, bb, cc)
            ch = chain(machine, aa, bb, cc)
            ball = (x - c0[0] + ch[0], y - c0[1] + ch[1], z - c0[2] + ch[2])
            assert abs(math.dist(ball, socket) - bar) < TOL_MM, (name, a)
    assert rotations == 1


def test_a_program_beyond_the_set_up_travel_is_refused_and_nothing_written(tmp_path):
    # the set-up file's [travel]: the R 150 circle needs X to reach ±151 (the feed-in); a
    # travel of ±120 is refused naming travel.x_mm, and no file is written; with room it passes
    assert NCGEN, "set BALLPOD_NCGEN to the ncgen binary"
    base = ('[setup]\ncircle_plane = "XY"\ncircle_centre_x = 0.0\ncircle_centre_y = 0.0\n'
            "circle_radius = 150.0\ncircle_feed = 1000.0\n")
    for travel, ok in (("x_mm = [-120.0, 120.0]", False), ("x_mm = [-152.0, 152.0]\ny_mm = [-152.0, 152.0]", True)):
        f = tmp_path / "setup.toml"
        f.write_text(base + "\n[travel]\n" + travel + "\n")
        out = tmp_path / "circle.ngc"
        p = subprocess.run([NCGEN, "circle", str(f), "--out", str(out)], capture_output=True, text=True,
                           timeout=60)
        if ok:
            assert p.returncode == 0, p.stderr
            assert out.exists()
            out.unlink()
        else:
            assert p.returncode == 1 and "travel.x_mm" in p.stderr, p.stderr
            assert not out.exists(), "nothing written"
