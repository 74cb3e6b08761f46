"""A serial client (pyserial over socket://) runs a full session on the simulated pod by SCPI
commands and downloads the log. `replay` turns the log into the same results; the log is also
checked independently here: a least-squares fit of ΔL = r0 + e·n over its rows (numpy) must give
the pod's reported eccentricity and the simulator's truth."""
import json
import subprocess
import time

import numpy as np
import pytest
import serial


def open_port(pod):
    port = serial.serial_for_url(f"socket://127.0.0.1:{pod['usb_port']}", timeout=5)
    return port


def ask(port, line):
    port.write((line + "\n").encode())
    return port.readline().decode().strip()


def read_block(port):
    """IEEE 488.2 definite-length block: '#', n, n digits of length, bytes, then '\\n'."""
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


def test_full_session_and_log_download(pod, tmp_path):
    port = open_port(pod)
    try:
        idn = ask(port, "*IDN?").split(",")
        assert len(idn) == 4 and idn[0].upper() == "BALLPOD"
        assert ask(port, "SYST:ERR?").startswith("0,")
        # configuration is locked until CONF:UNL: -203 "Command protected", unchanged
        port.write(b"CONF:BAR_LENGTH 150.0\n")
        assert ask(port, "SYST:ERR?").startswith("-203")
        assert ask(port, "CONF:LOCK?") == "1"
        port.write(b"CONF:UNL\n")
        assert ask(port, "CONF:LOCK?") == "0"
        # configuration: accepted, read back; out of range rejected with -222, unchanged
        port.write(b"CONF:BAR_LENGTH 150.0\n")
        assert float(ask(port, "CONF:BAR_LENGTH?")) == pytest.approx(150.0)
        port.write(b"CONF:BAR_LENGTH 20\n")
        assert ask(port, "SYST:ERR?").startswith("-222")
        assert float(ask(port, "CONF:BAR_LENGTH?")) == pytest.approx(150.0)
        # a line longer than the buffer is rejected whole; the next parses normally
        port.write(b"CONF:BAR_LENGTH " + b"1" * 400 + b"\n")
        assert ask(port, "SYST:ERR?").startswith("-363")
        assert float(ask(port, "CONF:BAR_LENGTH?")) == pytest.approx(150.0)
        # a session command in the wrong state: -221, state unchanged
        port.write(b"SESS:STOP\n")
        assert ask(port, "SYST:ERR?").startswith("-221")
        assert ask(port, "SESS:STAT?") == "IDLE"
        # the run
        port.write(b"SESS:PATT CIRC;DIR CCW;:SESS:ARM;STAR\n")
        assert ask(port, "SESS:STAT?") == "RUNNING"
        t0 = time.time()
        count = 0
        while time.time() - t0 < 10.0:
            count = int(ask(port, "DATA:LOG:COUN?"))
            if count >= 56_000:  # a full circle: 2π·150 mm at 1000 mm/min, 1 kHz
                break
            time.sleep(0.2)
        assert count >= 56_000
        port.write(b"SESS:STOP\n")
        assert ask(port, "SESS:STAT?") == "DONE"
        ex = [float(v) for v in ask(port, "FETC:RES? ecc_x").split(",")[:2]]
        ey = [float(v) for v in ask(port, "FETC:RES? ecc_y").split(",")[:2]]
        truth = pod["truth"]
        assert ex[0] == pytest.approx(truth["ecc_x_um"], abs=max(0.1, 5 * ex[1]))
        assert ey[0] == pytest.approx(truth["ecc_y_um"], abs=max(0.1, 5 * ey[1]))
        # the log
        port.write(b"DATA:LOG?\n")
        csv = read_block(port)
        meta = [l for l in csv.splitlines() if l.startswith("#")]
        rows = [l for l in csv.splitlines() if l and not l.startswith("#")]
        assert "# pattern=CIRCLE" in meta and "# direction=CCW" in meta
        header = rows[0].split(",")
        assert header[:2] == ["t_s", "dl_um"] and "x_mm" in header and "y_mm" in header
        data = np.array([[float(v) for v in r.split(",")] for r in rows[1:]])
        t, dl = data[:, 0], data[:, 1]
        x, y = data[:, header.index("x_mm")], data[:, header.index("y_mm")]
        assert np.all(np.diff(t) > 0)
        # independent limaçon fit over the logged samples
        r = np.hypot(x, y)
        a = np.column_stack([np.ones_like(x), x / r, y / r])
        sol, *_ = np.linalg.lstsq(a, dl, rcond=None)
        assert sol[1] == pytest.approx(ex[0], abs=0.02)
        assert sol[2] == pytest.approx(ey[0], abs=0.02)
        assert ask(port, "SYST:ERR?").startswith("0,")
        # replay: the downloaded log + a session description -> the same results
        (tmp_path / "circle.csv").write_text(csv)
        session = {"circle": {"radius_mm": 150.0, "socket_mm": [0.0, 0.0], "feed_mm_per_min": 1000.0},
                   "runs": [{"log": "circle.csv", "method": "ISO230-4", "direction": "CCW"}]}
        (tmp_path / "session.json").write_text(json.dumps(session))
        from conftest import host_binary
        subprocess.run([host_binary("replay"), str(tmp_path / "session.json"), "--out", str(tmp_path / "out")],
                       check=True, capture_output=True)
        results = json.loads((tmp_path / "out" / "results.json").read_text())
        run = results["runs"][0]
        assert run["samples"] == len(rows) - 1
        assert run["e_um"][0] == pytest.approx(ex[0], abs=0.01)
        assert run["e_um"][1] == pytest.approx(ey[0], abs=0.01)
    finally:
        port.close()
