"""Part programs that drive the pod themselves (`ncgen circle --session`): the M-codes in the
program's order as LinuxCNC's interpreter sees them (`rs274 -g`), the header naming every set-up
field the run needs, and the closed loop — a LinuxCNC program with its user M-code scripts
(`ncgen m-codes`) run by the served CNC (`sim --serve --program`, which runs each user M-code's
program in step with the motion, as LinuxCNC's task does) against the simulated pod, with no
other client: the pod's results are valid at the end and equal an independent numpy fit of the
samples it streamed.

The standalone `rs274` does not run user M-codes (LinuxCNC's task does; rs274 stops at "Unknown
m code used"), so here each M-code block is handed to it as a message, which the interpreter
orders among the moves like the M-code.

Run by .ci/run: BALLPOD_NCGEN=<ncgen> BALLPOD_SIM=<sim> python3 -m pytest host-tests/nc
"""
import json
import os
import pathlib
import re
import subprocess
import sys
import time
import tomllib

import canopen
import pytest

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "clients"))
from podlib import StreamCapture, fit_run, parse_runs  # noqa: E402
from test_rs274 import interpret  # noqa: E402

NCGEN = os.environ.get("BALLPOD_NCGEN")
SIM = os.environ.get("BALLPOD_SIM")
ROOT = pathlib.Path(__file__).resolve().parents[2]
SETUP = {"circle_plane": "XY", "circle_centre_x": 0.0, "circle_centre_y": 0.0, "circle_centre_z": -20.0,
         "circle_radius": 150.0, "circle_feed": 1000.0}
# the M-codes from the default base (book: "Running a test from the CNC")
M = {"setup": 150, "arm_ccw": 151, "arm_cw": 152, "start": 153, "stop": 154, "results": 155}


def ncgen(tmp_path, *args):
    assert NCGEN, "set BALLPOD_NCGEN to the ncgen binary"
    f = tmp_path / "setup.toml"
    f.write_text("[setup]\n" + "".join(f"{k} = {v!r}\n" if isinstance(v, str) else f"{k} = {v}\n"
                                       for k, v in SETUP.items()))
    p = subprocess.run([NCGEN, *[str(f) if a == "SETUP" else a for a in args]], capture_output=True,
                       text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    return p.stdout


def sequence(tmp_path, program):
    """The program through rs274 -g (test_rs274's `interpret`), each M-code block as a message:
    the ordered list of ('M', code), ('comment', text), ('move', name)."""
    marked = re.sub(r"^M(1\d\d)( P\S+)?$", lambda m: f"(MSG,ballpod M{m.group(1)})", program, flags=re.M)
    out = []
    for name, args in interpret(tmp_path, marked):
        if name == "MESSAGE":
            out.append(("M", int(re.search(r"ballpod M(\d+)", ", ".join(args)).group(1))))
        elif name == "COMMENT":
            out.append(("comment", ", ".join(args).strip('"')))  # (rejoined at its commas)
        elif name in ("STRAIGHT_FEED", "ARC_FEED", "STRAIGHT_TRAVERSE"):
            out.append(("move", name))
    return out


@pytest.mark.parametrize("trigger", ["command", "feed-in"])
def test_the_m_codes_arrive_in_order_around_each_data_arc(tmp_path, trigger):
    program = ncgen(tmp_path, "circle", "SETUP", "--arc-deg", "220", "--start-deg", "30", "--session",
                    "--trigger", trigger)
    seq = sequence(tmp_path, program)
    codes = [c for kind, c in seq if kind == "M"]
    commanded = trigger == "command"
    per_run = (["start", "stop"] if commanded else []) + ["results"]
    expected = [M["setup"]] + [M[k] for run in ("arm_ccw", "arm_cw") for k in [run] + per_run]
    assert codes == expected
    assert seq.index(("M", M["setup"])) < seq.index(("move", "STRAIGHT_FEED")), "set-up before any feed"
    for d, arm in (("CCW", M["arm_ccw"]), ("CW", M["arm_cw"])):
        start = seq.index(("comment", f"{d} data arc start"))
        end = seq.index(("comment", f"{d} data arc end, overshoot"))
        feed_out = seq.index(("comment", f"{d} feed-out"))
        # armed before the run's feed-in (the first) or the return to it (the second)
        feed_in = max(i for i, s in enumerate(seq[:start]) if s == ("move", "STRAIGHT_FEED"))
        assert seq.index(("M", arm)) < feed_in
        if commanded:
            # start right at the data arc, stop right at its end: no motion between
            assert seq[start + 1] == ("M", M["start"]) and seq[start + 2] == ("move", "ARC_FEED")
            assert seq[end - 1] == ("move", "ARC_FEED") and seq[end + 1] == ("M", M["stop"])
        # the results after the feed-out's move
        after = seq[feed_out + 1:]
        assert after[0] == ("move", "STRAIGHT_FEED") and after[1] == ("M", M["results"])


def test_the_header_names_every_set_up_field_of_the_file(tmp_path):
    out = tmp_path / "ballpod-setup-7.toml"
    program = ncgen(tmp_path, "circle", "SETUP", "--arc-deg", "220", "--session", "--setup-number", "7",
                    "--setup-out", str(out))
    assert "M150 P7" in program
    setup = tomllib.loads(out.read_text())
    assert setup["session"]["pattern"] == "CIRCLE"
    fields = setup["setup"]
    header = " ".join(re.findall(r"^\((.*)\)$", program, re.M))
    names = {"circle_plane": ["XY", "YZ", "ZX"], "run_trigger": ["COMMAND", "FEED_IN"]}
    for name, value in fields.items():
        shown = names[name][int(value)] if name in names else f"{value:.4f}"
        assert f"{name} {shown}" in header, name
    # a partial arc needs its minimum lowered, the radius is the bar's, the circle's Z is set
    assert fields["circle_min_arc"] == fields["circle_arc"] == 220
    assert fields["bar_length"] == 150 and fields["circle_centre_z"] == -20
    # a full circle leaves the minimum as it is
    full = ncgen(tmp_path, "circle", "SETUP", "--session")
    assert "circle_min_arc" not in full


def test_bad_session_options_are_refused(tmp_path):
    f = tmp_path / "setup.toml"
    f.write_text("[setup]\ncircle_plane = 'XY'\ncircle_centre_x = 0.0\ncircle_centre_y = 0.0\n"
                 "circle_radius = 150.0\ncircle_feed = 1000.0\n")
    p = subprocess.run([NCGEN, "circle", str(f), "--session", "--m-base", "195"], capture_output=True,
                       text=True, timeout=60)
    assert p.returncode == 1 and "M100–M199" in p.stderr and p.stdout == ""


def serve_program(tmp_path, trigger, via_usb=False):
    """The program and its M-code scripts, run by the served CNC: the JSON lines it printed and
    the stream a passive reader recorded."""
    assert SIM, "set BALLPOD_SIM to the sim binary"
    mc = tmp_path / "mc"
    ncgen(tmp_path, "m-codes", str(mc))
    program = tmp_path / "circle.ngc"
    ncgen(tmp_path, "circle", "SETUP", "--arc-deg", "220", "--start-deg", "30", "--session", "--trigger",
          trigger, "--setup-out", str(mc / "ballpod-setup-1000.toml"), "--out", str(program))
    cmd = [SIM, "--serve", "--max-seconds", "240", "--program", str(program), "--m-codes", str(mc),
           "--cycle-start-after", "1.5"] + (["--m-codes-via-usb"] if via_usb else [])
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True)
    try:
        info = json.loads(proc.stdout.readline())
        stream = StreamCapture(info["stream_port"])  # a recorder, as the technician's PC
        t0 = time.time()
        end = json.loads(proc.stdout.readline())  # the program's end (blocks until then)
        assert time.time() - t0 < 200
        time.sleep(0.3)
        return info, end, stream
    except BaseException:
        proc.kill()
        raise
    finally:
        # the pod's results are read by the test after the program, so the server stays
        SERVED.append(proc)


SERVED = []


@pytest.fixture(autouse=True)
def _stop_servers():
    yield
    while SERVED:
        p = SERVED.pop()
        p.kill()
        p.wait(timeout=10)


def read_results(info, names):
    net = canopen.Network()
    net.connect(interface="slcan", channel=f"socket://127.0.0.1:{info['can_port']}", bitrate=500000,
                sleep_after_open=0)
    try:
        node = net.add_node(info["node_id"], str(ROOT / "ballpod.eds"))
        node.sdo.RESPONSE_TIMEOUT = 2.0
        return {n: (node.sdo["result_valid"][n].raw, node.sdo["result_value"][n].raw,
                    node.sdo["result_uncertainty"][n].raw) for n in names}
    finally:
        net.disconnect()


def check_runs_against_the_stream(info, stream, results):
    runs = [r for r in parse_runs(stream.text()) if r.complete]
    assert [r.meta.get("direction") for r in runs] == ["CCW", "CW"], [r.meta for r in runs]
    # the last run's (CW) fit against an independent limaçon fit of its streamed samples
    f = fit_run(runs[-1], centre=(0.0, 0.0))
    for name, key in (("ecc_u", "e_u"), ("ecc_v", "e_v"), ("r0", "r0")):
        valid, value, _ = results[name]
        assert valid and value == pytest.approx(f[key], abs=2e-3), (name, value, f[key])
    # the 220° arc the program ran, as the samples turned it (the pod's minimum is 220°)
    assert results["arc"][1] == pytest.approx(f["arc"], abs=1e-3)
    assert results["arc"][1] == pytest.approx(220.0, abs=0.05)


CIRCLE_PAIR = ["ecc_u", "ecc_v", "r0", "arc", "G_ccw", "G_cw", "F_max_ccw", "F_min_cw", "G_bidir", "H",
               "radial_bidir"]


def test_a_linuxcnc_program_drives_the_pod_over_canopen(tmp_path):
    info, end, stream = serve_program(tmp_path, "command")
    # set-up, arm, start, stop, results per direction: every M-code ran and exited 0
    assert end == {"program": "done", "user_m_codes": 9}, end
    results = read_results(info, CIRCLE_PAIR)
    assert all(valid for valid, _, _ in results.values()), results
    check_runs_against_the_stream(info, stream, results)


def test_a_self_triggered_program_drives_the_pod_over_scpi(tmp_path):
    info, end, stream = serve_program(tmp_path, "feed-in", via_usb=True)
    assert end == {"program": "done", "user_m_codes": 5}, end  # set-up, then arm and results twice
    results = read_results(info, CIRCLE_PAIR)
    assert all(valid for valid, _, _ in results.values()), results
    check_runs_against_the_stream(info, stream, results)


# seed 002 (thesis Table 4.3, the simulator's set-up, mm) and the truth's keys of the deviations
S002 = {"s002_l_b": 100.0, "s002_r_b": 356.3945, "s002_r_b2": 406.4608, "s002_r_c": 50.0,
        "s002_z_c": 65.5348, "s002_z_t": 112.2877, "s002_z_t2": 62.2491, "s002_x_t": 490.0,
        "s002_origin_x": 0.0, "s002_origin_y": 0.0, "s002_origin_z": 0.0, "bar_length": 100.0}
MOUNTING_U = ["s002_u_w_clamp", "s002_u_t_centring", "s002_u_t_axial", "s002_u_r_c_z_c", "s002_u_r_b"]
DEVIATIONS = {"dx_BT": "dx_bt_um", "dz_BT": "dz_bt_um", "alpha_BT": "alpha_bt_arcsec",
              "alpha_XB": "alpha_xb_arcsec", "beta_XB": "beta_xb_arcsec",
              "gamma_XB": "gamma_xb_arcsec", "dx_CZ": "dx_cz_um", "dy_CZ": "dy_cz_um",
              "alpha_CZ": "alpha_cz_arcsec", "beta_CZ": "beta_cz_arcsec"}


def test_the_seed_002_programs_drive_the_procedure_to_the_identification(tmp_path):
    """Five LinuxCNC programs with their sessions, one after the other (the operator loads the
    next and presses cycle start): the pod identifies the machine's deviations as when a client
    drives it (within 3u and 0.5 um / 0.5 arc-second of the truth)."""
    setup = tmp_path / "s002.toml"
    setup.write_text("[setup]\n" + "".join(f"{k} = {v}\n" for k, v in S002.items()))
    mc = tmp_path / "mc"
    assert subprocess.run([NCGEN, "m-codes", str(mc)], timeout=60).returncode == 0
    programs = []
    for n, step in enumerate(["BX", "BY", "CR", "CA", "CR2"], start=1):
        program = tmp_path / f"{step}.ngc"
        p = subprocess.run([NCGEN, "pattern", step, str(setup), "--session", "--setup-number", str(n),
                            "--setup-out", str(mc / f"ballpod-setup-{n}.toml"), "--out", str(program)],
                           capture_output=True, text=True, timeout=60)
        assert p.returncode == 0, p.stderr
        programs += ["--program", str(program)]
        # the set-up file is the technician's to complete: the simulated machine's balls are
        # mounted without offsets at the R_C and Z_C entered, so no mounting uncertainty (as
        # clients/test_canopen_seed002.py states it)
        with open(mc / f"ballpod-setup-{n}.toml", "a") as f:
            f.write("".join(f"{k} = 0.0\n" for k in MOUNTING_U))
    proc = subprocess.Popen([SIM, "--serve", "--max-seconds", "400", "--m-codes", str(mc), *programs],
                            stdout=subprocess.PIPE, text=True)
    SERVED.append(proc)
    info = json.loads(proc.stdout.readline())
    end = json.loads(proc.stdout.readline())
    # per program: set-up, then per direction arm, start, stop, results
    assert end == {"program": "done", "user_m_codes": 5 * 9}, end
    results = read_results(info, list(DEVIATIONS))
    truth = info["truth"]["machine"]["seed002"]
    for name, key in DEVIATIONS.items():
        valid, value, u = results[name]
        t = truth[key]
        assert valid and abs(value - t) <= 3 * u and abs(value - t) <= 0.5, (name, value, u, t)
