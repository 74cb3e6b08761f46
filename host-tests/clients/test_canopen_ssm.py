"""An SSM (single socket method) run over CANopen: the live position error E arrives by TPDO on
SYNC with its validity bit, and is checked against the served machine's truth (truth.ssm_error_um)
within the uncertainty a numpy least-squares fit of the streamed samples of the pod's
neighbourhood gives it; the run's station result against the truth within its stated
uncertainty."""
import math

import numpy as np

from podlib import (COMMAND, PATTERN, STATUS_RUNNING, StreamCapture, assert_invalid, connect, result,
                    tpdo_snapshots, wait_until)

# The pod's streaming neighbourhood holds at most this many samples (src/app/ssm.rs SSM_WINDOW);
# samples farther than ssm_window_radius from the current point leave it, oldest first.
WINDOW = 256
# A direction counts as unobservable below this eigenvalue ratio of UᵀU (src/metrology/ssm):
# for numpy's lstsq, singular values below √ of it × the largest.
EIG_RATIO = 1e-9


def window_starts(points, radius_mm):
    """For each sample i, the first sample of the neighbourhood that ends at i: as each sample
    enters, the oldest leave while they lie beyond the radius from it, then one more if full."""
    starts, a = [], 0
    for i, p in enumerate(points):
        while a < i and np.sum((p - points[a]) ** 2) > radius_mm ** 2:
            a += 1
        a = max(a, i - WINDOW + 1)
        starts.append(a)
    return starts


def test_ssm_live_error_by_tpdo_against_truth(pod, eds):
    truth = pod["truth"]
    e_true = truth["ssm_error_um"]
    noise = truth["machine"]["instrument"]["bar_noise_um"]
    stream = StreamCapture(pod["stream_port"])
    net, node = connect(pod, eds)
    sdo = node.sdo
    try:
        for k in ("ssm_ex", "ssm_ey", "ssm_ez"):
            assert_invalid(sdo, k)
        for k in "xyz":
            sdo[f"ssm_socket_{k}"].raw = 0.0
        # TPDO4 (E_x, E_y) is disabled by default: enable it (CiA 301 §7.5.2.35 procedure)
        node.tpdo.read()
        node.tpdo[4].enabled = True
        node.tpdo[4].save()
        assert [v.name for v in node.tpdo[4].map] == ["live_values.ssm_ex", "live_values.ssm_ey"]
        snaps = tpdo_snapshots(node, (3, 4))
        sdo["pattern"].raw = PATTERN["SSM"]
        sdo["session_command"].raw = COMMAND["arm"]
        node.nmt.state = "OPERATIONAL"
        net.sync.start(0.01)
        sdo["session_command"].raw = COMMAND["start"]
        wait_until(lambda: sdo["session_state"].raw != 2, 30, "the SSM run's end")
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
        points = np.column_stack([r.col(c) for c in ("x_mm", "y_mm", "z_mm")])
        socket = np.array([float(r.meta[f"ssm_socket_{k}"]) for k in "xyz"])
        bar_mm, radius = float(r.meta["bar_length"]), float(r.meta["ssm_window_radius"])
        starts = window_starts(points, radius)
        frames = [s for s in snaps if int(s["sample_counter"]) in seqs and "live_values.ssm_ey" in s]
        assert len(frames) >= 20, len(snaps)
        checked = 0
        for s in frames:
            assert s["status_word"] & STATUS_RUNNING
            for bit, name in ((1, "ssm_ex"), (2, "ssm_ey")):
                value = s[f"live_values.{name}"]
                # the validity bit and the value agree: invalid is NaN, never a number
                assert (s["live_valid"] >> bit & 1) == (not math.isnan(value)), s
                if math.isnan(value):
                    continue
                # numpy: u·E = y over the neighbourhood's samples, u the unit vector socket → ball,
                # y = ΔL + L − |P − socket| (seed 000 eq 1)
                i = seqs[int(s["sample_counter"])]
                a = starts[i]
                d = points[a: i + 1] - socket
                rho = np.linalg.norm(d, axis=1)
                uu = d / rho[:, None]
                y = r.col("dl_um")[a: i + 1] + (bar_mm - rho) * 1e3
                e, *_ = np.linalg.lstsq(uu, y, rcond=math.sqrt(EIG_RATIO))
                sigma = max(noise, float(np.sqrt(np.mean((y - uu @ e) ** 2))))
                u = sigma * math.sqrt(np.linalg.pinv(uu.T @ uu, rcond=EIG_RATIO)[bit - 1, bit - 1])
                # the pod's estimate is the fit of these samples (its f32 positions and ΔL
                # limit it to a few 10 nm × the condition number: 0.1 u here)
                assert abs(value - e[bit - 1]) <= 0.1 * u + 0.02, (name, value, e, u)
                # k = 4: dozens of frames, each a new draw
                assert abs(value - e_true[bit - 1]) <= 4 * u, (name, value, e_true, u)
                checked += 1
        assert checked >= 3, f"{checked} valid live E components in {len(frames)} frames"
    finally:
        net.disconnect()
        stream.close()
