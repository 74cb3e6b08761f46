"""The technician's desk (`cargo desk`, host-tests/src/desk) against the served pod: machines,
tolerances, an ISO 230-4 circle pair run from the desk with the live trace growing, the pod's
results against the desk's replay of the recorded stream and against the `replay` binary on the
stream the desk exports, ISO 14253-1 decisions against this file's own statement of the rule,
the trend over three runs, the report, and bad input (fields named, a second desk refused,
loopback only, a pod lost mid-run kept and marked)."""
import csv
import glob
import io
import itertools
import json
import os
import pathlib
import shutil
import signal
import socket
import sqlite3
import subprocess
import tempfile
import time
import urllib.error
import urllib.request

import pytest

from conftest import host_binary
from podlib import SerialBridge

pytestmark = pytest.mark.desk


class Postgres:
    """A private PostgreSQL server on loopback (Debian's postgresql: initdb and pg_ctl, run as
    the postgres user when the tests run as root), stopped and started at will; each `database()`
    is a new, empty database on it. .ci/run installs the package and sets
    $BALLPOD_REQUIRE_POSTGRES, so that CI fails rather than skips when the server is missing."""

    names = itertools.count(1)

    def __init__(self):
        bins = sorted(glob.glob("/usr/lib/postgresql/*/bin/pg_ctl"))
        if not bins:
            if os.environ.get("BALLPOD_REQUIRE_POSTGRES"):
                raise AssertionError("PostgreSQL's server (Debian postgresql) is not installed")
            pytest.skip("PostgreSQL's server (Debian postgresql) is not installed")
        self.bin = pathlib.Path(bins[-1]).parent
        self.dir = pathlib.Path(tempfile.mkdtemp(prefix="ballpod-pg-"))
        self.dir.chmod(0o755)
        self.as_user = []
        if os.geteuid() == 0:
            shutil.chown(self.dir, "postgres")
            self.as_user = ["runuser", "-u", "postgres", "--"]
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            self.port = s.getsockname()[1]
        subprocess.run(self.as_user + [str(self.bin / "initdb"), "-D", str(self.dir / "data"), "-A", "trust",
                                       "-U", "postgres", "--no-sync"], check=True, capture_output=True)
        self.start()

    def start(self):
        subprocess.run(self.as_user + [str(self.bin / "pg_ctl"), "-D", str(self.dir / "data"), "-w", "-l",
                                       str(self.dir / "log"), "-o",
                                       f"-c listen_addresses=127.0.0.1 -p {self.port} -k {self.dir}", "start"],
                       check=True, capture_output=True)

    def stop(self):
        subprocess.run(self.as_user + [str(self.bin / "pg_ctl"), "-D", str(self.dir / "data"), "-m", "immediate",
                                       "-w", "stop"], check=True, capture_output=True)

    def database(self):
        name = f"desk{next(self.names)}"
        subprocess.run([str(self.bin / "createdb"), "-h", "127.0.0.1", "-p", str(self.port), "-U", "postgres", name],
                       check=True, capture_output=True)
        return f"postgres://postgres@127.0.0.1:{self.port}/{name}"

    def close(self):
        subprocess.run(self.as_user + [str(self.bin / "pg_ctl"), "-D", str(self.dir / "data"), "-m", "immediate",
                                       "stop"], capture_output=True)
        shutil.rmtree(self.dir, ignore_errors=True)


@pytest.fixture(scope="module")
def postgres():
    server = Postgres()
    yield server
    server.close()


@pytest.fixture(params=["sqlite", "postgres"])
def history(request, tmp_path):
    """Where a desk keeps its history: an SQLite file, or a database on a PostgreSQL server."""
    if request.param == "sqlite":
        return str(tmp_path / "desk.sqlite")
    return request.getfixturevalue("postgres").database()


class Desk:
    """A desk process on a history (a fresh SQLite file unless `db` names one), its page's URL,
    and JSON calls to its API."""

    def __init__(self, tmp_path, pod=None, db=None, link=None):
        cmd = [host_binary("desk"), "--db", db or str(tmp_path / "desk.sqlite"), "--spool", str(tmp_path / "spool"),
               "--port", "0"]
        if link:
            cmd += link
        elif pod:
            cmd += ["--pod-usb", str(pod["usb_port"]), "--pod-stream", str(pod["stream_port"])]
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     start_new_session=True)
        line = self.proc.stdout.readline()
        assert line, self.proc.stderr.read()
        self.url = json.loads(line)["url"]

    def call(self, path, body=None, headers=None):
        """(status, parsed JSON or text) of a GET, or a POST of `body` as JSON."""
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(self.url + path.lstrip("/"), data=data, headers={
            "content-type": "application/json", **(headers or {})})
        try:
            with urllib.request.urlopen(req, timeout=30) as r:
                status, raw, kind = r.status, r.read(), r.headers.get("content-type", "")
        except urllib.error.HTTPError as e:
            status, raw, kind = e.code, e.read(), e.headers.get("content-type", "")
        return status, json.loads(raw) if "json" in kind else raw.decode()

    def ok(self, path, body=None):
        status, j = self.call(path, body)
        assert status == 200, (path, status, j)
        return j

    def close(self):
        os.killpg(self.proc.pid, signal.SIGKILL)
        self.proc.wait(timeout=10)


def call_raw(desk, path, body):
    """POSTs bytes as they are (a file import); the run id."""
    req = urllib.request.Request(desk.url + path.lstrip("/"), data=body, method="POST")
    with urllib.request.urlopen(req, timeout=60) as r:
        return json.loads(r.read())["run_id"]


def decision(value, big_u, lower, upper):
    """ISO 14253-1:2017 §5 (the default rule), stated here independently of the desk's code."""
    if (upper is not None and value - big_u > upper) or (lower is not None and value + big_u < lower):
        return "does_not_conform"
    if (upper is None or value + big_u <= upper) and (lower is None or value - big_u >= lower):
        return "conforms"
    return "undecided"


TRACEABILITY = {"bar_serial": 40712, "bar_certificate": 2026117, "bar_calibrated": 20260315, "lvdt_serial": 9931}


def run_circle_pair(desk, machine_id, watch=False, meanwhile=None):
    """Starts a circle pair from the desk (the bar's traceability fields set with it) and waits
    for its end; the live sample counts seen."""
    setup = dict(TRACEABILITY, circle_plane="XY", circle_radius=150, circle_feed=1000)
    test = desk.ok("/api/tests", {"machine_id": machine_id, "operator": "A. Tester", "test": "circle",
                                  "setup": setup})["test"]
    seen = []
    t0 = time.time()
    while True:
        live = desk.ok("/api/live")
        assert live["test"] == test
        if live["finished"]:
            run_id = live["run_id"]
            assert run_id is not None, live
            break
        if meanwhile and live["trace"]["samples"] > 1000:
            (status, e), pod_info = meanwhile()
            assert status == 400 and "a test is running" in e["error"], e
            assert pod_info["identity"].startswith("BALLPOD,")
            meanwhile = None
        if watch and live["trace"]["samples"]:
            # "run 1 of 2 (CIRCLE CCW): the machine moves"
            seen.append((live["step"].split(":")[0], live["trace"]["samples"], len(live["trace"]["points"]),
                         live["trace"]["lost"]))
        assert time.time() - t0 < 120, live
        time.sleep(0.1)
    assert meanwhile is None, "the run ended before the checks to make while it ran"
    return run_id, seen


def test_a_circle_pair_from_the_desk_with_decisions_trend_and_report(pod, tmp_path, history):
    desk = Desk(tmp_path, pod, history)
    try:
        assert desk.ok("/api/pod")["identity"].startswith("BALLPOD,")
        # a second desk on the same pod is refused, as the pod refuses a second client
        second = subprocess.run([host_binary("desk"), "--db", str(tmp_path / "other.sqlite"), "--port", "0",
                                 "--pod-usb", str(pod["usb_port"]), "--pod-stream", str(pod["stream_port"])],
                                capture_output=True, text=True, timeout=30)
        assert second.returncode != 0 and "another program" in second.stderr, second

        # machines: a missing name and a duplicate are named
        assert desk.call("/api/machines", {"name": " "}) == (400, {"error": "machine name is missing"})
        mid = desk.ok("/api/machines", {"name": "DMU 50 #3", "builder": "DMG MORI", "model": "DMU 50",
                                        "serial": "12345", "kinematics": "table-table B/C",
                                        "axes": "X Y Z B C", "travel": "X 500, Y 450, Z 400 mm"})["id"]
        status, e = desk.call("/api/machines", {"name": "DMU 50 #3"})
        assert status == 400 and "exists already" in e["error"]
        # bad test input is named, nothing starts
        # (the set-up is checked by the core's own configuration rules, as the pod checks it)
        for setup, words in [({"circle_plane": "XZ"}, "circle_plane = \"XZ\" is not one of XY, YZ, ZX"),
                             ({"circle_radius": -5}, "circle_radius = -5 is outside"),
                             ({"circle_feed": "fast"}, "circle_feed = \"fast\": the field takes a number"),
                             ({"circle_radius_mm": 150}, "\"circle_radius_mm\" is not a configuration field")]:
            status, e = desk.call("/api/tests", {"machine_id": mid, "operator": "A", "test": "circle", "setup": setup})
            assert status == 400 and words in e["error"], (setup, e)
        status, e = desk.call("/api/tests", {"machine_id": mid, "operator": "A", "test": "spiral"})
        assert status == 400 and "spiral" in e["error"], e
        assert desk.call("/api/tests", {"machine_id": 99, "operator": "A", "test": "circle"})[0] == 404
        status, e = desk.call(f"/api/machines/{mid}/tolerances", {"figure": "G_nope", "upper": 1})
        assert status == 400 and "G_nope" in e["error"]
        status, e = desk.call(f"/api/machines/{mid}/tolerances", {"figure": "G_ccw", "lower": 2, "upper": 1})
        assert status == 400 and "lower limit" in e["error"]

        # the run, its trace growing while the machine moves; a second test is refused while
        # it runs, and the page still answers
        run_id, seen = run_circle_pair(desk, mid, watch=True, meanwhile=lambda: (
            desk.call("/api/tests", {"machine_id": mid, "operator": "B", "test": "circle"}),
            desk.ok("/api/pod")))
        for run in ("run 1 of 2 (CIRCLE CCW)", "run 2 of 2 (CIRCLE CW)"):
            counts = [n for r, n, _, _ in seen if r == run]
            assert len(set(counts)) >= 3 and counts == sorted(counts), (run, seen)
        assert max(p for _, _, p, _ in seen) > 100 and all(lost == 0 for *_, lost in seen), seen

        view = desk.ok(f"/api/runs/{run_id}")
        assert view["run"]["state"] == "done", view["run"]
        # the desk's replay of the stream equals the pod's printed results, digit for digit
        assert view["run"]["replay_check"] == "", view["run"]["replay_check"]
        pod_results = {f["name"]: f for f in view["run"]["pod_results"]}
        figures = {f["name"]: f for f in view["figures"]}
        assert len(pod_results) >= 40 and set(pod_results) == set(figures)
        for name, p in pod_results.items():
            assert figures[name]["value"] == pytest.approx(p["value"], abs=6e-5), name
        # the stream the desk kept, replayed by the replay binary: the same figures
        (tmp_path / "run.stream").write_bytes(urllib.request.urlopen(desk.url + f"api/runs/{run_id}/stream").read())
        out = subprocess.run([host_binary("replay"), str(tmp_path / "run.stream"), "--out", str(tmp_path / "out")],
                             capture_output=True, text=True)
        assert out.returncode == 0, out.stderr
        replayed = {f["name"]: f for f in json.loads((tmp_path / "out" / "results.json").read_text())["results"]}
        assert set(replayed) == set(figures)
        for name, f in replayed.items():
            assert figures[name]["value"] == pytest.approx(f["value"], rel=1e-6, abs=1e-9), name
        # and the truth: the socket offset s reads as the eccentricity e = -s
        s_u, s_v = pod["truth"]["machine"]["circle"]["socket_offset_um"]
        for name, truth in [("ecc_u", -s_u), ("ecc_v", -s_v)]:
            assert abs(figures[name]["value"] - truth) <= max(4 * figures[name]["u"], 0.05), name

        # tolerances on each side of a figure and inside its U; the decisions follow the rule
        def big_u(name):
            return figures[name]["expanded_u"]
        limits = {
            "G_ccw": (None, figures["G_ccw"]["value"] + 3 * big_u("G_ccw")),   # inside by 2U
            "G_cw": (None, figures["G_cw"]["value"] - 3 * big_u("G_cw")),      # outside by 2U
            "F_max_ccw": (None, figures["F_max_ccw"]["value"] + 0.5 * big_u("F_max_ccw")),  # within U
            "ecc_u": (figures["ecc_u"]["value"] - 2 * big_u("ecc_u"), figures["ecc_u"]["value"] + 2 * big_u("ecc_u")),
            "ecc_v": (figures["ecc_v"]["value"] + 0.5 * big_u("ecc_v"), figures["ecc_v"]["value"] + 9 * big_u("ecc_v")),
        }
        for name, (lo, hi) in limits.items():
            desk.ok(f"/api/machines/{mid}/tolerances", {"figure": name, "lower": lo, "upper": hi})
        view = desk.ok(f"/api/runs/{run_id}")
        decided = {f["name"]: f["decision"] for f in view["figures"] if f["decision"]}
        expected = {n: decision(figures[n]["value"], big_u(n), lo, hi) for n, (lo, hi) in limits.items()}
        assert decided == expected
        assert sorted(set(expected.values())) == ["conforms", "does_not_conform", "undecided"]
        # U = k·u: k = 2 where no degrees of freedom are stated
        assert figures["G_ccw"]["expanded_u"] == pytest.approx(2 * figures["G_ccw"]["u"])

        # two more runs: the trend shows three points
        for _ in range(2):
            assert desk.ok(f"/api/runs/{run_circle_pair(desk, mid)[0]}")["run"]["state"] == "done"
        status, svg = desk.call(f"/api/trend.svg?machine={mid}&figure=G_ccw")
        assert status == 200 and svg.count('class="point"') == 3 and 'class="limit"' in svg
        assert len(desk.ok(f"/api/runs?machine={mid}")) == 3

        # the report: conditions, polar plot, figures ± U with decisions, trend, traceability
        status, html = desk.call(f"/report/{run_id}")
        assert status == 200
        assert "<svg" in html and 'id="figures"' in html and "DMU 50 #3" in html and "A. Tester" in html
        assert desk.ok("/api/pod")["identity"] in html
        assert html.count('class="point"') == 3 * len(limits)
        # traceability: the bar's fields as the run's header carried them, in the report and in
        # results.json
        assert ("serial 40712, calibration certificate 2026117 of 2026-03-15; LVDT serial 9931"
                in html), html.split('id="trace"', 1)[1]
        runs_json = json.loads((tmp_path / "out" / "results.json").read_text())["runs"]
        assert all(r["instrument"] == TRACEABILITY for r in runs_json)
        # the diagnoses name the served machine's faults (its truth), largest share first, and
        # no other: out-of-squareness, scale mismatch, both axes' reversals, the cyclic error
        c = pod["truth"]["machine"]["circle"]
        assert c["squareness_urad"] and c["scale_x_um_per_m"] != c["scale_y_um_per_m"]
        assert c["backlash_x_um"] and c["backlash_y_um"] and c["cyclic_amplitude_um"]
        assert not any(c[k] for k in ("straightness_x_along_y_um", "straightness_y_along_x_um", "lateral_play_x_um",
                                      "lateral_play_y_um", "vibration_x_um", "stick_slip_x_um"))
        items = html.split('<ul id="diagnoses">', 1)[1].split("</ul>", 1)[0].split("<li>")[1:]
        named = sorted(i.split(":")[0] for i in items)
        assert named == ["cyclic error", "out-of-squareness", "reversal steps of X", "reversal steps of Y",
                         "scale mismatch"], items
        shares = [float(i.split(": ")[1].split(" µm")[0]) for i in items]
        assert shares == sorted(shares, reverse=True)
        for name, want in expected.items():
            row = html.split(f'<tr data-name="{name}" class="{want}">', 1)
            assert len(row) == 2, name
            assert row[1].split('class="value">', 1)[1].startswith(f'{figures[name]["value"]:.4f}'[:-1]), name

        # the part program the desk offers is ncgen's for the same set-up
        setup = {"circle_plane": "XY", "circle_radius": 150, "circle_feed": 1000}
        status, program = desk.call("/api/program", {"machine_id": mid, "operator": "A", "test": "circle",
                                                     "setup": setup})
        assert status == 200, program
        (tmp_path / "setup.toml").write_text("[setup]\n" + "".join(
            f"{k} = {json.dumps(v)}\n" for k, v in dict(setup, circle_centre_x=0, circle_centre_y=0,
                                                          circle_centre_z=0, bar_length=150).items()))
        ncgen = subprocess.run([host_binary("ncgen"), "circle", str(tmp_path / "setup.toml")],
                               capture_output=True, text=True)
        assert ncgen.returncode == 0, ncgen.stderr
        assert program == ncgen.stdout
        assert desk.call("/api/program?dialect=heidenhain", {"machine_id": mid, "operator": "A",
                                                             "test": "circle"})[0] == 400

        # two runs overlaid: each run's two traces in its own colour
        ids = [r["id"] for r in desk.ok(f"/api/runs?machine={mid}")]
        status, svg = desk.call(f"/api/overlay.svg?runs={ids[0]},{ids[2]}")
        assert status == 200 and svg.count(f'class="run-{ids[0]}"') == 2 and svg.count(f'class="run-{ids[2]}"') == 2

        # exports: CSV rows per figure with U and the decision, as the API states them
        status, text = desk.call(f"/api/export.csv?machine={mid}")
        rows = list(csv.DictReader(io.StringIO(text)))
        assert status == 200 and {int(r["run_id"]) for r in rows} == set(ids)
        mine = {r["figure"]: r for r in rows if int(r["run_id"]) == run_id}
        for name in limits:
            assert float(mine[name]["value"]) == pytest.approx(figures[name]["value"], abs=1e-9)
            assert mine[name]["decision"] == expected[name]
        assert [r["id"] for r in desk.ok(f"/api/export.json?machine={mid}")["runs"]] == ids

        # imports: the kept stream into another machine's history replays to the same figures;
        # the same file again is the same run; a results.json joins with its figures
        other = desk.ok("/api/machines", {"name": "imported"})["id"]
        body = (tmp_path / "run.stream").read_bytes()
        first = call_raw(desk, f"/api/import?machine={other}&operator=B&name=run.stream", body)
        assert call_raw(desk, f"/api/import?machine={other}&operator=B&name=run.stream", body) == first
        imported = desk.ok(f"/api/runs/{first}")
        assert imported["run"]["test"] == "circle" and "imported from run.stream" in imported["run"]["note"]
        assert {f["name"]: f["value"] for f in imported["figures"]} == {n: f["value"] for n, f in figures.items()}
        res = (tmp_path / "out" / "results.json").read_bytes()
        jid = call_raw(desk, f"/api/import?machine={other}&operator=B&name=results.json", res)
        assert len(desk.ok(f"/api/runs/{jid}")["figures"]) == len(figures)
        # a file that is neither is refused with its name, and nothing joins
        with pytest.raises(urllib.error.HTTPError) as bad:
            call_raw(desk, f"/api/import?machine={other}&operator=B&name=notes.txt", b"seq,t_s\n1,2\n")
        assert bad.value.code == 400 and "notes.txt" in json.loads(bad.value.read())["error"]
        assert len(desk.ok(f"/api/runs?machine={other}")) == 2

        # loopback only: a request naming another host is refused
        assert desk.call("/api/machines", headers={"host": "desk.example.com"})[0] == 403
    finally:
        desk.close()


def test_a_pod_lost_mid_run_is_kept_and_marked(tmp_path):
    sim = subprocess.Popen([host_binary("sim"), "--serve", "--max-seconds", "60", "--speed", "5"],
                           stdout=subprocess.PIPE, text=True, start_new_session=True)
    try:
        pod = json.loads(sim.stdout.readline())
        desk = Desk(tmp_path, pod)
        try:
            mid = desk.ok("/api/machines", {"name": "VF-2"})["id"]
            desk.ok("/api/tests", {"machine_id": mid, "operator": "A", "test": "circle"})
            t0 = time.time()
            while desk.ok("/api/live")["trace"]["samples"] < 200:
                assert time.time() - t0 < 30
                time.sleep(0.05)
            os.killpg(sim.pid, signal.SIGKILL)
            while not desk.ok("/api/live")["finished"]:
                assert time.time() - t0 < 60
                time.sleep(0.1)
            run_id = desk.ok("/api/live")["run_id"]
            run = desk.ok(f"/api/runs/{run_id}")["run"]
            assert run["state"] == "cut", run
            assert run["note"]
            kept = urllib.request.urlopen(desk.url + f"api/runs/{run_id}/stream").read()
            assert kept.startswith(b"# ballpod run") and kept.count(b"\xb5") > 200
        finally:
            desk.close()
    finally:
        os.killpg(sim.pid, signal.SIGKILL)
        sim.wait(timeout=10)


@pytest.mark.sim_args("--speed", "40")
def test_the_seed002_procedure_from_the_desk(pod, tmp_path):
    """The seed 002 template: the thesis Table 4.3 set-up, ten runs; the pod's identification
    against the served machine's truth, the replay check, a decision on a deviation."""
    from podlib import SEED002_DEVIATIONS, TABLE_4_3
    desk = Desk(tmp_path, pod)
    try:
        mid = desk.ok("/api/machines", {"name": "Mill-turn B/C", "kinematics": "B head, C table"})["id"]
        # without its set-up the pod refuses the first run, naming the field it lacks
        desk.ok("/api/tests", {"machine_id": mid, "operator": "A", "test": "seed002"})
        while not (live := desk.ok("/api/live"))["finished"]:
            time.sleep(0.05)
        run = desk.ok(f"/api/runs/{live['run_id']}")["run"]
        assert run["state"] == "failed" and "s002_l_b not set" in run["note"], run
        # the machine's balls are mounted without offsets at the R_C and Z_C entered: no
        # mounting uncertainty (as test_canopen_seed002.py)
        setup = dict(TABLE_4_3, s002_u_w_clamp=0, s002_u_t_centring=0, s002_u_t_axial=0, s002_u_r_c_z_c=0,
                     s002_u_r_b=0)
        desk.ok("/api/tests", {"machine_id": mid, "operator": "A", "test": "seed002", "setup": setup})
        steps = set()
        t0 = time.time()
        while not (live := desk.ok("/api/live"))["finished"]:
            steps.add(live["step"].split(":")[0])
            assert time.time() - t0 < 240, live
            time.sleep(0.1)
        assert {"run 1 of 10 (BX CW)", "run 10 of 10 (CR2 CCW)"} <= steps, steps
        rid = live["run_id"]
        view = desk.ok(f"/api/runs/{rid}")
        assert view["run"]["state"] == "done" and view["run"]["replay_check"] == "", view["run"]
        assert view["run"]["setup"]["BAR_LENGTH"] == view["run"]["setup"]["S002_L_B"]
        figures = {f["name"]: f for f in view["figures"]}
        truth = pod["truth"]["machine"]["seed002"]
        for name, key in SEED002_DEVIATIONS.items():
            f = figures[name]
            assert abs(f["value"] - truth[key]) <= max(4 * f["u"], 0.05) and abs(f["value"] - truth[key]) <= 0.5, name
        # a tolerance of ±5″ on alpha_XB (truth −20.89″): does not conform, by more than U
        desk.ok(f"/api/machines/{mid}/tolerances", {"figure": "alpha_XB", "lower": -5, "upper": 5})
        f = next(f for f in desk.ok(f"/api/runs/{rid}")["figures"] if f["name"] == "alpha_XB")
        assert f["decision"] == decision(f["value"], f["expanded_u"], -5, 5) == "does_not_conform"
        status, html = desk.call(f"/report/{rid}")
        assert status == 200 and "BX CW, BX CCW" in html and html.count("<svg") >= 1
    finally:
        desk.close()


def wait_finished(desk, seconds=120):
    t0 = time.time()
    while not (live := desk.ok("/api/live"))["finished"]:
        assert time.time() - t0 < seconds, live
        time.sleep(0.1)
    return live


def test_a_locked_history_file_keeps_the_run_in_the_spool_once(pod, tmp_path):
    """Another program holds the SQLite file locked when the run ends: the run waits in the
    spool (said on the page) and is stored, once, when the lock goes."""
    desk = Desk(tmp_path, pod)
    try:
        mid = desk.ok("/api/machines", {"name": "VF-2"})["id"]
        desk.ok("/api/tests", {"machine_id": mid, "operator": "A", "test": "circle"})
        while desk.ok("/api/live")["trace"]["samples"] < 100:
            time.sleep(0.05)
        other = sqlite3.connect(tmp_path / "desk.sqlite", timeout=1)
        other.execute("BEGIN EXCLUSIVE")
        live = wait_finished(desk)
        assert "kept in the spool" in live["step"] and "locked" in live["step"], live
        assert live["run_id"] is None and live["spooled"] == 1
        other.rollback()
        other.close()
        t0 = time.time()
        while (live := desk.ok("/api/live"))["run_id"] is None:
            assert time.time() - t0 < 30, live
            time.sleep(0.2)
        assert live["spooled"] == 0 and not list((tmp_path / "spool").glob("*.json"))
        runs = desk.ok(f"/api/runs?machine={mid}")
        assert [r["state"] for r in runs] == ["done"] and runs[0]["replay_check"] == ""
    finally:
        desk.close()


def test_a_database_server_that_is_down_keeps_runs_in_the_spool(pod, tmp_path, postgres):
    """The PostgreSQL server goes down after the desk started: the run waits in the spool; the
    server comes back: the run is stored once and reads back whole; a desk restarted on the same
    spool stores nothing twice."""
    url = postgres.database()
    desk = Desk(tmp_path, pod, url)
    try:
        mid = desk.ok("/api/machines", {"name": "DMU 50 #3"})["id"]
        desk.ok("/api/tests", {"machine_id": mid, "operator": "A", "test": "circle"})
        while desk.ok("/api/live")["trace"]["samples"] < 100:
            time.sleep(0.05)
        postgres.stop()
        try:
            live = wait_finished(desk)
            assert "kept in the spool" in live["step"], live
            status, e = desk.call("/api/machines")
            assert status == 400 and "database" in e["error"], e
            # the spool's copy is the whole run
            (spooled,) = (tmp_path / "spool").glob("*.json")
            assert json.loads(spooled.read_text())["state"] == "done"
        finally:
            postgres.start()
        t0 = time.time()
        while (live := desk.ok("/api/live"))["run_id"] is None:
            assert time.time() - t0 < 30, live
            time.sleep(0.2)
        run_id = live["run_id"]
        assert desk.ok(f"/api/runs/{run_id}")["run"]["replay_check"] == ""
        stream = urllib.request.urlopen(desk.url + f"api/runs/{run_id}/stream").read()
        assert stream.count(b"# stream_dropped=0") == 2
    finally:
        desk.close()
    again = Desk(tmp_path, None, url)
    try:
        time.sleep(1)
        assert len(again.ok("/api/runs")) == 1
    finally:
        again.close()


def test_an_ssm_run_from_the_desk(pod, tmp_path):
    """The SSM template: without its socket the pod names the field it lacks; with it, E
    against the served machine's truth (within 3u, as test_scpi_client.py)."""
    desk = Desk(tmp_path, pod)
    try:
        mid = desk.ok("/api/machines", {"name": "DMU 50 #3"})["id"]
        desk.ok("/api/tests", {"machine_id": mid, "operator": "A", "test": "ssm"})
        live = wait_finished(desk)
        run = desk.ok(f"/api/runs/{live['run_id']}")["run"]
        assert run["state"] == "failed" and "ssm_socket_x not set" in run["note"], run
        desk.ok("/api/tests", {"machine_id": mid, "operator": "A", "test": "ssm",
                               "setup": {"ssm_socket_x": 0, "ssm_socket_y": 0, "ssm_socket_z": 0}})
        live = wait_finished(desk)
        view = desk.ok(f"/api/runs/{live['run_id']}")
        assert view["run"]["state"] == "done" and view["run"]["replay_check"] == "", view["run"]
        figures = {f["name"]: f for f in view["figures"]}
        for k, name in enumerate(("ssm_ex", "ssm_ey", "ssm_ez")):
            f = figures[name]
            assert abs(f["value"] - pod["truth"]["ssm_error_um"][k]) <= 3 * f["u"], (name, f)
        status, e = desk.call("/api/program", {"machine_id": mid, "operator": "A", "test": "ssm"})
        assert status == 400 and "ncgen -- ssm" in e["error"]
    finally:
        desk.close()


@pytest.mark.sim_args("--speed", "40")
def test_the_probe_procedure_from_the_desk(pod, tmp_path):
    """The touch-probe template: eight PROBE runs, the second stylus's length written before run
    7; every run's touches counted live; the C- and B-axis deviations against the served
    machine's truth (as test_canopen_probe.py), the replay of the eight runs (each with its own
    probe_length) equal to the pod's results."""
    from test_canopen_probe import C_AXIS, ORIGIN, R_B, R_B2, b_axis_truth
    desk = Desk(tmp_path, pod)
    try:
        mid = desk.ok("/api/machines", {"name": "Mill-turn B/C"})["id"]
        setup = {"s002_origin_x": ORIGIN[0], "s002_origin_y": ORIGIN[1], "s002_origin_z": ORIGIN[2],
                 "s002_z_c": pod["truth"]["sphere_rc_zc_mm"][1], "probe_u_lobing": 0.0, "probe_length": R_B}
        req = {"machine_id": mid, "operator": "A", "test": "probe", "setup": setup}
        # the two styli are named before anything starts
        status, e = desk.call("/api/tests", dict(req))
        assert status == 400 and "second_probe_length" in e["error"], e
        status, e = desk.call("/api/tests", dict(req, setup={k: v for k, v in setup.items() if k != "probe_length"},
                                                 second_probe_length=R_B2))
        assert status == 400 and "needs probe_length" in e["error"], e
        status, e = desk.call("/api/tests", dict(req, second_probe_length=-3))
        assert status == 400 and "second_probe_length = -3 is outside" in e["error"], e
        status, e = desk.call("/api/tests", {"machine_id": mid, "operator": "A", "test": "circle",
                                             "second_probe_length": R_B2})
        assert status == 400 and "probe test's alone" in e["error"], e
        status, e = desk.call("/api/program", dict(req, second_probe_length=R_B2))
        assert status == 400 and "ncgen -- sphere" in e["error"], e

        desk.ok("/api/tests", dict(req, second_probe_length=R_B2))
        touches = {}
        t0 = time.time()
        while not (live := desk.ok("/api/live"))["finished"]:
            run = live["step"].split(":")[0]
            if run.startswith("run "):
                touches.setdefault(run, set()).add(live["trace"]["touches"])
            assert time.time() - t0 < 240, live
            time.sleep(0.05)
        # the touches of a run seen growing on the page (nine a run)
        assert any(len(n) >= 3 for n in touches.values()), touches
        assert all(max(n) <= 9 for n in touches.values()), touches
        view = desk.ok(f"/api/runs/{live['run_id']}")
        assert view["run"]["state"] == "done" and view["run"]["replay_check"] == "", view["run"]
        assert view["run"]["setup"]["PROBE_LENGTH"] == str(R_B)
        assert view["run"]["setup"]["PROBE_LENGTH from run 7"] == str(R_B2)
        figures = {f["name"]: f for f in view["figures"]}
        truth = pod["truth"]["machine"]["seed002"]
        for name, key in C_AXIS.items():
            assert abs(figures[name]["value"] - truth[key]) <= 0.5, (name, figures[name], truth[key])
        for name, t in b_axis_truth(truth).items():
            f = figures[name]
            d = abs(f["value"] - t)
            assert d <= max(4 * f["u"], 0.1) and d <= 0.5, (name, f, t)
        # the recorded stream: eight runs, the last two with the second stylus
        stream = urllib.request.urlopen(desk.url + f"api/runs/{live['run_id']}/stream").read()
        assert stream.count(b"# stream_dropped=0") == 8
        assert stream.count(f"probe_length={R_B2}".encode()) == 2, "the second stylus's runs"
        status, html = desk.call(f"/report/{live['run_id']}")
        assert status == 200 and "probe_alpha_CZ" in html and "PROBE CCW" in html, html[:2000]
    finally:
        desk.close()


@pytest.mark.sim_args("--speed", "40")
def test_a_feed_in_circle_from_the_desk(pod, tmp_path):
    """A circle pair armed with run_trigger FEED_IN: the desk arms each run and waits; the
    served CNC's program feeds in and the pod starts and ends each run itself."""
    desk = Desk(tmp_path, pod)
    try:
        mid = desk.ok("/api/machines", {"name": "VF-2"})["id"]
        desk.ok("/api/tests", {"machine_id": mid, "operator": "A", "test": "circle",
                               "setup": {"run_trigger": "FEED_IN"}})
        live = wait_finished(desk)
        view = desk.ok(f"/api/runs/{live['run_id']}")
        assert view["run"]["state"] == "done" and view["run"]["replay_check"] == "", view["run"]
        assert view["run"]["setup"]["RUN_TRIGGER"] == "FEED_IN"
        figures = {f["name"]: f for f in view["figures"]}
        truth = pod["truth"]["machine"]["circle"]
        # the eccentricity is the socket offset turned round (as test_canopen_trigger.py)
        for k, name in enumerate(("ecc_u", "ecc_v")):
            f = figures[name]
            assert abs(f["value"] + truth["socket_offset_um"][k]) <= 3 * f["u"] + 0.05, (name, f)
    finally:
        desk.close()


@pytest.mark.sim_args("--speed", "40", "--machine", str(pathlib.Path(__file__).with_name("machine_no_feed_in.toml")))
def test_a_feed_in_run_that_never_starts_says_why_and_stops_on_request(pod, tmp_path):
    """A part program without a feed-in: the desk never starts the run itself; the page shows
    what the pod waits for, in the pod's words, until the operator stops the test (the run
    aborted, the test kept as failed)."""
    desk = Desk(tmp_path, pod)
    try:
        mid = desk.ok("/api/machines", {"name": "VF-2"})["id"]
        assert desk.call("/api/tests/stop", {}) == (400, {"error": "there is no test running to stop"})
        desk.ok("/api/tests", {"machine_id": mid, "operator": "A", "test": "circle",
                               "setup": {"run_trigger": "FEED_IN"}})
        t0 = time.time()
        while "waiting for the feed-in" not in (live := desk.ok("/api/live"))["step"]:
            assert time.time() - t0 < 30, live
            time.sleep(0.05)
        assert live["step"] == "run 1 of 2 (CIRCLE CCW): armed; the pod: FEED_IN: waiting for the feed-in", live
        # the served program has run its whole arc (~1.6 s at 40 times): still armed, no sample
        time.sleep(3)
        live = desk.ok("/api/live")
        assert not live["finished"] and live["trace"]["samples"] == 0 and "armed" in live["step"], live
        desk.ok("/api/tests/stop", {})
        live = wait_finished(desk, 30)
        run = desk.ok(f"/api/runs/{live['run_id']}")["run"]
        assert run["state"] == "failed" and "stopped by the operator" in run["note"], run
    finally:
        desk.close()


def test_a_pod_on_serial_ports(pod, tmp_path):
    """The pod's two ports as serial devices (pseudo-terminals carrying the served pod's ports,
    as a USB pod's /dev/ttyACMn): a circle pair recorded and checked as over TCP; a desk asked
    for a USB pod where there is none says so."""
    stream = SerialBridge(pod["stream_port"])
    command = SerialBridge(pod["usb_port"])
    desk = Desk(tmp_path, link=["--pod-command-port", command.path, "--pod-stream-port", stream.path])
    try:
        assert desk.ok("/api/pod")["identity"].startswith("BALLPOD,")
        mid = desk.ok("/api/machines", {"name": "VF-2"})["id"]
        run_id, _ = run_circle_pair(desk, mid)
        run = desk.ok(f"/api/runs/{run_id}")["run"]
        assert run["state"] == "done" and run["replay_check"] == "", run
    finally:
        desk.close()
        stream.close()
        command.close()
    none = subprocess.run([host_binary("desk"), "--db", str(tmp_path / "x.sqlite"), "--pod-serial", "0BA11000"],
                          capture_output=True, text=True, timeout=30)
    assert none.returncode != 0 and "no pod with serial number 0BA11000 on USB" in none.stderr, none
