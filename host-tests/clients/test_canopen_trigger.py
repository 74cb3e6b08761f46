"""Runs that start and stop themselves (run_trigger FEED_IN), with the `canopen` package as the CNC
and pyserial as the technician: the served CNC runs its circle part program (feed-in, data arc,
overshoot, feed-out) as soon as the pod is armed for a FEED_IN run, and only the pod decides when
the run starts and ends. The run's samples (the pod's stream) are exactly the data arc — none of
the feed-in or feed-out, the overshoot cut at circle_arc — and its eccentricity is the truth's
socket offset turned round. A program without a feed-in (the machine file's feed_in_mm = 0)
never starts the run: the pod stays armed and says why in 0x3007 and SESS:NOTE?."""
import math
import pathlib
import time

import numpy as np
import pytest
import serial

from podlib import (COMMAND, DIRECTION, PATTERN, StreamCapture, configure_circle, connect, fit_run,
                    result, wait_until, RUN_TIMEOUT, STATUS_RESULTS_READY)

ARC_DEG = 360.0
NO_FEED_IN = str(pathlib.Path(__file__).with_name("machine_no_feed_in.toml"))


def arm_feed_in(sdo, truth):
    configure_circle(sdo, truth)
    sdo["circle_arc"].raw = ARC_DEG
    sdo["run_trigger"].raw = 1  # FEED_IN
    sdo["pattern"].raw = PATTERN["CIRCLE"]
    sdo["direction"].raw = DIRECTION["CCW"]
    sdo["session_command"].raw = COMMAND["arm"]
    # ARMED, or already RUNNING: the served CNC's program starts with the arm (the feed-in takes
    # a few milliseconds at the served speed)
    assert sdo["session_state"].raw in (1, 2)


@pytest.mark.sim_args("--speed", "40")
def test_a_feed_in_run_starts_and_stops_itself_on_the_data_arc(pod, eds):
    truth = pod["truth"]["machine"]["circle"]
    r_mm = truth["radius_mm"]
    stream = StreamCapture(pod["stream_port"])
    net, node = connect(pod, eds)
    sdo = node.sdo
    try:
        arm_feed_in(sdo, truth)
        # no START: the pod starts the run at the data arc and ends it after circle_arc
        wait_until(lambda: sdo["session_state"].raw == 3, RUN_TIMEOUT, "the self-triggered run's end")
        (run,) = stream.runs(1)
        assert (run.meta["pattern"], run.meta["direction"], run.end["end"]) == ("CIRCLE", "CCW", "DONE")
        x, y = run.col("x_mm"), run.col("y_mm")
        radius = np.hypot(x, y)
        # every sample on the circle: the feed-in and feed-out (1 mm) stay out
        assert np.max(np.abs(radius - r_mm)) < 0.005, np.max(np.abs(radius - r_mm))
        # the run starts at the feed-in's end (0°) and sweeps circle_arc, the overshoot cut
        theta = np.unwrap(np.arctan2(y, x))
        assert math.degrees(theta[0]) == pytest.approx(0.0, abs=0.05)
        span = math.degrees(theta[-1] - theta[0])
        assert ARC_DEG <= span <= ARC_DEG + 0.05, span
        # the run's results come from its job: once RESULTS_READY is set
        wait_until(lambda: sdo["status_word"].raw & STATUS_RESULTS_READY, 30, "the run's results")
        ecc_u, ecc_v = result(sdo, "ecc_u"), result(sdo, "ecc_v")
        f = fit_run(run)
        assert ecc_u[0] == pytest.approx(f["e_u"], abs=2e-3) and ecc_v[0] == pytest.approx(f["e_v"], abs=2e-3)
        # ΔL = |P − S| − R with the socket off by s: e = −s within 3u
        s = truth["socket_offset_um"]
        assert abs(ecc_u[0] + s[0]) <= 3 * ecc_u[1] + 0.05 and abs(ecc_v[0] + s[1]) <= 3 * ecc_v[1] + 0.05
        assert result(sdo, "arc")[0] == pytest.approx(span, abs=0.01)
    finally:
        net.disconnect()


@pytest.mark.sim_args("--speed", "40", "--machine", NO_FEED_IN)
@pytest.mark.emu_args("--machine", NO_FEED_IN)
def test_a_program_without_a_feed_in_never_starts_and_the_pod_says_why(pod, eds):
    truth = pod["truth"]["machine"]["circle"]
    assert truth["feed_in_mm"] == 0.0
    net, node = connect(pod, eds)
    sdo = node.sdo
    try:
        arm_feed_in(sdo, truth)
        # the served program runs its whole data arc and overshoot on the circle (~1.6 s at
        # 40 times real time); the run never starts
        for _ in range(30):
            assert sdo["session_state"].raw == 1  # still ARMED
            time.sleep(0.1)
        why = "FEED_IN: waiting for the feed-in"
        assert sdo["procedure_note"].raw == why
        usb = serial.serial_for_url(f"socket://127.0.0.1:{pod['usb_port']}", timeout=2)
        try:
            usb.write(b"SESS:NOTE?\n")
            assert usb.readline().decode().strip() == f'"{why}"'
            usb.write(b"SESS:STAT?\n")
            assert usb.readline().decode().strip() == "ARMED"
        finally:
            usb.close()
        sdo["session_command"].raw = COMMAND["abort"]
        assert sdo["session_state"].raw == 4
    finally:
        net.disconnect()
