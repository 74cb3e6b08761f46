#!/usr/bin/env python3
"""The pod's session from a part program's M-codes (LinuxCNC user M-codes; `ncgen m-codes DIR`
writes this file and the M1xx scripts that call it). Each call is one step:

    ballpod_session.py setup P [Q]    apply ballpod-setup-<P>.toml (pattern, configuration)
    ballpod_session.py arm-ccw|arm-cw arm a run of the set-up's pattern, wait until ARMED
    ballpod_session.py start          start the armed run, wait until RUNNING
    ballpod_session.py stop           stop the run, wait until DONE
    ballpod_session.py results        wait until the run is DONE and its results are published,
                                      print the valid ones

The pod is reached over CANopen (python `canopen` on any python-can interface) or over its USB
command port (SCPI, pyserial), as the environment says:

    BALLPOD_CAN          python-can "interface:channel" (default "socketcan:can0"; e.g.
                         "slcan:/dev/ttyACM0", "slcan:socket://127.0.0.1:PORT")
    BALLPOD_CAN_BITRATE  bit/s (default 500000)
    BALLPOD_NODE         the pod's node-ID (default 16)
    BALLPOD_EDS          the pod's EDS (default: ballpod.eds beside this file)
    BALLPOD_SCPI         a pyserial URL of the USB command port instead (e.g. /dev/ttyACM0,
                         socket://127.0.0.1:PORT)
    BALLPOD_SETUP_DIR    where the set-up files are (default: beside this file)
    BALLPOD_TIMEOUT      seconds a step waits for the pod (default 60)

Exit status 0 when the pod reached the state the step waits for; 1 with the reason otherwise
(the pod's refusal, its abort reason, or the timeout). LinuxCNC runs the next block once the
script exits.
"""
import os
import pathlib
import re
import sys
import time
import tomllib

HERE = pathlib.Path(__file__).resolve().parent
PATTERNS = ["CIRCLE", "BX", "BY", "CR", "CA", "CR2", "SSM", "PROBE"]
STATES = ["IDLE", "ARMED", "RUNNING", "DONE", "ABORTED"]
RESULTS_READY = 1 << 10
TIMEOUT = float(os.environ.get("BALLPOD_TIMEOUT", "60"))


class Refused(Exception):
    """The pod refused a step, or did not reach its state in time."""


def setup_file(number):
    d = pathlib.Path(os.environ.get("BALLPOD_SETUP_DIR", HERE))
    path = d / f"ballpod-setup-{number}.toml"
    try:
        data = tomllib.loads(path.read_text())
    except OSError as e:
        raise Refused(f"set-up {number}: {e}") from e
    pattern = data.get("session", {}).get("pattern", "CIRCLE")
    if pattern not in PATTERNS:
        raise Refused(f"{path}: pattern {pattern!r} is not one of {PATTERNS}")
    return pattern, data.get("setup", {})


def with_u(u):
    """A standard uncertainty as printed (NaN, or SCPI's 9.91E+37: not evaluated)."""
    return f"u {u:.4f}" if u == u and u < 1e37 else "u not evaluated"


def wait(what, cond):
    t0 = time.time()
    while time.time() - t0 < TIMEOUT:
        if cond():
            return
        time.sleep(0.05)
    raise Refused(f"timed out after {TIMEOUT:.0f} s waiting for {what}")


class Can:
    """The pod over CANopen, objects read and written by their EDS names."""

    def __init__(self):
        import canopen
        from canopen.sdo.exceptions import SdoAbortedError
        self.aborted = SdoAbortedError
        interface, _, channel = os.environ.get("BALLPOD_CAN", "socketcan:can0").partition(":")
        self.net = canopen.Network()
        self.net.connect(interface=interface, channel=channel,
                         bitrate=int(os.environ.get("BALLPOD_CAN_BITRATE", "500000")),
                         **({"sleep_after_open": 0} if interface == "slcan" else {}))
        eds = os.environ.get("BALLPOD_EDS", str(HERE / "ballpod.eds"))
        self.node = self.net.add_node(int(os.environ.get("BALLPOD_NODE", "16")), eds)
        self.node.sdo.RESPONSE_TIMEOUT = 2.0

    def close(self):
        self.net.disconnect()

    def write(self, name, value):
        var = self.node.sdo[name]
        real = var.od.data_type == 0x0008
        try:
            var.raw = float(value) if real else int(value)
        except self.aborted as e:
            raise Refused(f"{name} = {value}: SDO abort 0x{e.code:08X}: "
                          f"{self.node.sdo['last_refusal'].raw}") from e

    def read(self, name):
        return self.node.sdo[name].raw

    def setup(self, pattern, fields):
        self.node.nmt.state = "PRE-OPERATIONAL"  # configuration is written in pre-operational
        time.sleep(0.05)
        for name, value in fields.items():
            self.write(name, value)
        self.write("pattern", PATTERNS.index(pattern))

    def arm(self, direction):
        self.write("direction", direction)
        self.write("session_command", 1)
        self.wait_state(1)

    def command(self, code, state):
        self.write("session_command", code)
        self.wait_state(state)

    def wait_state(self, state):
        def reached():
            s = self.read("session_state")
            if s == 4 and state != 4:
                raise Refused(f"the run aborted (abort_reason {self.read('abort_reason')})")
            return s == state
        wait(STATES[state], reached)

    def results(self):
        wait("DONE", lambda: self.read("session_state") in (3, 4))
        if self.read("session_state") == 4:
            raise Refused(f"the run aborted (abort_reason {self.read('abort_reason')})")
        wait("RESULTS_READY", lambda: self.read("status_word") & RESULTS_READY)
        out = []
        for var in self.node.sdo["result_valid"].values():
            if var.subindex and var.raw:
                v = self.node.sdo["result_value"][var.subindex].raw
                u = self.node.sdo["result_uncertainty"][var.subindex].raw
                out.append(f"{var.name.split('.')[-1]} {v:.4f} {with_u(u)}")
        return out


class Scpi:
    """The pod over its USB command port."""

    def __init__(self):
        import serial
        self.port = serial.serial_for_url(os.environ["BALLPOD_SCPI"], timeout=2.0)

    def close(self):
        self.port.close()

    def ask(self, line):
        self.port.write(line.encode() + b"\n")
        reply = self.port.readline().decode().strip()
        if not reply:
            raise Refused(f"{line}: no answer")
        return reply

    def send(self, line):
        self.port.write(line.encode() + b"\n")
        err = self.ask("SYST:ERR?")
        if not err.startswith("0,"):
            raise Refused(f"{line}: {err}")

    def setup(self, pattern, fields):
        self.send("CONF:UNL")
        for name, value in fields.items():
            self.send(f"CONF:{name.upper()} {value}")
        self.send(f"SESS:PATT {pattern}")

    def arm(self, direction):
        self.send(f"SESS:DIR {('CCW', 'CW')[direction]}")
        self.send("SESS:ARM")
        self.wait_state(1)

    def command(self, code, state):
        self.send({2: "SESS:STAR", 3: "SESS:STOP"}[code])
        self.wait_state(state)

    def wait_state(self, state):
        def reached():
            s = self.ask("SESS:STAT?")
            if s == "ABORTED" and state != 4:
                raise Refused(f"the run aborted ({self.ask('SESS:REAS?')})")
            return s == STATES[state]
        wait(STATES[state], reached)

    def results(self):
        wait("DONE", lambda: self.ask("SESS:STAT?") in ("DONE", "ABORTED"))
        if self.ask("SESS:STAT?") == "ABORTED":
            raise Refused(f"the run aborted ({self.ask('SESS:REAS?')})")
        wait("RESULTS_READY", lambda: int(self.ask("STAT:POD?")) & RESULTS_READY)
        out = []
        for name in self.ask("FETC:RES:CAT?").replace('"', "").split(","):
            # an invalid result's query answers nothing and queues -230: the error query
            # after it answers in either case (`value,u,UNIT;0,"No error"` or `-230,"…"`)
            line = self.ask(f"FETC:RES? {name};:SYST:ERR?")
            if not re.match(r'^-?\d+,"', line):
                value, u, _unit = line.split(";")[0].split(",")
                out.append(f"{name} {float(value):.4f} {with_u(float(u))}")
        return out


def main(argv):
    if not argv:
        raise Refused("no step given: " + __doc__.splitlines()[0])
    action, args = argv[0], [float(a) for a in argv[1:3]]
    pod = Scpi() if os.environ.get("BALLPOD_SCPI") else Can()
    try:
        if action == "setup":
            number = int(args[0]) if args else 0
            pattern, fields = setup_file(number)
            pod.setup(pattern, fields)
            print(f"ballpod: set-up {number} applied ({pattern}, {len(fields)} fields)")
        elif action in ("arm-ccw", "arm-cw"):
            pod.arm(0 if action == "arm-ccw" else 1)
            print(f"ballpod: {action[4:].upper()} run armed")
        elif action == "start":
            pod.command(2, 2)
            print("ballpod: run started")
        elif action == "stop":
            pod.command(3, 3)
            print("ballpod: run stopped")
        elif action == "results":
            for line in pod.results():
                print(f"ballpod: {line}")
        else:
            raise Refused(f"unknown step {action!r}")
    finally:
        pod.close()


if __name__ == "__main__":
    try:
        main(sys.argv[1:])
    except Refused as e:
        print(f"ballpod: {e}", file=sys.stderr)
        sys.exit(1)
