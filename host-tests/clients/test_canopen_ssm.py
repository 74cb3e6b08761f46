"""An SSM (single socket method) run over CANopen: the live position error E and its standard
uncertainty arrive by TPDO on SYNC with their validity bits. E is checked against a numpy
least-squares fit of the streamed samples of the pod's neighbourhood, its u against that fit's
(the residual's Type A, the bar's and the socket's shares from the configuration the pod
reports), and E
against the served machine's truth (truth.ssm_error_um) within the pod's u; the run's station
result against the truth within its stated uncertainty."""
import math

import numpy as np
import pytest

from podlib import (ABORT_TOO_LOW, COMMAND, PATTERN, STATUS_RUNNING, StreamCapture, abort_code,
                    assert_invalid, arm_then_start, connect, result, tpdo_snapshots, wait_until,
                    RUN_TIMEOUT)

# The pod's streaming neighbourhood holds at most this many samples (src/app/ssm.rs SSM_WINDOW);
# samples farther than ssm_window_radius from the current point leave it, oldest first.
WINDOW = 256
# A direction counts as unobservable below this eigenvalue ratio of UᵀU (src/metrology/ssm):
# for numpy's lstsq, singular values below √ of it × the largest.
EIG_RATIO = 1e-9
# The live E's u is refreshed at every sample whose counter is a multiple of this
# (src/app/live.rs LIVE_U_EVERY), and of the second while the window grows (src/app/ssm.rs
# LIVE_U_EVERY_GROWING), from at least this many residual degrees of freedom
# (src/metrology/ssm/streaming.rs LIVE_MIN_DOF), with this floor on the scatter (q/√12 of the
# 0.1 µm resolution, LIVE_SIGMA_FLOOR_UM).
LIVE_U_EVERY, LIVE_U_EVERY_GROWING, LIVE_MIN_DOF, SIGMA_FLOOR_UM = 32, 4, 30, 0.1 / math.sqrt(12)
# Rotary speed below which the dwell detection counts a rotary axis still, °/s
# (src/app/ssm.rs DWELL_ROTARY_SPEED_DEG_PER_S).
DWELL_ROTARY_SPEED = 0.1


def windows(r, radius_mm, dwell_speed_mm_per_s):
    """For each sample, the indices of the samples of the pod's live window at it, and whether
    the pod counts the window as growing there (src/metrology/ssm/streaming.rs `is_growing`:
    the ring's oldest index at the window's first, i.e. a multiple of WINDOW samples left since
    the window started, none while it grows; a window every sample has left starts anew). As
    each sample
    enters, the oldest leave while they lie beyond the radius from it, then one more if full; a
    still sample empties the window and does not enter it (src/app/ssm.rs SsmRun::update): the
    window restarts with the next move. Still, as the pod's dwell detection has it: later than
    the sample before, within the dwell speed of it and each rotary axis within
    DWELL_ROTARY_SPEED of it. The rotary axes stand still in this run (asserted), so the
    window's emptying at a rotary move does not arise."""
    points = np.column_stack([r.col(c) for c in ("x_mm", "y_mm", "z_mm")])
    rotary = np.column_stack([r.col(c) for c in r.cols if c.endswith("_deg")])
    assert np.all(rotary == rotary[0])
    t_s = r.col("t_s")
    starts, grows, a, first = [], [], 0, 0
    for i, p in enumerate(points):
        dt = t_s[i] - t_s[i - 1] if i > 0 else 0.0
        if dt > 0 and np.sum((p - points[i - 1]) ** 2) <= (dwell_speed_mm_per_s * dt) ** 2 \
                and np.all(np.abs(rotary[i] - rotary[i - 1]) <= DWELL_ROTARY_SPEED * dt):
            a = first = i + 1
            starts.append(a)
            grows.append(True)
            continue
        while a < i and np.sum((p - points[a]) ** 2) > radius_mm ** 2:
            a += 1
        a = max(a, i - WINDOW + 1)
        if a == i:
            first = i
        starts.append(a)
        grows.append((a - first) % WINDOW == 0)
    return (lambda i: np.arange(starts[i], i + 1)), grows


def neighbourhood_fit(r, window, i, socket, bar_mm):
    """numpy's least squares u·E = y over the pod's window at sample i (`window`, see
    `windows`; u the unit vector socket → ball, y = ΔL + L − |P − socket|, seed 000 eq 1): E,
    the Type A covariance σ̂² (UᵀU)⁺ with σ̂² = RSS/(n − rank), E's response to y ≡ 1, and
    n − rank."""
    idx = window(i)
    if len(idx) < 3:
        # an emptied window (the machine still): nothing to fit
        return np.full(3, np.nan), np.full((3, 3), np.nan), np.full(3, np.nan), 0
    points = np.column_stack([r.col(c) for c in ("x_mm", "y_mm", "z_mm")])[idx]
    d = points - socket
    rho = np.linalg.norm(d, axis=1)
    uu = d / rho[:, None]
    y = r.col("dl_um")[idx] + (bar_mm - rho) * 1e3
    e, _, rank, _ = np.linalg.lstsq(uu, y, rcond=math.sqrt(EIG_RATIO))
    dof = len(y) - rank
    sigma2 = max(SIGMA_FLOOR_UM ** 2, float(np.sum((y - uu @ e) ** 2)) / max(dof, 1))
    cov = sigma2 * np.linalg.pinv(uu.T @ uu, rcond=EIG_RATIO)
    offset, *_ = np.linalg.lstsq(uu, np.ones(len(y)), rcond=math.sqrt(EIG_RATIO))
    return e, cov, offset, dof


def test_ssm_live_error_by_tpdo_against_truth(pod, eds):
    truth = pod["truth"]
    e_true = truth["ssm_error_um"]
    stream = StreamCapture(pod["stream_port"])
    net, node = connect(pod, eds)
    sdo = node.sdo
    try:
        for k in ("ssm_ex", "ssm_ey", "ssm_ez"):
            assert_invalid(sdo, k)
        for k in "xyz":
            sdo[f"ssm_socket_{k}"].raw = 0.0
        # the bar's inputs to u: the offset's (length, and temperature through the CTE) and the
        # LVDT scale's, as the pod's configuration states them
        bar_mm = sdo["bar_length"].raw
        thermal_um = bar_mm * sdo["bar_cte"].raw * sdo["bar_u_temp"].raw * 1e-3
        u_offset = math.hypot(sdo["bar_u_length"].raw, thermal_um)
        u_scale = sdo["lvdt_u_scale"].raw * 1e-6
        # and the socket's as entered, one to one in each component (per coordinate, µm; the
        # served machine's socket is where it is entered: a small u, so that the fit's Type A
        # still shows in the comparison below)
        assert sdo["ssm_u_socket"].index == 0x2045
        assert sdo["ssm_u_socket"].raw == pytest.approx(1.0)
        assert abort_code(lambda: setattr(sdo["ssm_u_socket"], "raw", -1.0)) == ABORT_TOO_LOW
        sdo["ssm_u_socket"].raw = 0.3
        u_socket = sdo["ssm_u_socket"].raw
        assert u_socket == pytest.approx(0.3)
        # TPDO4 (E_x, E_y) is disabled by default: enable it (CiA 301 §7.5.2.35 procedure); map
        # their u onto TPDO2 (e_u, e_v by default, invalid in an SSM run)
        node.tpdo.read()
        node.tpdo[4].enabled = True
        node.tpdo[4].save()
        assert [v.name for v in node.tpdo[4].map] == ["live_values.ssm_ex", "live_values.ssm_ey"]
        node.tpdo[2].clear()
        node.tpdo[2].add_variable("live_values", "u_ssm_ex")
        node.tpdo[2].add_variable("live_values", "u_ssm_ey")
        node.tpdo[2].enabled = True
        node.tpdo[2].save()
        snaps = tpdo_snapshots(node, (2, 3, 4))
        sdo["pattern"].raw = PATTERN["SSM"]

        def arm():
            sdo["session_command"].raw = COMMAND["arm"]
            node.nmt.state = "OPERATIONAL"
            net.sync.start(0.01)

        arm_then_start(arm, lambda: setattr(sdo["session_command"], "raw", COMMAND["start"]))
        wait_until(lambda: sdo["session_state"].raw != 2, RUN_TIMEOUT, "the SSM run's end")
        net.sync.stop()
        assert sdo["session_state"].raw == 3
        # the stations' E: truth within 3 u
        for k, name in enumerate(("ssm_ex", "ssm_ey", "ssm_ez")):
            v, u = result(sdo, name)
            assert abs(v - e_true[k]) <= 3 * u, (name, v, u, e_true[k])
        (r,) = stream.runs(1)
        assert r.meta["pattern"] == "SSM" and int(r.end["stream_dropped"]) == 0
        seqs = {int(s): i for i, s in enumerate(r.col("seq"))}
        assert np.all(r.col("flags") == 0)
        socket = np.array([float(r.meta[f"ssm_socket_{k}"]) for k in "xyz"])
        assert float(r.meta["bar_length"]) == bar_mm
        window, grows = windows(r, float(r.meta["ssm_window_radius"]),
                                float(r.meta["ssm_dwell_speed"]))
        frames = [s for s in snaps if int(s["sample_counter"]) in seqs and "live_values.ssm_ey" in s]
        assert len(frames) >= 20, len(snaps)
        checked = checked_u = 0
        for s in frames:
            assert s["status_word"] & STATUS_RUNNING
            counter = int(s["sample_counter"])
            for bit, name in ((1, "ssm_ex"), (2, "ssm_ey")):
                value, u = s[f"live_values.{name}"], s[f"live_values.u_{name}"]
                # the validity bits and the values agree: invalid is NaN, never a number
                assert (s["live_valid"] >> bit & 1) == (not math.isnan(value)), s
                assert (s["live_valid"] >> (bit + 7) & 1) == (not math.isnan(u)), s
                if math.isnan(value):
                    assert math.isnan(u), s
                    continue
                e, cov, offset, dof = neighbourhood_fit(r, window, seqs[counter], socket, bar_mm)
                u_a = math.sqrt(cov[bit - 1, bit - 1])
                # the pod's estimate is the fit of these samples (its f32 positions and ΔL
                # limit it to a few 10 nm × the condition number: 0.1 u here)
                assert abs(value - e[bit - 1]) <= 0.1 * u_a + 0.02, (name, value, e, u_a)
                # and the truth is within 4 u of this neighbourhood (dozens of frames, each a
                # new draw; the coverage itself is metrology_ssm.rs's, on the served path):
                # Type A and the bar's shares, offset through the fit of y ≡ 1, scale |E|·u_k;
                # and the socket's
                u_now = math.hypot(u_a, offset[bit - 1] * u_offset, value * u_scale, u_socket)
                assert abs(value - e_true[bit - 1]) <= 4 * u_now, (name, value, e_true, u_now)
                checked += 1
                # the pod's u is the same as of the last refresh: the latest sample whose
                # counter is a multiple of LIVE_U_EVERY, or of LIVE_U_EVERY_GROWING with the
                # window growing
                refreshed = next((c for c in range(counter - counter % LIVE_U_EVERY_GROWING,
                                                   counter - counter % LIVE_U_EVERY - 1,
                                                   -LIVE_U_EVERY_GROWING)
                                  if c % LIVE_U_EVERY == 0 or (c in seqs and grows[seqs[c]])),
                                 None)
                if refreshed not in seqs:
                    continue
                e0, cov0, offset0, dof0 = neighbourhood_fit(r, window, seqs[refreshed], socket,
                                                            bar_mm)
                if dof0 < LIVE_MIN_DOF:
                    assert math.isnan(u), (name, dof0, u)
                    continue
                if math.isnan(u):
                    # E was not valid at some sample since the refresh (the frames do not show
                    # every sample): no u until the next
                    continue
                want = math.hypot(math.sqrt(cov0[bit - 1, bit - 1]), offset0[bit - 1] * u_offset,
                                  e0[bit - 1] * u_scale, u_socket)
                assert u == pytest.approx(want, rel=0.02), (name, counter, u, want)
                checked_u += 1
        assert checked >= 3 and checked_u >= 3, \
            f"{checked} valid live E components, {checked_u} with u, in {len(frames)} frames"
    finally:
        net.disconnect()
        stream.close()
