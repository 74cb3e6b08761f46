"""The technician's side: SCPI over the USB command port, by PyVISA (pyvisa-py's TCPIP SOCKET
resource) and by pyserial (socket://), against the simulated pod. The results are held against
a numpy fit of the samples the pod streamed, the CANopen side's SDO reads, the served machine's
truth, and `replay` of the streamed runs."""
import json
import math
import pathlib
import re
import subprocess
import time

import numpy as np
import pytest
import pyvisa
import serial

from conftest import host_binary
from podlib import (LIVE, SCPI_ERROR, wait_results_scpi, StreamCapture, connect, fit_run, iso230_4, scpi_nan, scpi_result,
                    wait_until, arm_then_start, RUN_TIMEOUT, firmware_version)

ROOT = pathlib.Path(__file__).resolve().parents[2]


def open_visa(pod):
    rm = pyvisa.ResourceManager("@py")
    inst = rm.open_resource(f"TCPIP::127.0.0.1::{pod['usb_port']}::SOCKET", read_termination="\n",
                            write_termination="\n")
    inst.timeout = 5000  # ms
    return rm, inst


def error(query):
    """The oldest queued error: (code, message)."""
    m = SCPI_ERROR.match(query("SYST:ERR?"))
    assert m, "SYST:ERR? answer"
    return int(m.group(1)), m.group(2)


def configure_circle(write, circle):
    """The truth's circle machine's ISO 230-4 set-up (socket at X = Y = 0, radius = bar length)."""
    r, f = circle["radius_mm"], circle["feed_mm_per_min"]
    write(f"CONF:BAR_LENGTH {r};CIRCLE_PLANE XY;CIRCLE_CENTRE_X 0;CIRCLE_CENTRE_Y 0;"
          f"CIRCLE_RADIUS {r};CIRCLE_FEED {f}")


def run_circle(query, write, direction):
    arm_then_start(lambda: write(f"SESS:PATT CIRCLE;DIR {direction};:SESS:ARM"), lambda: write("SESS:STAR"))
    wait_until(lambda: query("SESS:STAT?") != "RUNNING", RUN_TIMEOUT, f"the CIRCLE {direction} run's end")
    assert query("SESS:STAT?") == "DONE"
    wait_results_scpi(query)


def test_pyvisa_circle_session(pod, eds):
    truth = pod["truth"]["machine"]["circle"]
    stream = StreamCapture(pod["stream_port"])
    rm, inst = open_visa(pod)
    q, w = inst.query, inst.write
    try:
        # IEEE 488.2 §10.14: manufacturer, model, serial, firmware version (the crate's and the
        # commit the firmware was built from)
        idn = q("*IDN?").split(",")
        assert len(idn) == 4 and idn[0] == "BALLPOD" and idn[3] == firmware_version(ROOT)
        assert error(q) == (0, "No error")
        # nothing computed yet: no answer, -230 naming the result
        w("FETC:RES? ecc_u")
        assert error(q) == (-230, "Data corrupt or stale;ecc_u has no valid value")
        # configuration is locked until CONF:UNL (-203), then range checked (-222)
        w("CONF:CIRCLE_RADIUS 150")
        assert error(q)[0] == -203
        w("CONF:UNL")
        configure_circle(w, truth)
        assert error(q) == (0, "No error")
        assert (q("CONF:CIRCLE_PLANE?"), float(q("CONF:CIRCLE_RADIUS?"))) == ("XY", truth["radius_mm"])
        w("CONF:BAR_LENGTH 20")
        assert error(q) == (-222, "Data out of range;bar_length out of range")
        assert float(q("CONF:BAR_LENGTH?")) == truth["radius_mm"]
        # the live values: counter, 14 values (9.91E+37 where invalid), status word, validity mask
        arm_then_start(lambda: w("SESS:PATT CIRCLE;DIR CCW;:SESS:ARM"), lambda: w("SESS:STAR"))
        assert q("SESS:STAT?") == "RUNNING"
        for _ in range(5):
            f = q("MEAS:ALL?").split(",")
            assert len(f) == 1 + len(LIVE) + 2
            n = len(LIVE)
            values = [scpi_nan(float(v)) for v in f[1:1 + n]]
            status, mask = int(f[1 + n]), int(f[2 + n])
            assert status & 1 << 9  # running
            names = [n.strip('"') for n in q("MEAS:VAL?").split(",") if n]
            for k, name in enumerate(LIVE):
                assert (mask >> k & 1) == (not math.isnan(values[k])), f
            assert set(names) <= set(LIVE) and "delta_l" in names
        # the live fit's u (u_ecc_u, u_ecc_v, u_r0): invalid until e is, then what the results
        # would state for the samples so far; the last before the run's end against the results
        live_u, deadline = None, time.monotonic() + RUN_TIMEOUT
        while q("SESS:STAT?") == "RUNNING":
            assert time.monotonic() < deadline, "the CCW run's end"
            v = [scpi_nan(float(x)) for x in q("MEAS:ALL?").split(",")[1:1 + len(LIVE)]]
            live = dict(zip(LIVE, v))
            for name in ("ecc_u", "ecc_v", "r0"):
                assert not (math.isnan(live[name]) and not math.isnan(live[f"u_{name}"])), live
            if not math.isnan(live["u_ecc_u"]):
                live_u = live
        assert q("SESS:STAT?") == "DONE"
        wait_results_scpi(q)
        w("FETC:RES? G_bidir")
        assert error(q)[0] == -230  # needs the CW run
        ccw = {n: scpi_result(q, n) for n in ("ecc_u", "ecc_v", "r0", "G_ccw")}
        assert live_u is not None, "no valid live u during the run"
        for name in ("ecc_u", "ecc_v", "r0"):
            # fewer samples (u ∝ 1/√N) and the noise as told by the profile up to 1 024 samples
            # before, which scatters by some percent about the end's
            u_end = ccw[name][1]
            assert 0.8 * u_end <= live_u[f"u_{name}"] < 1.3 * u_end, (name, live_u, u_end)
        run_circle(q, w, "CW")
        cw = {n: scpi_result(q, n) for n in ("ecc_u", "ecc_v", "r0", "G_cw", "G_bidir", "H")}
        fits = [fit_run(r) for r in stream.runs(2)]
        iso = iso230_4(*fits)
        for p, f in zip((ccw, cw), fits):
            assert p["ecc_u"][0] == pytest.approx(f["e_u"], abs=2e-3)
            assert p["ecc_v"][0] == pytest.approx(f["e_v"], abs=2e-3)
            assert p["r0"][0] == pytest.approx(f["r0"], abs=2e-3)
            # u(e) is the noise's (the profile's third differences), below numpy's residual u,
            # which counts the faults' shape as noise
            assert 0.0 < p["ecc_u"][1] < f["u_e"], (p["ecc_u"], f["u_e"])
            assert p["ecc_u"][2] == "UM"
            s = truth["socket_offset_um"]  # e = −(socket offset) within 3u
            assert abs(p["ecc_u"][0] + s[0]) <= 3 * p["ecc_u"][1]
            assert abs(p["ecc_v"][0] + s[1]) <= 3 * p["ecc_v"][1]
        for name, (v, u, unit) in list(cw.items())[3:] + [("G_ccw", ccw["G_ccw"])]:
            # numpy's extremes of the bin means, which the pod corrects for the noise's bias by
            # less than its stated u twice over (metrology/extremes.rs)
            assert 0.0 < u < 0.1 and unit == "UM", (name, u)
            assert v == pytest.approx(iso[name], abs=2 * u), name
        # the budget: u, then the largest contributors with their shares, largest first; the
        # bar's shares computed here from the configuration: the LVDT's scale |value| times
        # lvdt_u_scale, and for a radial figure (r0) the bar's offset, its length's u and its
        # temperature's (L · CTE · u_T) in quadrature; a shape figure (G) has no offset share
        cfg = {f: float(q(f"CONF:{f.upper()}?")) for f in
               ("bar_length", "bar_cte", "bar_u_length", "bar_u_temp", "lvdt_u_scale")}
        offset = math.hypot(cfg["bar_u_length"], cfg["bar_length"] * cfg["bar_cte"] * cfg["bar_u_temp"] * 1e-3)
        for name in ("r0", "G_cw"):
            v, u, _ = cw[name]
            f = q(f"FETC:RES:BUDG? {name}").split(",")
            shares = dict(zip(f[1::2], map(float, f[2::2])))
            assert float(f[0]) == pytest.approx(u, abs=1e-4), f
            assert list(shares.values()) == sorted(shares.values(), reverse=True), f
            assert math.hypot(*shares.values()) == pytest.approx(u, abs=2e-4), f
            assert shares["LVDT_SCALE"] == pytest.approx(abs(v) * cfg["lvdt_u_scale"] * 1e-6, abs=1e-4), f
            assert "TYPE_A" in shares, f
            if name == "r0":
                assert shares["BAR_OFFSET"] == pytest.approx(offset, abs=1e-4), f
            else:
                assert "BAR_OFFSET" not in shares, f
        w("FETC:RES:BUDG? G_bidir_x")
        assert error(q)[0] == -224
        # the same numbers over CANopen
        net, node = connect(pod, eds)
        try:
            # one serial number on both sides: *IDN?'s third field is CANopen 0x1018:4 in hex
            assert idn[2] == f"{node.sdo[0x1018][4].raw:08X}"
            for name, (v, u, _) in cw.items():
                assert node.sdo["result_value"][name].raw == pytest.approx(v, abs=1e-4), name
        finally:
            net.disconnect()
        assert error(q) == (0, "No error")
    finally:
        inst.close()
        rm.close()
        stream.close()


def read_block(port):
    """IEEE 488.2 §8.7.9 definite-length block: '#', n, n digits of length, bytes; then '\\n'."""
    assert port.read(1) == b"#"
    n = int(port.read(1))
    length = int(port.read(n))
    data = b""
    while len(data) < length:
        chunk = port.read(length - len(data))
        assert chunk, "download stalled"
        data += chunk
    assert port.read(1) == b"\n"
    return data.decode()


def test_pyserial_ssm_session_and_log_download(pod):
    """A serial client: error queue, an over-long line, an SSM run whose E is the truth's, and the
    log download, whose rows are the streamed rows of the same samples."""
    stream = StreamCapture(pod["stream_port"])
    port = serial.serial_for_url(f"socket://127.0.0.1:{pod['usb_port']}", timeout=5)

    def ask(line):
        port.write((line + "\n").encode())
        return port.readline().decode().rstrip("\n")

    try:
        assert ask("*IDN?").startswith("BALLPOD,")
        # a line longer than the 256-byte buffer is rejected whole (-363); the next parses normally
        port.write(b"CONF:UNL;:CONF:BAR_LENGTH " + b"1" * 400 + b"\n")
        assert ask("SYST:ERR?").startswith("-363,")
        assert ask("CONF:LOCK?") == "1"
        # a session command in the wrong state: -221 with the reason, state unchanged
        port.write(b"SESS:STOP\n")
        assert ask("SYST:ERR?") == '-221,"Settings conflict;STOP needs RUNNING"'
        assert ask("SESS:STAT?") == "IDLE"
        port.write(b"SESS:PATT SSM;:SESS:ARM\n")
        assert ask("SYST:ERR?") == '-221,"Settings conflict;ssm_socket_x not set"'
        port.write(b"CONF:UNL;:CONF:SSM_SOCKET_X 0;SSM_SOCKET_Y 0;SSM_SOCKET_Z 0\n")
        arm_then_start(lambda: port.write(b"SESS:ARM\n"), lambda: port.write(b"SESS:STAR\n"))
        wait_until(lambda: ask("SESS:STAT?") != "RUNNING", RUN_TIMEOUT, "the SSM run's end")
        assert ask("SESS:STAT?") == "DONE"
        wait_results_scpi(ask)
        e_true = pod["truth"]["ssm_error_um"]
        for k, name in enumerate(("ssm_ex", "ssm_ey", "ssm_ez")):
            v, u, unit = scpi_result(ask, name)
            assert unit == "UM" and abs(v - e_true[k]) <= 3 * u, (name, v, u, e_true[k])
        # the log: a definite-length block of the run's text
        port.write(b"DATA:LOG?\n")
        log = read_block(port)
        lines = log.split("\n")
        assert lines[0].startswith("# ballpod run v") and "# pattern=SSM" in lines and "# end=DONE" in lines
        # the firmware that made it, in the log and in the stream's header
        assert "# firmware=" + firmware_version(ROOT) in lines
        (run,) = stream.runs(1)
        assert run.meta["firmware"] == firmware_version(ROOT), run.meta
        rows = [l for l in lines if l and not l.startswith("#")]
        assert rows[0].split(",") == run.cols
        streamed = {int(r[0]): r for r in run.data}
        logged = np.array([[float(v) for v in r.split(",")] for r in rows[1:]])
        assert len(logged) > 100
        # the log's 9 digits read back to the f32 the stream's record holds (ΔL, the axes);
        # sample number, time, temperature and flags are the same numbers
        f32 = slice(2, len(run.cols) - 2)
        for r in logged:
            s = streamed[int(r[0])]
            assert np.array_equal(np.float32(r[f32]), np.float32(s[f32]), equal_nan=True), r
            keep = [0, 1, len(run.cols) - 2, len(run.cols) - 1]
            assert np.array_equal(r[keep], s[keep], equal_nan=True), r
        # *RST: IDLE, the port locked again
        port.write(b"*RST\n")
        assert (ask("SESS:STAT?"), ask("CONF:LOCK?")) == ("IDLE", "1")
        assert ask("SYST:ERR?") == '0,"No error"'
    finally:
        port.close()
        stream.close()


def test_replay_of_the_stream_gives_the_pods_results(pod, tmp_path):
    """The stream text of a CCW and a CW run, replayed by `replay` into a fresh application, gives
    the results table the pod reports over SCPI — every valid result, and only those."""
    stream = StreamCapture(pod["stream_port"])
    rm, inst = open_visa(pod)
    q, w = inst.query, inst.write
    try:
        w("CONF:UNL")
        configure_circle(w, pod["truth"]["machine"]["circle"])
        run_circle(q, w, "CCW")
        run_circle(q, w, "CW")
        stream.runs(2)
        # the book's reader of the stream's records ("The sample stream and the log") on the
        # port's bytes: every row of both runs, the same numbers
        book = (ROOT / "docs" / "src" / "sample-stream.md").read_text()
        (reader,) = re.findall(r"```python\n(.*?)```", book, re.S)
        scope = {}
        exec(reader, scope)
        recs = list(scope["records"](stream.raw()))
        rows = np.vstack([r.data for r in stream.runs(2)])
        assert len(recs) == len(rows) > 500
        for (flags, seq, t_us, dl, axes, temp), row in zip(recs, rows):
            assert (seq, t_us / 1e6, flags) == (row[0], row[1], row[-1])
            assert np.array_equal(np.float32([dl, *axes]), np.float32(row[2:-2]), equal_nan=True)
        # the port's bytes as recorded: replay reads the sample records itself
        (tmp_path / "circle.stream").write_bytes(stream.raw())
        out = subprocess.run([host_binary("replay"), str(tmp_path / "circle.stream"), "--out", str(tmp_path / "out")],
                             capture_output=True, text=True)
        assert out.returncode == 0, out.stderr
        replayed = json.loads((tmp_path / "out" / "results.json").read_text())
        assert [(r["pattern"], r["direction"], r["outcome"]) for r in replayed["runs"]] == \
            [("CIRCLE", "CCW", "DONE"), ("CIRCLE", "CW", "DONE")]
        names = [n.strip('"') for n in q("FETC:RES:CAT?").split(",")]
        pod_results = {}
        for name in names:
            # a valid result answers, an invalid one queues -230: one line each
            answer = q(f"FETC:RES? {name};:SYST:ERR?")
            if answer.startswith("-230,"):
                continue
            first, _, err = answer.partition(";")  # response units are separated by ';'
            v, u, unit = first.split(",")
            assert err == '0,"No error"', answer
            pod_results[name] = (float(v), scpi_nan(float(u)), unit)
        assert len(pod_results) >= 20
        rep = {f["name"]: f for f in replayed["results"]}
        assert set(rep) == set(pod_results)
        for name, (v, u, unit) in pod_results.items():
            f = rep[name]
            assert f["value"] == pytest.approx(v, abs=1e-4), name
            assert (f["u"] is None) == math.isnan(u), name
            assert f["unit"].upper() == unit, name
    finally:
        inst.close()
        rm.close()
        stream.close()


@pytest.mark.sim_only
def test_a_reader_that_connects_and_arms_at_once_gets_the_runs_header(pod, tmp_path):
    """A client that opens the stream port and arms at once (no pause for the pod to take the
    reader) gets the run with its header: whole, and `replay` gives DONE; or, if the served pod
    took the reader after samples of the run went, marked `# partial=1`, and `replay` refuses it
    saying so — never a run without its header. (The race is the served pod's TCP accept against
    the command port; on the firmware the stream port opens with DTR, as the book says.)"""
    rm, inst = open_visa(pod)
    q, w = inst.query, inst.write
    try:
        w("CONF:UNL")
        configure_circle(w, pod["truth"]["machine"]["circle"])
        assert q("*OPC?") == "1"
        stream = StreamCapture(pod["stream_port"], settle=0.0)
        run_circle(q, w, "CCW")
        wait_until(lambda: b"# end=" in stream.raw(), 10.0, "the run's end on the stream")
        text = stream.text()
        assert text.startswith("# ballpod run v2\n"), text[:200]
        (tmp_path / "run.stream").write_bytes(stream.raw())
        out = subprocess.run([host_binary("replay"), str(tmp_path / "run.stream"), "--out", str(tmp_path / "out")],
                             capture_output=True, text=True)
        if "# partial=1\n" in text:
            assert out.returncode == 1 and "joined the run after its first samples" in out.stderr, out.stderr
        else:
            assert out.returncode == 0, out.stderr
            replayed = json.loads((tmp_path / "out" / "results.json").read_text())
            assert [r["outcome"] for r in replayed["runs"]] == ["DONE"]
        stream.close()
    finally:
        inst.close()
        rm.close()
