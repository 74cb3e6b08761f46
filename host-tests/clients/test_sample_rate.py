"""The highest sample rate the configuration accepts, on the emulated firmware: the board boots
with sample_rate = 10 000 Hz and excitation = 20 000 Hz (two excitation periods a sample: the
most ADC codes a sample at that rate) stored in its settings (`emu --set`), and python `canopen`
runs an ISO 230-4 CIRCLE pair while the sample stream is read. What must hold — the CPU busy at
most half of any 100 ms while a run runs, no sample period lost or dropped, heartbeats and SDO
answers on time — is conftest's check of the board's figures; this test checks that the runs
were measured at 10 kHz and that the results equal a numpy fit of the streamed samples.

`sim --serve` has no stored settings to boot with; against it the test is skipped."""
import numpy as np
import pytest

from conftest import emulated
from podlib import ABORT_TOO_HIGH, StreamCapture, abort_code, configure_circle, connect, fit_run, result, run

RATE_HZ, EXCITATION_HZ = 10_000.0, 20_000.0


@pytest.mark.emu_args("--set", f"sample_rate={RATE_HZ:.0f}", "--set", f"excitation={EXCITATION_HZ:.0f}")
def test_a_circle_pair_at_the_highest_sample_rate_with_the_stream_read(pod, eds):
    if not emulated():
        pytest.skip("the emulated board's stored settings (emu --set); sim --serve boots on the defaults")
    # (a faster circle than the truth's: 6.3 s a direction, 63 000 samples, 2.8 MB of stream)
    circle = {**pod["truth"]["machine"]["circle"], "feed_mm_per_min": 6000.0}
    stream = StreamCapture(pod["stream_port"])
    net, node = connect(pod, eds)
    sdo = node.sdo
    try:
        # the highest sample rate the configuration accepts: one more hertz is refused
        assert sdo["sample_rate"].raw == RATE_HZ and sdo["excitation"].raw == EXCITATION_HZ
        assert abort_code(lambda: setattr(sdo["sample_rate"], "raw", RATE_HZ + 1)) == ABORT_TOO_HIGH
        configure_circle(sdo, circle)
        assert run(sdo, "CIRCLE", "CCW") == 3
        ccw = {n: result(sdo, n) for n in ("ecc_u", "ecc_v", "r0")}
        assert run(sdo, "CIRCLE", "CW") == 3
        cw = {n: result(sdo, n) for n in ("ecc_u", "ecc_v", "r0")}
        g = result(sdo, "G_bidir")
        runs = stream.runs(2, timeout=30.0)
        for r, p in zip(runs, (ccw, cw)):
            assert int(r.end["stream_dropped"]) == 0
            t = r.col("t_s")
            # every sample 100 µs after the last: the run was measured at 10 kHz, none lost
            assert np.all(np.round(np.diff(t) * 1e6) == 1e6 / RATE_HZ), np.unique(np.round(np.diff(t) * 1e6))
            f = fit_run(r)
            assert int(r.end["used"]) == len(f["dl"]) > 50_000
            for name, key in (("ecc_u", "e_u"), ("ecc_v", "e_v"), ("r0", "r0")):
                assert p[name][0] == pytest.approx(f[key], abs=2e-3), name
        assert np.isfinite(g[0]) and g[1] > 0.0
    finally:
        net.disconnect()
        stream.close()
