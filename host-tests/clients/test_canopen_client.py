"""The `canopen` package (on python-can's slcan interface) as the CNC, against the simulated pod.

Every expectation comes from CiA 301 (abort codes, NMT states, frame layouts), the EDS, or the
simulator's truth — not from the pod's own output."""
import struct
import time

import can
import canopen
import pytest
from canopen.sdo.exceptions import SdoAbortedError


def connect(pod, eds):
    net = canopen.Network()
    net.connect(interface="slcan", channel=f"socket://127.0.0.1:{pod['can_port']}", bitrate=500000,
                sleep_after_open=0)
    node = net.add_node(pod["truth"]["node_id"], eds)
    node.sdo.RESPONSE_TIMEOUT = 2.0
    return net, node


def abort_code(fn):
    with pytest.raises(SdoAbortedError) as e:
        fn()
    return e.value.code


def test_identity_heartbeat_and_nmt(pod, eds):
    net, node = connect(pod, eds)
    try:
        node.nmt.wait_for_heartbeat(3)
        assert node.nmt.state == "PRE-OPERATIONAL"
        assert node.sdo["Identity object"]["Product code"].raw == 0xBA110001
        assert node.sdo["Identity object"]["Vendor-ID"].raw == 0
        name = node.sdo["Manufacturer device name"].raw  # segmented upload (> 4 bytes)
        assert "ballpod" in name.lower() and len(name) > 4
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


def test_configuration_expedited_and_segmented(pod, eds):
    net, node = connect(pod, eds)
    try:
        node.nmt.wait_for_heartbeat(3)
        node.sdo["bar_length"].raw = 150.012            # expedited REAL32
        assert node.sdo["bar_length"].raw == pytest.approx(150.012, abs=1e-4)
        node.sdo.download(0x2001, 0, struct.pack("<f", 0.5), force_segment=True)  # segmented
        assert node.sdo["bar_cte"].raw == pytest.approx(0.5, abs=1e-6)
        # value range (CiA 301: 0x06090031 too high, 0x06090032 too low), state unchanged
        assert abort_code(lambda: setattr(node.sdo["bar_length"], "raw", 10.0)) == 0x06090032
        assert abort_code(lambda: setattr(node.sdo["bar_length"], "raw", 9000.0)) == 0x06090031
        assert node.sdo["bar_length"].raw == pytest.approx(150.012, abs=1e-4)
        node.sdo["bar_length"].raw = 150.0
    finally:
        net.disconnect()


def test_every_abort_code(pod, eds):
    net, node = connect(pod, eds)
    try:
        node.nmt.wait_for_heartbeat(3)
        # no object / no sub-index
        assert abort_code(lambda: node.sdo.upload(0x5FFF, 0)) == 0x06020000
        assert abort_code(lambda: node.sdo.upload(0x1018, 9)) == 0x06090011
        # read-only / write-only
        assert abort_code(lambda: node.sdo.download(0x1018, 1, b"\x01\x00\x00\x00")) == 0x06010002
        assert abort_code(lambda: node.sdo.upload(0x3002, 0)) == 0x06010001
        # length mismatch: 2 bytes into a REAL32 (0x06070010 family: 0x06070010/0x06070013)
        assert abort_code(lambda: node.sdo.download(0x2000, 0, b"\x00\x00")) in (0x06070010, 0x06070013)
        # wrong state: configuration only in pre-operational
        node.nmt.state = "OPERATIONAL"
        time.sleep(0.05)
        assert abort_code(lambda: setattr(node.sdo["bar_length"], "raw", 151.0)) == 0x08000022
        node.nmt.state = "PRE-OPERATIONAL"
        time.sleep(0.05)
        assert node.sdo["bar_length"].raw == pytest.approx(150.0, abs=1e-4)
        # raw SDO frames: command specifier, toggle, timeout (client → 0x600+n, server → 0x580+n)
        n = pod["truth"]["node_id"]
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
        assert code(request([0x10, 1, 2, 3, 4, 5, 6, 7])) == 0x05030000  # first segment must have toggle 0
        init = request([0x21, 0x01, 0x20, 0x00, 4, 0, 0, 0])
        assert init is not None and init[0] == 0x60
        got.clear()  # ... and the client falls silent
        t0 = time.time()
        while not got and time.time() - t0 < 3.0:  # server-side SDO timeout (1 s)
            time.sleep(0.02)
        assert got and code(got[0]) == 0x05040000
        assert node.sdo["bar_cte"].raw == pytest.approx(11.5, abs=1e-4)
    finally:
        net.disconnect()


def test_measurement_tpdo_against_sdo_and_truth(pod, eds):
    net, node = connect(pod, eds)
    try:
        node.nmt.wait_for_heartbeat(3)
        node.tpdo.read()
        node.sdo["pattern"].raw = 0          # ISO 230-4 circle
        node.sdo["direction"].raw = 0        # CCW
        node.sdo["session_command"].raw = 1  # arm
        assert node.sdo["session_state"].raw == 1
        node.nmt.state = "OPERATIONAL"
        node.sdo["session_command"].raw = 2  # start
        assert node.sdo["session_state"].raw == 2
        counters = []
        t0 = time.time()
        while time.time() - t0 < 6.0:       # a full circle is ~57 s of virtual time (20× speed)
            net.sync.transmit()
            node.tpdo[1].wait_for_reception(1.0)
            dl = node.tpdo[1]["live_values.delta_l_um"].raw
            counters.append(node.tpdo[1]["sample_counter"].raw)
            sdo_dl = node.sdo["live_values"]["delta_l_um"].raw
            # the TPDO and a following SDO read see the same signal (it moves ≤ 1 µm in between)
            assert abs(dl - sdo_dl) < 2.0
            # truth: ΔL = |P + e| − R lies within ±|e| (+ noise) of zero
            e = (pod["truth"]["ecc_x_um"] ** 2 + pod["truth"]["ecc_y_um"] ** 2) ** 0.5
            assert abs(dl) < e + 1.0
            time.sleep(0.05)
        assert counters == sorted(counters) and counters[-1] > counters[0]
        node.sdo["session_command"].raw = 3  # stop
        assert node.sdo["session_state"].raw == 3
        ex = node.sdo["result_value"]["ecc_x"].raw
        ey = node.sdo["result_value"]["ecc_y"].raw
        ux = node.sdo["result_uncertainty"]["ecc_x"].raw
        assert ex == pytest.approx(pod["truth"]["ecc_x_um"], abs=max(0.1, 5 * ux))
        assert ey == pytest.approx(pod["truth"]["ecc_y_um"], abs=max(0.1, 5 * ux))
        # the live TPDO2 eccentricities agree with the results
        net.sync.transmit()
        node.tpdo[2].wait_for_reception(1.0)
        assert node.tpdo[2]["live_values.ecc_x_um"].raw == pytest.approx(ex, abs=0.05)
    finally:
        net.disconnect()
