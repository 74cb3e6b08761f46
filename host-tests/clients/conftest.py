"""Starts the simulated pod (`sim --serve`) for each client test and hands its JSON line to it.
The binary is taken from $BALLPOD_SIM (set by .ci/run), else built with cargo.

`pod` is that JSON line: can_port, usb_port, stream_port, node_id and truth (the served machine:
truth.machine.circle / .seed002 / .instrument, truth.ssm_error_um, truth.sphere_rc_zc_mm).
`@pytest.mark.sim_args("--speed", "40")` passes options to that test's pod."""
import json
import os
import pathlib
import signal
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def host_binary(name):
    """The release host binary `name` (sim, replay): from $BALLPOD_SIM's folder, else built."""
    env = os.environ.get("BALLPOD_SIM")
    if env:
        return str(pathlib.Path(env).with_name(name))
    host = subprocess.run(["rustc", "-vV"], capture_output=True, text=True, check=True).stdout
    triple = next(l.split(": ")[1] for l in host.splitlines() if l.startswith("host: "))
    subprocess.run(["cargo", "build", "--manifest-path", "host-tests/Cargo.toml", "--target", "host-tuple",
                    "--release", "--bin", name], cwd=ROOT, check=True)
    return str(ROOT / "host-tests" / "target" / triple / "release" / name)


def pytest_configure(config):
    config.addinivalue_line("markers", "sim_args(*args): extra options of that test's `sim --serve`")
    config.addinivalue_line("markers", "needs_motion: the test runs a pattern on the served machine")
    config.addinivalue_line("markers", "sim_only: a behaviour of sim --serve's TCP server itself")


EMU_ELF = ROOT / "host-tests/emu-board/target/thumbv7em-none-eabihf/release/ballpod-emu"


def emulated():
    """True when the tests run against the emulated firmware ($BALLPOD_POD=emu: `emu --serve`,
    the firmware on QEMU's mps2-an386) instead of the simulated pod."""
    return os.environ.get("BALLPOD_POD") == "emu"


@pytest.fixture()
def pod(request):
    """A fresh pod per test (killed after it): its JSON line as a dict. The simulated pod
    (`sim --serve`), or with $BALLPOD_POD=emu the firmware on the emulated board (`emu --serve`;
    a test marked `needs_motion` is skipped there: its machine stands still)."""
    marker = request.node.get_closest_marker("sim_args")
    extra = list(marker.args) if marker else []
    if emulated():
        if request.node.get_closest_marker("needs_motion"):
            pytest.skip("the emulated board's machine stands still (no virtual CNC yet)")
        if request.node.get_closest_marker("sim_only"):
            pytest.skip("a behaviour of sim --serve's own TCP server (QEMU serves the emulated ports)")
        cmd = [host_binary("emu"), "--serve", "--max-seconds", "150", "--elf", str(EMU_ELF)]
    else:
        cmd = [host_binary("sim"), "--serve", "--max-seconds", "150", *extra]
    # its own process group: killing it kills the emulator the harness started too
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True, start_new_session=True)
    try:
        info = json.loads(proc.stdout.readline())
        assert {"can_port", "usb_port", "stream_port", "node_id"} <= info.keys(), info
        assert emulated() or "truth" in info, info
        yield info
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)


@pytest.fixture()
def eds():
    return str(ROOT / "ballpod.eds")
