"""What real clients do to `sim --serve`, and the pod going on serving (issue 16): the protocols'
timers in real time while the machine runs fast, a USB client that never reads, a second client
on a taken port, and bytes on the CAN port that are not SLCAN. The CNC side is python `canopen`
(heartbeats through its network's subscription, SDO round trips timed around its upload)."""
import re
import socket
import statistics
import time

import pytest

from podlib import COMMAND, PATTERN, configure_circle, connect, wait_until

HEARTBEAT_S = 1.0  # 0x1017 default (reference: CANopen objects)


def start_circle(sdo):
    sdo["pattern"].raw = PATTERN["CIRCLE"]
    sdo["session_command"].raw = COMMAND["arm"]
    sdo["session_command"].raw = COMMAND["start"]
    assert sdo["session_state"].raw == 2  # RUNNING


@pytest.mark.sim_args("--speed", "40")
@pytest.mark.sim_only
def test_heartbeats_keep_real_time_while_a_run_runs_fast(pod, eds):
    net, node = connect(pod, eds)
    sdo = node.sdo
    beats = []
    net.subscribe(0x700 + pod["node_id"], lambda can_id, data, ts: beats.append(time.monotonic()))
    try:
        # the truth's 150 mm circle at F300: 188 s of machine time, under 5 s of real time at
        # speed 40
        configure_circle(sdo, {**pod["truth"]["machine"]["circle"], "feed_mm_per_min": 300.0})
        start_circle(sdo)
        t0 = time.monotonic()
        del beats[:]
        time.sleep(3.5)
        assert sdo["session_state"].raw == 2, "the run still runs"
        gaps = [b - a for a, b in zip(beats, beats[1:])]
        assert len(gaps) >= 2, beats
        # at the machine's speed the heartbeat would come every 25 ms
        assert all(abs(g - HEARTBEAT_S) < 0.2 for g in gaps), gaps
        assert time.monotonic() - t0 < 5.0
        sdo["session_command"].raw = COMMAND["abort"]
    finally:
        net.disconnect()


@pytest.mark.sim_args("--speed", "40")
def test_a_usb_client_that_never_reads_holds_up_nothing(pod, eds):
    net, node = connect(pod, eds)
    sdo = node.sdo
    try:
        # a run, so that the log holds something to download
        configure_circle(sdo, {**pod["truth"]["machine"]["circle"], "feed_mm_per_min": 6000.0})
        start_circle(sdo)
        wait_until(lambda: sdo["session_state"].raw != 2, 20, "the circle's end")

        def round_trips():
            """30 SDO reads at 10 Hz, as a CNC goes on reading: each one's round trip, s."""
            times = []
            for _ in range(30):
                t = time.monotonic()
                assert sdo["session_state"].raw == 3  # DONE
                times.append(time.monotonic() - t)
                time.sleep(0.1)
            return times

        # the round trip through python-can and the SLCAN socket with nobody else on the pod:
        # medians of 1.5 ms (sim --serve) and 2.4 ms (the emulated board) on the development
        # machine (2026-12-02); a loaded two-core CI runner is slower (10.7 ms to the emulated
        # board that day, which a fixed bound of 10 ms failed)
        alone = round_trips()
        # a technician asks for the log and never reads (a small receive window)
        usb = socket.socket()
        usb.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        usb.connect(("127.0.0.1", pod["usb_port"]))
        usb.sendall(b"DATA:LOG?\n")
        time.sleep(0.5)
        held = round_trips()
        # A server held up by the unread download would answer none of them for the whole
        # download. The median says "at once" (as with nobody on the USB port, with 2 ms for
        # the scheduler), the slowest "never held up": a stall of the host on a loaded runner
        # holds one round trip or two, not the download's
        med_alone, med_held = statistics.median(alone), statistics.median(held)
        assert med_held < 1.5 * med_alone + 0.002, f"median {med_held} (alone {med_alone}), {held}"
        assert sorted(held)[-3] < 0.100, held
        usb.close()
    finally:
        net.disconnect()


@pytest.mark.sim_only
def test_a_second_client_is_refused_and_the_first_keeps_its_port(pod):
    first = socket.create_connection(("127.0.0.1", pod["usb_port"]))
    first.settimeout(5)
    first.sendall(b"*IDN?\n")
    assert b"ballpod" in first.recv(256).lower()
    second = socket.create_connection(("127.0.0.1", pod["usb_port"]))
    second.settimeout(5)
    said = b""
    while chunk := second.recv(256):
        said += chunk
    assert said == b"port in use by another client\n"
    first.sendall(b"*IDN?\n")
    assert b"ballpod" in first.recv(256).lower()
    first.close()
    # the port is free again
    third = socket.create_connection(("127.0.0.1", pod["usb_port"]))
    third.settimeout(5)
    time.sleep(0.1)
    third.sendall(b"*IDN?\n")
    assert b"ballpod" in third.recv(256).lower()
    third.close()


def test_bytes_that_are_not_slcan_get_bel_and_the_pod_goes_on(pod):
    can = socket.create_connection(("127.0.0.1", pod["can_port"]))
    can.settimeout(5)

    def ask(line):
        """The adapter's answer to `line` (CR or BEL), the pod's frames (heartbeats) left out."""
        can.sendall(line)
        got = b""
        while (answer := re.sub(rb"t[0-9A-F]{4,20}\r", b"", got)) not in (b"\r", b"\x07"):
            assert len(got) < 4096, got
            got += can.recv(64)
        return answer

    assert ask(b"O\r") == b"\r"
    # issue 16's crash: a non-ASCII byte among the data digits
    assert ask(b"t6102A\xe9B\r") == b"\x07"
    assert ask(b"\xff\xfe\r") == b"\x07"
    assert ask(b"t" + b"7" * 5000 + b"\r") == b"\x07"
    # a CANopen SDO upload of 0x1000:0 (device type) still answered, among heartbeat lines
    node = pod["node_id"]
    can.sendall(f"t{0x600 + node:03X}84000100000000000\r".encode())
    answer = f"t{0x580 + node:03X}8".encode()
    got = b""
    deadline = time.monotonic() + 3
    while answer not in got and time.monotonic() < deadline:
        got += can.recv(256)
    assert answer in got, got
    can.close()
