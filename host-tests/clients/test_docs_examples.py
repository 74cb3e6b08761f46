"""The book's protocol examples run verbatim against the simulated pod: every ```python block of
the pages "The CNC's side" (docs/src/cnc.md: a session, then LSS) and "The technician's side" (docs/src/technician.md),
with only the port placeholders CAN_PORT / USB_PORT filled in, in a fresh interpreter from the
repository root; what they print is checked against the served machine's truth. The page
"Serving the simulated pod" (docs/src/serve.md) must name every key of the JSON line the pod
prints."""
import os
import pathlib
import re
import subprocess
import sys

import pytest

from podlib import LIVE, SerialBridge

ROOT = pathlib.Path(__file__).resolve().parents[2]


def page(name):
    return (ROOT / "docs" / "src" / name).read_text()


def python_blocks(name):
    blocks = re.findall(r"```python\n(.*?)```", page(name), re.S)
    assert blocks, f"no python example in docs/src/{name}"
    return blocks


def run_example(code, page):
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=90)
    assert out.returncode == 0, f"the example of docs/src/{page} failed:\n{code}\n{out.stderr}"
    return out.stdout.splitlines()


def test_canopen_example(pod):
    _, code = python_blocks("cnc.md")
    assert "net.add_node(16," in code and pod["node_id"] == 16  # the example's node-ID is the pod's
    lines = run_example(code.replace("CAN_PORT", str(pod["can_port"])), "cnc.md")
    assert lines[0] == "ballpod measurement pod"
    assert lines[1] == "ecc_u: abort 0x08000024"  # CiA 301: no data available
    assert re.fullmatch(r"delta_l_um -?\d+\.\d+(e-?\d+)? at sample \d+", lines[2]), lines[2]
    # e = −(socket offset) within 3 u (the truth's circle machine)
    s = pod["truth"]["machine"]["circle"]["socket_offset_um"]
    for line, offset in zip(lines[3:5], s):
        name, value, _, u = line.split()
        assert name in ("ecc_u_um", "ecc_v_um") and abs(float(value) + offset) <= 3 * float(u), line
    assert lines[5].startswith("G_ccw_um ") and float(lines[5].split()[1]) > 0


def test_lss_example(pod):
    code, _ = python_blocks("cnc.md")
    lines = run_example(code.replace("CAN_PORT", str(pod["can_port"])), "cnc.md")
    assert lines == [f"node-ID {pod['node_id']}", "node-ID 21"]


def test_scpi_examples(pod):
    visa, pyserial = python_blocks("technician.md")
    lines = run_example(visa.replace("USB_PORT", str(pod["usb_port"])), "technician.md")
    assert lines[0].startswith("BALLPOD,BP-1,")
    assert lines[1] == '-230,"Data corrupt or stale;ecc_u has no valid value"'
    s = pod["truth"]["machine"]["circle"]["socket_offset_um"]
    value, u, unit = lines[2].split(",")
    assert unit == "UM" and abs(float(value) + s[0]) <= 3 * float(u), lines[2]
    g, u_g, unit = lines[3].split(",")  # G and its u (the noise's, a few hundredths of a µm)
    assert unit == "UM" and float(g) > 0 and 0 < float(u_g) < 0.1, lines[3]
    # r0's budget: u, then the largest contributors, the bar's offset (its length's default
    # 0.5 µm and temperature's 0.2 K × 150 mm × 11.5 ppm/K in quadrature) first
    budget = lines[4].split(",")
    shares = dict(zip(budget[1::2], map(float, budget[2::2])))
    assert list(shares)[0] == "BAR_OFFSET", lines[4]
    assert abs(shares["BAR_OFFSET"] - (0.5**2 + (150 * 11.5 * 0.2e-3) ** 2) ** 0.5) < 1e-3, lines[4]
    assert abs(sum(v * v for v in shares.values()) ** 0.5 - float(budget[0])) < 2e-4, lines[4]
    # the page's own "e.g." line is what the pod answers (u and the shares within 1e-3 µm)
    shown = re.search(r"# (\d[\d.]*,BAR_OFFSET,[^\n]*)", page("technician.md")).group(1).split(",")
    assert shown[1::2] == budget[1::2], (shown, lines[4])
    assert all(abs(float(a) - float(b)) <= 1e-3 for a, b in zip(shown[0::2], budget[0::2])), (shown, lines[4])
    # MEAS:ALL?: counter, the live values (podlib's LIVE), status word, validity mask
    assert len(lines[5].split(",")) == 1 + len(LIVE) + 2, lines[5]
    # pyserial on the same pod, after the PyVISA session
    (line,) = run_example(pyserial.replace("USB_PORT", str(pod["usb_port"])), "technician.md")
    assert re.fullmatch(r'DONE;-?\d+\.\d{4},\d+\.\d{4},UM;0,"No error"', line), line


@pytest.mark.sim_only
def test_serve_section_names_the_json_line(pod):
    text = page("serve.md")
    keys = set(pod) | set(pod["truth"]) | set(pod["truth"]["machine"])
    missing = sorted(k for k in keys if f"`{k}`" not in text and f"`truth.{k}`" not in text
                     and f"`truth.machine.{k}`" not in text)
    assert not missing, f"keys of the JSON line not in docs/src/serve.md: {missing}"


@pytest.mark.client
def test_the_machine_tutorials_client_on_serial_ports(pod, tmp_path):
    """The client of "Your first test on the machine" as on a real pod: pyserial on two serial
    devices (pseudo-terminals bridged to the served pod's ports, as USB CDC-ACM ports are),
    through configure, reference, the bar check and a FEED_IN circle pair; the eccentricity is
    the served machine's socket offset (e = -s) within 3u."""
    text = page("tutorial-machine.md")
    client = re.search(r"```python\n# file: first-machine/pod.py\n(.*?)```", text, re.S).group(1)
    setup = re.search(r"```toml\n# file: first-machine/machine.toml\n(.*?)```", text, re.S).group(1)
    (tmp_path / "pod.py").write_text(client)
    (tmp_path / "machine.toml").write_text(setup)
    command, stream = SerialBridge(pod["usb_port"]), SerialBridge(pod["stream_port"])
    env = dict(os.environ, POD_COMMAND=command.path, POD_STREAM=stream.path)

    def step(*args):
        out = subprocess.run([sys.executable, "pod.py", *args], cwd=tmp_path, env=env, capture_output=True,
                             text=True, timeout=300)
        assert out.returncode == 0, (args, out.stderr)
        return out.stdout.splitlines()

    try:
        assert step("configure", "machine.toml")[1] == "13 fields written; axes X Y Z"
        assert step("reference", "451", "200", "-350") == ["X 451.0000 Y 200.0000 Z -350.0000"]
        assert step("bar", "150.000")[1] == "bar 4711, certificate 2026117 of 20260915"
        lines = step("run", "circle.stream")
    finally:
        command.close()
        stream.close()
    assert lines[:4] == ["CCW armed", "CCW DONE", "CW armed", "CW DONE"], lines
    s = pod["truth"]["machine"]["circle"]["socket_offset_um"]
    for line, offset in zip(lines[-2:], s):
        name, rest = line.split()
        value, u, unit = rest.split(",")
        assert name in ("ecc_u", "ecc_v") and unit == "UM" and abs(float(value) + offset) <= 3 * float(u), line
    assert (tmp_path / "circle.stream").read_bytes().count(b"# stream_dropped=") == 2
