"""What the client tests share: the pod's interface contract as its documents state it, a reader of
the sample stream port, and numpy implementations of the figures the pod reports, written from
their definitions (least-squares limaçon fit, ISO 230-4 G / F / G(b) / H on 1° bins) without the
pod's code, so that a test can hold the pod's answer against them."""
import math
import os
import re
import socket
import struct
import threading
import time

import canopen
import numpy as np
import pytest
from canopen.sdo.exceptions import SdoAbortedError

# --- the contract (the book's CANopen pages, EDS comments, SCPI names) ------------------------------------
PATTERN = {"CIRCLE": 0, "BX": 1, "BY": 2, "CR": 3, "CA": 4, "CR2": 5, "SSM": 6, "PROBE": 7}
DIRECTION = {"CCW": 0, "CW": 1}
COMMAND = {"arm": 1, "start": 2, "stop": 3, "abort": 4, "clear": 5, "reset": 6, "store": 7,
           "restore": 8}
LIVE = ["delta_l", "ssm_ex", "ssm_ey", "ssm_ez", "ecc_u", "ecc_v", "r0", "temp", "u_ssm_ex", "u_ssm_ey",
        "u_ssm_ez", "u_ecc_u", "u_ecc_v", "u_r0"]  # 0x2100:k+1
STATUS_RUNNING, STATUS_RESULTS_READY, STATUS_IDENTIFYING = 1 << 9, 1 << 10, 1 << 13
def firmware_version(root):
    """The version the pod's firmware was built as: the crate's version (Cargo.toml) and the
    commit, asked of git (`0.2.0+1a2b3c4d5e6f`; `*IDN?`, CANopen 0x100A after `ballpod `)."""
    import re
    import subprocess
    version = re.search(r'^version\s*=\s*"([^"]+)"', (root / "Cargo.toml").read_text(), re.M).group(1)
    commit = subprocess.run(["git", "rev-parse", "--short=12", "HEAD"], cwd=root, check=True,
                            capture_output=True, text=True).stdout.strip()
    return f"{version}+{commit}"


# SYST:COUN? / 0x2110, in order (src/app/device.rs DEVICE_COUNTERS)
DEVICE_COUNTERS = ["adc_blocks_lost", "block_queue_overruns", "probe_queue_overruns",
                   "thermistor_queue_overruns", "can_rx_overruns", "can_tx_overruns", "can_tx_dropped",
                   "usb_rx_overruns", "usb_tx_overruns", "stream_lines_dropped", "log_paused_samples",
                   "settings_store_failures", "watchdog_misses", "dac_underruns", "masked_max_ns",
                   "stack_high_water_bytes", "settings_slots_unreadable",
                   "can_rx_lost", "can_bus_off_entries", "can_error_passive_entries"]

# CiA 301 table 22 abort codes
ABORT_WRITE_ONLY = 0x06010001
ABORT_READ_ONLY = 0x06010002
ABORT_NO_OBJECT = 0x06020000
ABORT_PARAMETER_INCOMPATIBLE = 0x06040043
ABORT_LENGTH = 0x06070010
ABORT_NO_SUB_INDEX = 0x06090011
ABORT_INVALID_VALUE = 0x06090030
ABORT_TOO_HIGH = 0x06090031
ABORT_TOO_LOW = 0x06090032
ABORT_DEVICE_STATE = 0x08000022
ABORT_NO_DATA = 0x08000024
# CiA 301 table 44 data types
BOOLEAN, UNSIGNED8, UNSIGNED16, UNSIGNED32, REAL32 = 0x1, 0x5, 0x6, 0x7, 0x8
TYPE_SIZE = {BOOLEAN: 1, UNSIGNED8: 1, UNSIGNED16: 2, UNSIGNED32: 4, REAL32: 4}

# Seed 002 ball-bar set-up, thesis Table 4.3 (shared/spec/seed-002.md §5.5), mm; the model origin
# O_M at machine zero.
TABLE_4_3 = {"s002_l_b": 100.0, "s002_r_b": 356.3945, "s002_r_b2": 406.4608, "s002_r_c": 50.0,
             "s002_z_c": 65.5348, "s002_z_t": 112.2877, "s002_z_t2": 62.2491, "s002_x_t": 490.0,
             "s002_origin_x": 0.0, "s002_origin_y": 0.0, "s002_origin_z": 0.0}
# Model-mode deviation (pod result name) -> the truth's key (the key names the unit: um / arcsec)
SEED002_DEVIATIONS = {"dx_BT": "dx_bt_um", "dz_BT": "dz_bt_um", "alpha_BT": "alpha_bt_arcsec",
                      "alpha_XB": "alpha_xb_arcsec", "beta_XB": "beta_xb_arcsec",
                      "gamma_XB": "gamma_xb_arcsec", "dx_CZ": "dx_cz_um", "dy_CZ": "dy_cz_um",
                      "alpha_CZ": "alpha_cz_arcsec", "beta_CZ": "beta_cz_arcsec"}


def abort_code(fn):
    """The SDO abort code `fn` provokes (it must abort)."""
    with pytest.raises(SdoAbortedError) as e:
        fn()
    return e.value.code


def wait_until(cond, timeout, what, period=0.05):
    t0 = time.time()
    while not cond():
        if time.time() - t0 > timeout:
            raise AssertionError(f"timed out after {timeout} s waiting for {what}")
        time.sleep(period)


# --- the sample stream port ------------------------------------------------------------------------
class Run:
    """One run of the stream text: `meta` (header `# key=value`), `cols`, `data` (rows, float),
    `end` (end lines `# key=value`)."""

    def __init__(self, meta, cols, rows, end):
        self.meta, self.cols, self.end = meta, cols, end
        self.data = np.array([[float(v) for v in r.split(",")] for r in rows]).reshape(-1, len(cols))

    def col(self, name):
        return self.data[:, self.cols.index(name)]

    @property
    def complete(self):
        return "stream_dropped" in self.end


RECORD_TAG = 0xB5


def decode_stream(data):
    """The stream port's bytes as the run text: text lines as they are, each sample record (tag
    0xB5, n axis columns, little-endian `<H I Q f nf f`: flags, seq, µs, ΔL, the axes, °C; the
    book's "The sample stream and the log") as a row of exact values: ΔL and positions as the
    f32's own value, time to the µs, temperature to 0.01 °C as the log writes it; the NUL
    bytes that pad each item to a multiple of 4 skipped. Stops at a record or line not yet
    complete."""
    out, at = [], 0
    while at < len(data):
        if data[at] == 0:  # padding: every item starts on a multiple of 4 bytes
            at += 1
        elif data[at] == RECORD_TAG:
            if at + 2 > len(data):
                break
            n = data[at + 1]
            assert n <= 5, f"byte {at}: not a sample record"
            size = 24 + 4 * n
            if at + size > len(data):
                break
            flags, seq, t_us = struct.unpack_from("<HIQ", data, at + 2)
            vals = struct.unpack_from(f"<{n + 2}f", data, at + 16)
            # the pod's log: the f32 product °C · 100, ± 0.5 in f32, truncated
            centi = np.float32(vals[-1]) * np.float32(100.0)
            if np.isfinite(centi) and abs(centi) < 32767.0:
                half = np.float32(-0.5) if centi < 0 else np.float32(0.5)
                temp = f"{int(centi + half) / 100:.2f}"
            else:
                temp = "nan"
            cells = [str(seq), f"{t_us // 1_000_000}.{t_us % 1_000_000:06d}"]
            cells += ["nan" if math.isnan(v) else repr(v) for v in vals[:-1]]
            cells += [temp, str(flags)]
            out.append(",".join(cells) + "\n")
            at += size
        else:
            end = data.find(b"\n", at)
            if end < 0:
                break
            out.append(data[at:end + 1].decode())
            at = end + 1
    return "".join(out)


def parse_runs(text):
    """The runs of a stream text (`# ballpod run v2` … `# stream_dropped=N`): a plain reader of
    the format of src/protocol/csv.rs."""
    runs, cur = [], None
    # whole lines only: the port delivers bytes as they come (a UART's a byte at a time)
    for line in text[:text.rfind("\n") + 1].split("\n"):
        if line.startswith("# ballpod run v"):
            cur = {"meta": {}, "cols": None, "rows": [], "end": {}}
            runs.append(cur)
        elif cur is None or not line:
            continue
        elif line.startswith("# "):
            k, _, v = line[2:].partition("=")
            (cur["meta"] if cur["cols"] is None else cur["end"])[k] = v
        elif cur["cols"] is None:
            cur["cols"] = line.split(",")
        else:
            cur["rows"].append(line)
    return [Run(r["meta"], r["cols"] or [], r["rows"], r["end"]) for r in runs]


class StreamCapture:
    """Reads the stream port in a thread (the pod blocks on a full socket, so keep reading)."""

    def __init__(self, port, settle=0.3):
        self.sock = socket.create_connection(("127.0.0.1", port))
        self.buf = bytearray()
        self.lock = threading.Lock()
        threading.Thread(target=self._read, daemon=True).start()
        # the pod takes the reader on its next loop turn: runs armed from then on arrive whole
        # (one armed before gets its header when the reader is taken, `# partial=1` if samples
        # of it went before)
        time.sleep(settle)

    def _read(self):
        while True:
            try:
                d = self.sock.recv(1 << 16)
            except OSError:
                return
            if not d:
                return
            with self.lock:
                self.buf.extend(d)

    def raw(self):
        """The bytes the port sent (text lines and sample records), as a recording is kept."""
        with self.lock:
            return bytes(self.buf)

    def text(self):
        """The stream as the run text: each sample record as the row the log writes."""
        return decode_stream(self.raw())

    def runs(self, n, timeout=10.0):
        """The first `n` runs, once the stream has ended all of them."""
        got = []

        def done():
            got[:] = parse_runs(self.text())
            return len(got) >= n and all(r.complete for r in got[:n])

        wait_until(done, timeout, f"{n} complete runs on the stream port")
        return got[:n]

    def close(self):
        self.sock.close()


# --- numpy figures --------------------------------------------------------------------------------
def limacon_fit(u_mm, v_mm, dl_um, centre=(0.0, 0.0)):
    """Least squares ΔL = r0 + e_u·n_u + e_v·n_v, n the unit vector from the centre: r0, e and
    their standard uncertainties from the residual RMS, the residuals, n."""
    du, dv = u_mm - centre[0], v_mm - centre[1]
    r = np.hypot(du, dv)
    nu, nv = du / r, dv / r
    a = np.column_stack([np.ones_like(nu), nu, nv])
    x, *_ = np.linalg.lstsq(a, dl_um, rcond=None)
    res = dl_um - a @ x
    rms = float(np.sqrt(np.mean(res ** 2)))
    u = rms * np.sqrt(np.diag(np.linalg.inv(a.T @ a)))
    return {"r0": x[0], "e_u": x[1], "e_v": x[2], "u_r0": u[0], "u_e": u[1],
            "residual_rms": rms, "x": x, "nu": nu, "nv": nv}


def arc_deg(nu, nv):
    """The angle turned along the samples, degrees."""
    th = np.unwrap(np.arctan2(nv, nu))
    return float(abs(th[-1] - th[0]) * 180.0 / math.pi)


def bins_1deg(nu, nv, dl):
    """ISO 230-4 profile on 1° bins from +u: per bin the means of ΔL, n_u, n_v."""
    k = np.minimum((np.mod(np.arctan2(nv, nu), 2 * math.pi) * 180.0 / math.pi).astype(int), 359)
    out = {}
    for b in np.unique(k):
        m = k == b
        out[int(b)] = (dl[m].mean(), nu[m].mean(), nv[m].mean())
    return out


def profile_residuals(bins, x):
    return {b: d - x[0] - x[1] * u - x[2] * v for b, (d, u, v) in bins.items()}


def iso230_4(ccw, cw):
    """ISO 230-4 figures of a CCW and a CW run (each from `limacon_fit`, with `dl`): G, F per
    direction on 1° bin means; G(b), H and the mean bi-directional radial deviation from one circle fitted to
    both directions."""
    out = {}
    bins = {}
    for name, f in (("ccw", ccw), ("cw", cw)):
        bins[name] = bins_1deg(f["nu"], f["nv"], f["dl"])
        r = profile_residuals(bins[name], f["x"])
        out[f"G_{name}"] = max(r.values()) - min(r.values())
        # F on the same bin means (the single samples' extremes would be the noise's)
        out[f"F_max_{name}"] = float(max(d for d, _, _ in bins[name].values()))
        out[f"F_min_{name}"] = float(min(d for d, _, _ in bins[name].values()))
    nu = np.concatenate([ccw["nu"], cw["nu"]])
    nv = np.concatenate([ccw["nv"], cw["nv"]])
    dl = np.concatenate([ccw["dl"], cw["dl"]])
    x, *_ = np.linalg.lstsq(np.column_stack([np.ones_like(nu), nu, nv]), dl, rcond=None)
    ra, rb = profile_residuals(bins["ccw"], x), profile_residuals(bins["cw"], x)
    both = list(ra.values()) + list(rb.values())
    out["G_bidir"] = max(both) - min(both)
    out["H"] = max(abs(ra[b] - rb[b]) for b in ra if b in rb)
    out["radial_bidir"] = x[0]
    return out


def fit_run(run, u="x_mm", v="y_mm", centre=(0.0, 0.0)):
    """`limacon_fit` of a recorded circular run's used samples (flags 0)."""
    ok = run.col("flags") == 0
    f = limacon_fit(run.col(u)[ok], run.col(v)[ok], run.col("dl_um")[ok], centre)
    f["dl"] = run.col("dl_um")[ok]
    f["arc"] = arc_deg(f["nu"], f["nv"])
    return f


# --- CANopen -------------------------------------------------------------------------------------
def connect(pod, eds):
    net = canopen.Network()
    net.connect(interface="slcan", channel=f"socket://127.0.0.1:{pod['can_port']}", bitrate=500000,
                sleep_after_open=0)
    try:
        node = net.add_node(pod["node_id"], eds)
        node.sdo.RESPONSE_TIMEOUT = 2.0
        node.nmt.wait_for_heartbeat(3)
    except BaseException:
        net.disconnect()
        raise
    return net, node


def tpdo_snapshots(node, others):
    """A list that fills, per SYNC, with one dict of the mapped values: TPDO1 (it carries the
    sample counter) starts a snapshot, the TPDOs `others` of the same SYNC add to it."""
    snaps = []
    node.tpdo[1].add_callback(lambda m: snaps.append({v.name: v.raw for v in m.map}))
    for k in others:
        node.tpdo[k].add_callback(lambda m: snaps and snaps[-1].update({v.name: v.raw for v in m.map}))
    return snaps


def configure_circle(sdo, circle):
    """The ISO 230-4 set-up of the truth's circle machine: socket at X = Y = 0 (machine file
    doc), radius = bar length, the machine's feed (so the servo mismatch is evaluated)."""
    sdo["bar_length"].raw = circle["radius_mm"]
    sdo["circle_plane"].raw = 0  # XY
    sdo["circle_centre_x"].raw = 0.0
    sdo["circle_centre_y"].raw = 0.0
    sdo["circle_radius"].raw = circle["radius_mm"]
    sdo["circle_feed"].raw = circle["feed_mm_per_min"]


# the emulated board's virtual CNC runs at real time (sim --serve's runs faster while a run runs)
RUN_TIMEOUT = 240.0 if os.environ.get("BALLPOD_POD") == "emu" else 30.0
# The emulated board's virtual CNC (emu --serve) puts the machine at an armed run's start a few
# sample periods after it sees the run armed; a CNC starts a run once its positioning move is
# done. `conftest` sets this to a function that says how many times it has (the harness's
# figures, `positioned`); None against sim --serve, whose virtual CNC starts at once.
POSITIONED = None


def arm_then_start(arm, start):
    """Arms (`arm()`), waits until the machine stands at the run's start, starts (`start()`)."""
    before = POSITIONED() if POSITIONED else 0
    arm()
    if POSITIONED:
        wait_until(lambda: POSITIONED() > before, 10, "the machine at the armed run's start")
    start()


def run(sdo, pattern, direction, timeout=None):
    """Arms and starts a run; the served machine ends it with its motion. Returns the state,
    once a run that ended DONE has its results (status bit 10 RESULTS_READY: the jobs it left
    have published them), as a CNC reads them (book "The CNC's side")."""
    timeout = timeout or RUN_TIMEOUT
    sdo["pattern"].raw = PATTERN[pattern]
    sdo["direction"].raw = DIRECTION[direction]

    def arm():
        sdo["session_command"].raw = COMMAND["arm"]
        assert sdo["session_state"].raw == 1  # ARMED

    arm_then_start(arm, lambda: setattr(sdo["session_command"], "raw", COMMAND["start"]))
    wait_until(lambda: sdo["session_state"].raw != 2, timeout, f"the {pattern} {direction} run's end")
    state = sdo["session_state"].raw
    if state == 3:  # DONE
        wait_until(lambda: sdo["status_word"].raw & STATUS_RESULTS_READY, 30, "the run's results")
    return state


def wait_results_scpi(query):
    """After a run ended DONE: until `STAT:POD?` has bit 10 RESULTS_READY (the jobs the run left
    have published its results)."""
    wait_until(lambda: int(query("STAT:POD?")) & STATUS_RESULTS_READY, 30, "the run's results")


def result(sdo, name):
    """(value, standard uncertainty) of a result, which must be valid (0x4002)."""
    assert sdo["result_valid"][name].raw is True, name
    return sdo["result_value"][name].raw, sdo["result_uncertainty"][name].raw


def assert_refused(sdo, command, reason):
    """Session command `command` is refused: abort 0x08000022 and 0x3006 says `reason`."""
    assert abort_code(lambda: setattr(sdo["session_command"], "raw", COMMAND[command])) == ABORT_DEVICE_STATE
    assert sdo["last_refusal"].raw == reason


def assert_invalid(sdo, name):
    """An invalid result is never sent as a number: 0x4000/0x4001 abort "no data available"."""
    assert sdo["result_valid"][name].raw is False, name
    assert abort_code(lambda: sdo["result_value"][name].raw) == ABORT_NO_DATA, name
    assert abort_code(lambda: sdo["result_uncertainty"][name].raw) == ABORT_NO_DATA, name


# --- SCPI -----------------------------------------------------------------------------------------
def scpi_result(query, name):
    """`FETC:RES? name` → (value, uncertainty or NaN, unit); `query` sends a line, returns a line."""
    v, u, unit = query(f"FETC:RES? {name}").split(",")
    return float(v), float(u), unit


def scpi_nan(x):
    """SCPI's NaN (9.91E+37, SCPI-99 vol 1 §7.2.1.5) as float NaN."""
    return math.nan if abs(x - 9.91e37) < 1e31 else x


SCPI_ERROR = re.compile(r'^(-?\d+),"(.*)"$')


class SerialBridge:
    """A pseudo-terminal whose far end is one of the served pod's TCP ports: the port as the
    serial device a USB CDC-ACM port is (the desk opens it by path, raw, as /dev/ttyACMn)."""

    def __init__(self, port):
        import tty
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)
        self.sock = socket.create_connection(("127.0.0.1", port))

        def pump(read, write):
            try:
                while data := read(1 << 16):
                    write(data)
            except OSError:
                pass
        threading.Thread(target=pump, args=(lambda n: os.read(self.master, n), self.sock.sendall),
                         daemon=True).start()
        threading.Thread(target=pump, args=(self.sock.recv, lambda d: os.write(self.master, d)),
                         daemon=True).start()

    def close(self):
        self.sock.close()
        for fd in (self.master, self.slave):
            os.close(fd)
