"""The `canopen` package on python-can's slcan interface as the CNC, against the simulated pod.

Expectations come from CiA 301 (abort codes, data type sizes, NMT states, frame layouts), the EDS,
the simulator's truth (the JSON line) and numpy fits of the samples the pod streamed — not from
the pod's own output."""
import math
import pathlib
import struct
import time

import canopen
import numpy as np
import pytest

from podlib import (ABORT_DEVICE_STATE, ABORT_INVALID_VALUE, ABORT_LENGTH, ABORT_NO_OBJECT,
                    ABORT_NO_SUB_INDEX, ABORT_PARAMETER_INCOMPATIBLE, ABORT_READ_ONLY, ABORT_TOO_HIGH,
                    ABORT_TOO_LOW, ABORT_WRITE_ONLY, BOOLEAN, COMMAND, LIVE, PATTERN, REAL32,
                    STATUS_RUNNING, TYPE_SIZE, UNSIGNED8, UNSIGNED16, UNSIGNED32, StreamCapture,
                    abort_code, assert_invalid, assert_refused, configure_circle, connect, firmware_version,
                    fit_run, iso230_4,
                    limacon_fit, result, run, tpdo_snapshots)

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_identity_heartbeat_and_nmt(pod, eds):
    net, node = connect(pod, eds)
    try:
        assert node.nmt.state == "PRE-OPERATIONAL"
        # identity as the EDS's [DeviceInfo] states it
        od = canopen.import_od(eds)
        assert node.sdo["Identity object"]["Product code"].raw == od.device_information.product_number
        assert node.sdo["Identity object"]["Vendor-ID"].raw == od.device_information.vendor_number
        assert node.sdo["Identity object"]["Revision number"].raw == od.device_information.revision_number
        name = node.sdo["Manufacturer device name"].raw  # segmented upload (> 4 bytes)
        assert name == od.device_information.product_name
        # the software version is the crate's and the commit the firmware was built from
        assert node.sdo["Manufacturer software version"].raw == "ballpod " + firmware_version(ROOT)
        assert node.sdo["Producer heartbeat time"].raw == 1000
        # NMT transitions, seen in the heartbeat (CiA 301: 0x04 stopped, 0x05 operational, 0x7F pre-op)
        for state in ("OPERATIONAL", "STOPPED", "PRE-OPERATIONAL"):
            node.nmt.state = state
            time.sleep(0.05)
            node.nmt.wait_for_heartbeat(3)
            node.nmt.wait_for_heartbeat(3)
            assert node.nmt.state == state
        # reset communication: boot-up (state 0) then pre-operational
        node.nmt.state = "RESET COMMUNICATION"
        node.nmt.wait_for_bootup(3)
        node.nmt.wait_for_heartbeat(3)
        assert node.nmt.state == "PRE-OPERATIONAL"
    finally:
        net.disconnect()


def test_every_abort_code(pod, eds):
    net, node = connect(pod, eds)
    try:
        assert abort_code(lambda: node.sdo.upload(0x5FFF, 0)) == ABORT_NO_OBJECT
        assert abort_code(lambda: node.sdo.upload(0x1018, 9)) == ABORT_NO_SUB_INDEX
        assert abort_code(lambda: node.sdo.download(0x1018, 1, b"\x01\x00\x00\x00")) == ABORT_READ_ONLY
        assert abort_code(lambda: node.sdo.upload(0x3002, 0)) == ABORT_WRITE_ONLY
        assert abort_code(lambda: node.sdo.download(0x2000, 0, b"\x00\x00")) == ABORT_LENGTH
        # raw SDO frames: command specifier, toggle, timeout (client → 0x600+n, server → 0x580+n)
        n = pod["node_id"]
        got = []
        net.subscribe(0x580 + n, lambda cob, data, ts: got.append(bytes(data)))

        def request(data, wait=0.3):
            got.clear()
            net.send_message(0x600 + n, bytes(data))
            t0 = time.time()
            while not got and time.time() - t0 < wait:
                time.sleep(0.01)
            return got[0] if got else None

        def code(frame):
            assert frame is not None and frame[0] == 0x80, frame
            return struct.unpack("<I", frame[4:8])[0]

        assert code(request([0xE0, 0, 0, 0, 0, 0, 0, 0])) == 0x05040001
        # segmented download initiated (size 4) to bar_cte (0x2001)
        init = request([0x21, 0x01, 0x20, 0x00, 4, 0, 0, 0])
        assert init is not None and init[0] == 0x60
        assert code(request([0x10, 1, 2, 3, 4, 5, 6, 7])) == 0x05030000  # first segment has toggle 0
        init = request([0x21, 0x01, 0x20, 0x00, 4, 0, 0, 0])
        assert init is not None and init[0] == 0x60
        got.clear()  # ... and the client falls silent
        t0 = time.time()
        while not got and time.time() - t0 < 3.0:  # server-side SDO timeout (1 s)
            time.sleep(0.02)
        assert got and code(got[0]) == 0x05040000
        od = canopen.import_od(eds)
        assert node.sdo["bar_cte"].raw == pytest.approx(float(od["bar_cte"].default), abs=1e-4)
    finally:
        net.disconnect()


def test_configuration_typed_objects(pod, eds):
    """Each configuration object has its EDS data type and range; a write of the wrong length,
    out of range, not a value, or breaking a cross-field rule aborts with its CiA 301 code and
    changes nothing; configuration is written only in pre-operational."""
    net, node = connect(pod, eds)
    sdo, od = node.sdo, node.object_dictionary
    try:
        # data types of the EDS, and the SDO transfer length CiA 301 gives each type
        for name, sub, ty in [("bar_length", None, REAL32), ("samples_per_period", None, UNSIGNED16),
                              ("probe_debounce", None, UNSIGNED32), ("can_node_id", None, UNSIGNED8),
                              ("circle_plane", None, UNSIGNED8), ("axis_name", 1, UNSIGNED8),
                              ("axis_reversed", 1, BOOLEAN), ("live_values", 1, REAL32),
                              ("status_word", None, UNSIGNED16), ("live_valid", None, UNSIGNED16)]:
            var = od[name] if sub is None else od[name][sub]
            assert var.data_type == ty, name
            assert len(sdo.upload(var.index, var.subindex)) == TYPE_SIZE[ty], name
        assert sdo["can_node_id"].raw == pod["node_id"]
        # expedited REAL32 write, read back (f32)
        sdo["bar_length"].raw = 150.012
        assert sdo["bar_length"].raw == pytest.approx(150.012, abs=1e-4)
        # segmented download of a REAL32 (CiA 301 §7.2.4.3.3)
        sdo.download(od["bar_cte"].index, 0, struct.pack("<f", 0.5), force_segment=True)
        assert sdo["bar_cte"].raw == pytest.approx(0.5, abs=1e-6)
        # integer objects
        sdo["samples_per_period"].raw = 20  # the excitation table's 20 points: its only value
        sdo["probe_debounce"].raw = 2500
        assert (sdo["samples_per_period"].raw, sdo["probe_debounce"].raw) == (20, 2500)
        assert abort_code(lambda: setattr(sdo["samples_per_period"], "raw", 32)) == ABORT_TOO_HIGH
        assert abort_code(lambda: sdo.download(od["samples_per_period"].index, 0, b"\x20\0\0\0")) == ABORT_LENGTH
        # the EDS's LowLimit / HighLimit: the limits are writable, beyond them 0x06090032 / 31
        lo, hi = od["bar_length"].min, od["bar_length"].max
        sdo["bar_length"].raw = lo
        assert sdo["bar_length"].raw == pytest.approx(lo)
        sdo["bar_length"].raw = 150.0
        assert abort_code(lambda: setattr(sdo["bar_length"], "raw", lo - 1)) == ABORT_TOO_LOW
        assert abort_code(lambda: setattr(sdo["bar_length"], "raw", hi + 1)) == ABORT_TOO_HIGH
        assert abort_code(lambda: setattr(sdo["bar_length"], "raw", math.nan)) == ABORT_INVALID_VALUE
        assert sdo["bar_length"].raw == pytest.approx(150.0)
        top = od["circle_plane"].max
        assert abort_code(lambda: setattr(sdo["circle_plane"], "raw", top + 1)) == ABORT_TOO_HIGH
        assert abort_code(lambda: sdo.download(od["axis_reversed"][1].index, 1, b"\x02")) == ABORT_INVALID_VALUE
        # cross-field rules: general parameter incompatibility, nothing changed
        x_input = sdo["axis_name"][1].raw
        assert abort_code(lambda: setattr(sdo["axis_name"][2], "raw", x_input)) == ABORT_PARAMETER_INCOMPATIBLE
        assert sdo["axis_name"][2].raw != x_input
        # a sample is 1 to 5 whole excitation periods (the ADC ring, config.rs): 5 kHz / 1 kHz
        # passes, 8 kHz / 1 kHz does not
        assert abort_code(lambda: setattr(sdo["excitation"], "raw", 8000.0)) == ABORT_PARAMETER_INCOMPATIBLE
        assert sdo["excitation"].raw == 5000.0
        # configuration only in pre-operational
        node.nmt.state = "OPERATIONAL"
        time.sleep(0.05)
        assert abort_code(lambda: setattr(sdo["bar_length"], "raw", 151.0)) == ABORT_DEVICE_STATE
        node.nmt.state = "PRE-OPERATIONAL"
        time.sleep(0.05)
        assert sdo["bar_length"].raw == pytest.approx(150.0)
    finally:
        net.disconnect()


def test_refusals_with_the_reason(pod, eds):
    """A command the session state does not allow, a pattern without its geometry, a change while
    a run is armed or running: abort 0x08000022, nothing changes, 0x3006 says why."""
    net, node = connect(pod, eds)
    sdo = node.sdo
    try:
        sdo["pattern"].raw = PATTERN["CIRCLE"]
        assert_refused(sdo, "arm", "circle_centre_x not set")
        assert_refused(sdo, "start", "START needs ARMED")
        assert sdo["session_state"].raw == 0
        # out of the EDS's range of the command and pattern objects
        assert abort_code(lambda: setattr(sdo["session_command"], "raw", 9)) == ABORT_TOO_HIGH
        assert abort_code(lambda: setattr(sdo["pattern"], "raw", 8)) == ABORT_TOO_HIGH
        configure_circle(sdo, pod["truth"]["machine"]["circle"])
        sdo["session_command"].raw = COMMAND["arm"]
        sdo["session_command"].raw = COMMAND["start"]
        assert sdo["session_state"].raw == 2
        for obj, value in [("bar_length", 151.0), ("pattern", PATTERN["SSM"]), ("direction", 1)]:
            assert abort_code(lambda: setattr(sdo[obj], "raw", value)) == ABORT_DEVICE_STATE, obj
            assert sdo["last_refusal"].raw == "not while a run is armed or running"
        assert_refused(sdo, "arm", "ARM needs IDLE, DONE or ABORTED")
        assert (sdo["bar_length"].raw, sdo["pattern"].raw, sdo["direction"].raw) == (150.0, 0, 0)
        # abort by command: ABORTED, reason 1, no results
        sdo["session_command"].raw = COMMAND["abort"]
        assert (sdo["session_state"].raw, sdo["abort_reason"].raw) == (4, 1)
        assert_invalid(sdo, "ecc_u")
    finally:
        net.disconnect()


def test_circle_ccw_then_cw_against_numpy_and_truth(pod, eds):
    """The ISO 230-4 circle CCW then CW: the results read over SDO equal a numpy fit of the
    samples the pod streamed, and the eccentricity is the truth's socket offset turned round;
    while running, SYNC-driven TPDOs carry the streamed ΔL of their sample and the validity mask
    matches the values; results are invalid until computed and again after a reset."""
    truth = pod["truth"]["machine"]["circle"]
    stream = StreamCapture(pod["stream_port"])
    net, node = connect(pod, eds)
    sdo = node.sdo
    try:
        # nothing computed yet: invalid, never 0.0
        for name in ("ecc_u", "G_ccw", "G_bidir"):
            assert_invalid(sdo, name)
        for k, name in enumerate(LIVE):
            if name not in ("delta_l", "temp"):
                assert math.isnan(sdo["live_values"][name].raw) and not sdo["live_valid"].raw & 1 << k
        configure_circle(sdo, truth)
        # TPDOs 1–3 (ΔL + sample counter, e_u + e_v, r0 + status word + validity) on each SYNC
        node.tpdo.read()
        snaps = tpdo_snapshots(node, (2, 3))
        node.nmt.state = "OPERATIONAL"
        net.sync.start(0.02)
        assert run(sdo, "CIRCLE", "CCW") == 3
        net.sync.stop()
        node.nmt.state = "PRE-OPERATIONAL"
        ccw_pod = {n: result(sdo, n) for n in ("ecc_u", "ecc_v", "r0", "residual_rms", "arc", "G_ccw",
                                               "F_max_ccw", "F_min_ccw")}
        for name in ("G_cw", "G_bidir", "H", "squareness"):
            assert_invalid(sdo, name)  # need the CW run
        assert run(sdo, "CIRCLE", "CW") == 3
        pod_r = {n: result(sdo, n) for n in ("G_ccw", "F_max_ccw", "F_min_ccw", "G_cw", "F_max_cw",
                                             "F_min_cw", "G_bidir", "H", "radial_bidir")}
        cw_pod = {n: result(sdo, n) for n in ("ecc_u", "ecc_v", "r0", "residual_rms", "arc")}
        diag = {n: result(sdo, n)[0] for n in ("squareness", "scale_mismatch", "reversal_u", "reversal_v",
                                               "cyclic_amplitude", "cyclic_order", "servo_mismatch")}
        runs = stream.runs(2)
        assert [(r.meta["pattern"], r.meta["direction"], r.end["end"]) for r in runs] == \
            [("CIRCLE", "CCW", "DONE"), ("CIRCLE", "CW", "DONE")]
        fits = [fit_run(r) for r in runs]
        # the bar's budget as configured (the book's "The bar's own budget"): a constant shift
        # of ΔL with u = √(u_L² + (L·α·u_T)²), r0 and F move by it; every figure by u_k × itself
        bar = {n: sdo[n].raw for n in ("bar_length", "bar_cte", "bar_u_length", "bar_u_temp",
                                       "lvdt_u_scale")}
        u_shift = math.hypot(bar["bar_u_length"],
                             bar["bar_length"] * 1e3 * bar["bar_cte"] * 1e-6 * bar["bar_u_temp"])
        u_k = bar["lvdt_u_scale"] * 1e-6
        assert u_shift > 0.5 and u_k > 0.0, bar
        for r, f, p in zip(runs, fits, (ccw_pod, cw_pod)):
            assert int(r.end["stream_dropped"]) == 0 and int(r.end["used"]) == len(f["dl"])
            # (a) numpy: least-squares limaçon over the streamed samples, its stated uncertainty
            assert p["ecc_u"][0] == pytest.approx(f["e_u"], abs=2e-3)
            assert p["ecc_v"][0] == pytest.approx(f["e_v"], abs=2e-3)
            assert p["r0"][0] == pytest.approx(f["r0"], abs=2e-3)
            # u(e) is the noise's (the profile's third differences), not the residual's, which
            # counts the faults' shape as noise: below numpy's residual u, with u_k × e added
            assert u_k * abs(p["ecc_u"][0]) < p["ecc_u"][1] < f["u_e"], (p["ecc_u"], f["u_e"])
            # u(r0): the shift's, with the noise's and u_k × r0 under a nanometre-scale rest
            assert p["r0"][1] == pytest.approx(math.hypot(u_shift, u_k * p["r0"][0]), abs=0.01)
            assert p["residual_rms"][0] == pytest.approx(f["residual_rms"], rel=1e-3)
            assert p["arc"][0] == pytest.approx(f["arc"], abs=0.01)
            # (b) truth: ΔL = |P − S| − R with the socket S off by s: e = −s within 3u
            s = truth["socket_offset_um"]
            u = p["ecc_u"][1]
            assert abs(p["ecc_u"][0] + s[0]) <= 3 * u and abs(p["ecc_v"][0] + s[1]) <= 3 * u, (p, s)
        iso = iso230_4(*fits)
        for name, (v, u) in pod_r.items():
            # the bar's share of u (F and the radial deviation: the shift's; all: u_k × value)
            radial = name.startswith("F_") or name == "radial_bidir"
            u_bar = math.hypot(u_shift if radial else 0.0, u_k * v)
            if name == "radial_bidir":
                # numpy's joint fit of the streamed samples (at the stream's resolution); the
                # noise's u through that fit is nanometres over a whole circle of samples
                assert v == pytest.approx(iso[name], abs=0.01), name
                assert u_bar * (1 - 1e-5) <= u < math.hypot(u_bar, 0.01), (name, u, u_bar)
                continue
            # numpy's extremes of the bin means, which the pod corrects for the noise's bias by
            # less than its stated noise u twice over (metrology/extremes.rs)
            assert u_bar * (1 - 1e-5) <= u < math.hypot(u_bar, 0.1), (name, u, u_bar)
            u_noise = math.sqrt(max(u * u - u_bar * u_bar, 0.0))
            assert v == pytest.approx(iso[name], abs=2 * u_noise), name
        # the diagnoses against the injected faults (±10 %, as sim_iso230_4.rs)
        injected = {"squareness": truth["squareness_urad"],
                    "scale_mismatch": truth["scale_x_um_per_m"] - truth["scale_y_um_per_m"],
                    "reversal_u": truth["backlash_x_um"], "reversal_v": truth["backlash_y_um"],
                    "cyclic_amplitude": truth["cyclic_amplitude_um"],
                    "servo_mismatch": truth["servo_lag_x_ms"] - truth["servo_lag_y_ms"]}
        for name, v in injected.items():
            assert diag[name] == pytest.approx(v, rel=0.10), name
        assert diag["cyclic_order"] == truth["cyclic_order"]
        # the TPDOs of the CCW run against the streamed samples of the same sample number
        rows = {int(s): i for i, s in enumerate(runs[0].col("seq"))}
        dl = runs[0].col("dl_um")
        seen = [s for s in snaps if int(s["sample_counter"]) in rows and "live_valid" in s]
        assert len(seen) >= 20, len(snaps)
        # the arc turned up to each sample; the live fit is valid once it reaches circle_min_arc
        turned = np.degrees(np.abs(np.unwrap(np.arctan2(runs[0].col("y_mm"), runs[0].col("x_mm")))
                                   - math.atan2(runs[0].col("y_mm")[0], runs[0].col("x_mm")[0])))
        min_arc = float(runs[0].meta["circle_min_arc"])
        for s in seen:
            i = rows[int(s["sample_counter"])]
            assert s["status_word"] & STATUS_RUNNING
            assert np.float32(s["live_values.delta_l"]) == np.float32(dl[i])
            for k, name in ((4, "ecc_u"), (5, "ecc_v"), (6, "r0")):
                assert (s["live_valid"] >> k & 1) == (not math.isnan(s[f"live_values.{name}"])), s
            if abs(turned[i] - min_arc) > 0.1:
                assert bool(s["live_valid"] >> 4 & 1) == (turned[i] > min_arc), (turned[i], s)
        assert {bool(s["live_valid"] >> 4 & 1) for s in seen} == {False, True}
        # the live eccentricity = the fit of the samples so far (valid once the minimum arc is turned)
        last = max((s for s in seen if s["live_valid"] >> 4 & 1), key=lambda s: s["sample_counter"])
        i = rows[int(last["sample_counter"])]
        r = runs[0]
        ok = r.col("flags")[: i + 1] == 0
        part = limacon_fit(r.col("x_mm")[: i + 1][ok], r.col("y_mm")[: i + 1][ok], dl[: i + 1][ok])
        assert last["live_values.ecc_u"] == pytest.approx(part["e_u"], abs=2e-3)
        assert last["live_values.ecc_v"] == pytest.approx(part["e_v"], abs=2e-3)
        # NMT reset node resets the application: state IDLE, results invalid, configuration kept
        node.nmt.state = "RESET"
        node.nmt.wait_for_bootup(3)
        assert sdo["session_state"].raw == 0
        for name in ("ecc_u", "G_bidir", "H"):
            assert_invalid(sdo, name)
        assert sdo["circle_radius"].raw == truth["radius_mm"]
    finally:
        net.disconnect()
        stream.close()


def test_axis_reference_over_sdo(pod, eds):
    """0x300C: an axis's position is read back as written (REAL32, the EDS's names), in
    operational too; refused with the reason while a run runs; the EDS's limits hold."""
    net, node = connect(pod, eds)
    sdo = node.sdo
    try:
        configure_circle(sdo, pod["truth"]["machine"]["circle"])  # in pre-operational
        x = sdo["axis_position"]["axis_position_1"]
        start = x.raw
        node.nmt.state = "OPERATIONAL"
        x.raw = start + 10.0
        assert abs(x.raw - (start + 10.0)) < 1e-4  # the count nearest to the written mm
        assert abort_code(lambda: setattr(x, "raw", 10_000.5)) == ABORT_TOO_HIGH
        x.raw = start
        sdo["session_command"].raw = COMMAND["arm"]
        sdo["session_command"].raw = COMMAND["start"]
        assert abort_code(lambda: setattr(x, "raw", start)) == ABORT_DEVICE_STATE
        assert sdo["last_refusal"].raw == "not while a run is armed or running"
        sdo["session_command"].raw = COMMAND["abort"]
    finally:
        net.disconnect()
