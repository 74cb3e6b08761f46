"""Starts the simulated pod (`sim --serve`) for the client tests and hands its ports and truth
to them. The binary is taken from $BALLPOD_SIM (set by .ci/run), else built with cargo."""
import json
import os
import subprocess
import pathlib

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


def sim_binary():
    return host_binary("sim")


@pytest.fixture()
def pod():
    """A fresh simulated pod per test: dict with can_port, usb_port, truth."""
    proc = subprocess.Popen([sim_binary(), "--serve", "--max-seconds", "120"], stdout=subprocess.PIPE,
                            text=True)
    try:
        line = proc.stdout.readline()
        info = json.loads(line)
        yield info
    finally:
        proc.kill()
        proc.wait(timeout=10)


@pytest.fixture()
def eds():
    return str(ROOT / "ballpod.eds")
