"""Starts the simulated pod (`sim --serve`) for each client test and hands its JSON line to it.
The binary is taken from $BALLPOD_SIM (set by .ci/run), else built with cargo.

`pod` is that JSON line: can_port, usb_port, stream_port, node_id and truth (the served machine:
truth.machine.circle / .seed002 / .instrument, truth.ssm_error_um, truth.sphere_rc_zc_mm).
`@pytest.mark.sim_args("--speed", "40")` passes options to that test's pod (`sim --serve`'s; with
$BALLPOD_POD=emu, `@pytest.mark.emu_args` passes `emu --serve`'s)."""
import json
import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest

import podlib

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


def pytest_runtest_logreport(report):
    """A test run again (`--reruns`, .ci/run): what failed in its first attempt, printed, since
    pytest-rerunfailures reports only that it ran again (a flaky test is then read, not guessed)."""
    if report.outcome == "rerun":
        sys.stderr.write(f"\n{report.nodeid} ({report.when}) failed, run again:\n"
                         f"{report.longreprtext[-3000:]}\n")


def pytest_configure(config):
    config.addinivalue_line("markers", "sim_args(*args): extra options of that test's `sim --serve`")
    config.addinivalue_line("markers", "emu_args(*args): extra options of that test's `emu --serve`")
    config.addinivalue_line("markers", "sim_only: a behaviour of sim --serve itself (its TCP server, its speed-up)")
    config.addinivalue_line("markers", "desk: the desk's tests, against the simulated pod only (the emulated board "
                            "speaks the same SCPI and stream, at real time: a circle pair takes two minutes)")
    config.addinivalue_line("markers", "client: a client's behaviour (a book's script), against the simulated pod "
                            "only; the pod's side of it is tested on the emulated board by the protocol tests")


EMU_ELF = ROOT / "host-tests/emu-board/target/thumbv7em-none-eabihf/release/ballpod-emu"
# what the emulated board measured of itself during each test (CI prints it; book "The emulated board")
EMU_FIGURES = ROOT / "host-tests/target/emulated-board-figures.md"
# The STM32 board's stack, bytes (.ci/stack-report: memory.x's RAM less the STM32 build's statics;
# .ci/run sets it): the emulated board's high-water mark must stay 2 KiB under it
STM32_STACK_BYTES = int(os.environ.get("BALLPOD_STM32_STACK", "0"))
NOT_MEASURED = 0xFFFF_FFFF  # a device figure not measured (yet)
# a heartbeat's way from the application task to the bus task that times it (emu-board's
# board/can.rs), µs: seen at 10 kHz with the stream read, 3.23 ms late where tick and turn
# allowed 3.04 (2026-12-02)
HEARTBEAT_BUS_PATH_US = 500
# what the application task's longest turn handled (src/board/compute.rs TurnKind)
TURN_KINDS = {1: "block", 2: "CAN frame", 3: "USB", 4: "tick", 5: "work done"}


def check_emulated_figures(request, info, seconds):
    """After a test against the emulated firmware: what the board measured of itself in emulated
    time (its CAN adapter's SDO answer times and heartbeat gaps, the boots, the device counters
    the application task last set), one row of EMU_FIGURES; fails the test if the watchdog reset
    the firmware (a lock-up ends QEMU and the test with it; an expiry that a stall of QEMU on the
    host made, emulated time jumping while the firmware slept, is excused by the board and
    counted), a heartbeat came more than 2.5 ms off
    its 1000 ms (or the longest turn + 1.5 ms, where a turn was longer; the gaps around a QEMU stall
    on the host, which the sample clock's late tick shows, are left out and counted), an SDO
    answer took longer
    than 10 ms, a sample period was lost (by the ADC or on the way to the application task while
    a run ran or a job computed), a watchdog look
    missed a task, the stack came within
    2 KiB of the STM32 board's, or the CPU was busy more than 55 % of any 100 ms while a run ran
    (the interrupts and the application task; a job in the worker and the windows where the
    board caught up on periods owed after a QEMU stall are left out: board/load.rs). 55 % of the
    emulated CPU (125 M instructions a second) is 40 % of the G474 at 170 MHz; the highest
    sample rate's test runs at 51-53 % here."""
    f = info["figures"]()
    stack = f.get("stack_high_water_bytes", NOT_MEASURED)
    if not EMU_FIGURES.exists():
        EMU_FIGURES.parent.mkdir(exist_ok=True)
        EMU_FIGURES.write_text(
            "| test (emulated board) | s | heartbeat gaps: n (left out), least / most (ms) | SDO answers: n, worst (ms) "
            "| boots (watchdog) | periods lost / blocks dropped (in runs and jobs) | stack high water (B) "
            "| CPU while running: mean / busiest 100 ms (%) | longest turn (µs, of) "
            "| periods delivered late / most owed at a tick |\n"
            "|---|---|---|---|---|---|---|---|---|---|\n")
    gaps = f.get("heartbeat_gaps", 0)
    measured, peak = f.get("run_measured_us", 0), f.get("run_load_peak_permille", 0)
    load = f"{100 * f['run_busy_us'] / measured:.1f} / {peak / 10:.1f}" if measured else "no run"
    # watchdog expiries excused: QEMU stalled on the host while the firmware slept (its timers
    # all late at once; book "The emulated board")
    excused = f", {f['watchdog_stalls_excused']} QEMU stall excused" if f.get("watchdog_stalls_excused") else ""
    with EMU_FIGURES.open("a") as out:
        out.write(f"| {request.node.name} | {seconds:.0f} | {gaps} ({f.get('heartbeat_gaps_left_out', 0)}), "
                  f"{f.get('heartbeat_gap_min_us', 0) / 1e3:.3f} / "
                  f"{f.get('heartbeat_gap_max_us', 0) / 1e3:.3f} | {f.get('sdo_answers', 0)}, "
                  f"{f.get('sdo_worst_us', 0) / 1e3:.3f} | {f.get('boots')} ({f.get('watchdog_resets')}{excused}) | "
                  f"{f.get('adc_blocks_lost')} / {f.get('block_queue_overruns')} ({f.get('run_blocks_dropped')}) | "
                  f"{'not measured yet' if stack in (0, NOT_MEASURED) else stack} | {load} | "
                  f"{f.get('longest_turn_us', 0)} ({TURN_KINDS.get(f.get('longest_turn_kind', 0), hex(f.get('longest_turn_kind', 0)))}) | "
                  f"{f.get('periods_delivered_late', 0)} / {f.get('most_periods_owed', 0)} |\n")
    assert f["watchdog_resets"] == 0, f"the watchdog reset the firmware during the test: {f}"
    # a heartbeat leaves at the 1 ms tick nearest its time, and a tick waits for the application
    # task's turn in front of it: 2 ms, or the longest turn + 1 ms where a turn between runs is
    # longer (a line of several SCPI configuration writes, a probe run's sphere fit); and the
    # board times it where the bus task takes it, after the I/O executor's turn in front of
    # that task (the USB task's stream bytes, a UART the host reads late): 0.5 ms more. A job
    # in the application task would hold it for seconds.
    hb_tolerance_us = max(2000, f.get("longest_turn_us", 0) + 1000) + HEARTBEAT_BUS_PATH_US
    if gaps:
        assert abs(f["heartbeat_gap_min_us"] - 1e6) <= hb_tolerance_us, f
        assert abs(f["heartbeat_gap_max_us"] - 1e6) <= hb_tolerance_us, f
    assert f["sdo_worst_us"] <= 10_000, f
    assert f["adc_blocks_lost"] == 0 and f["watchdog_misses"] == 0, f
    # (blocks dropped between runs, with no job, are counted in the table but lose no sample
    # of a measurement: a command burst's turn)
    assert f["run_blocks_dropped"] == 0, f
    assert peak <= 550, f
    if STM32_STACK_BYTES and stack != NOT_MEASURED:
        assert stack <= STM32_STACK_BYTES - 2048, stack


def emulated():
    """True when the tests run against the emulated firmware ($BALLPOD_POD=emu: `emu --serve`,
    the firmware on QEMU's mps2-an386) instead of the simulated pod."""
    return os.environ.get("BALLPOD_POD") == "emu"


@pytest.fixture()
def pod(request, tmp_path_factory):
    """A fresh pod per test (killed after it): its JSON line as a dict. The simulated pod
    (`sim --serve`), or with $BALLPOD_POD=emu the firmware on the emulated board (`emu --serve`;
    its virtual CNC runs the same programs at real time; what the board measured of itself in
    emulated time is in `info["figures"]()`)."""
    marker = request.node.get_closest_marker("emu_args" if emulated() else "sim_args")
    extra = list(marker.args) if marker else []
    if emulated():
        if request.node.get_closest_marker("sim_only"):
            pytest.skip("a behaviour of sim --serve itself (its TCP server, its speed-up)")
        if request.node.get_closest_marker("desk"):
            pytest.skip("the desk is tested against the simulated pod")
        if request.node.get_closest_marker("client"):
            pytest.skip("a client's behaviour: tested against the simulated pod")
        figures = tmp_path_factory.mktemp("emu") / "figures.json"
        # (runs at real time: the seed 002 procedure's ten runs take about four minutes)
        cmd = [host_binary("emu"), "--serve", "--max-seconds", "900", "--elf", str(EMU_ELF),
               "--figures", str(figures), *extra]
    else:
        cmd = [host_binary("sim"), "--serve", "--max-seconds", "150", *extra]
    # its own process group: killing it kills the emulator the harness started too
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True, start_new_session=True)
    t0 = time.time()
    try:
        info = json.loads(proc.stdout.readline())
        assert {"can_port", "usb_port", "stream_port", "node_id"} <= info.keys(), info
        assert "truth" in info, info
        if emulated():
            info["figures"] = lambda: json.loads(figures.read_text()) if figures.exists() else {}
            # the harness's process (QEMU is its child): the host-stall test stops one or the other
            info["pid"] = proc.pid
            podlib.POSITIONED = lambda: info["figures"]().get("positioned", 0)
        yield info
        if emulated():
            check_emulated_figures(request, info, time.time() - t0)
    finally:
        podlib.POSITIONED = None
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)


@pytest.fixture()
def eds():
    return str(ROOT / "ballpod.eds")
