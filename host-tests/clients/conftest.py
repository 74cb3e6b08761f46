"""Starts the simulated pod (`sim --serve`) for each client test and hands its JSON line to it.
The binary is taken from $BALLPOD_SIM (set by .ci/run), else built with cargo.

`pod` is that JSON line: can_port, usb_port, stream_port, node_id and truth (the served machine:
truth.machine.circle / .seed002 / .instrument, truth.ssm_error_um, truth.sphere_rc_zc_mm).
`@pytest.mark.sim_args("--speed", "40")` passes options to that test's pod."""
import json
import os
import pathlib
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


@pytest.fixture()
def pod(request):
    """A fresh simulated pod per test (killed after it): its JSON line as a dict."""
    marker = request.node.get_closest_marker("sim_args")
    extra = list(marker.args) if marker else []
    proc = subprocess.Popen([host_binary("sim"), "--serve", "--max-seconds", "150", *extra],
                            stdout=subprocess.PIPE, text=True)
    try:
        info = json.loads(proc.stdout.readline())
        assert {"can_port", "usb_port", "stream_port", "node_id", "truth"} <= info.keys(), info
        yield info
    finally:
        proc.kill()
        proc.wait(timeout=10)


@pytest.fixture()
def eds():
    return str(ROOT / "ballpod.eds")
