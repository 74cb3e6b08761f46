"""python `canopen`'s LSS master (CiA 305) as the integrator's, against the pod: set a node-ID
and a bit rate over the bus, find a pod that has no node-ID by fastscan.

Expectations come from CiA 305 (command specifiers, error codes, state rules), the EDS's
[DeviceInfo] (the LSS address) and what a CAN analyser on the bus sees — not from the pod's own
output. Frames pass on the SLCAN bus only while the adapter's bit rate (`Sn`) is the pod's."""
import threading
import time

import canopen
import pytest
from canopen.lss import LssError
from canopen.sdo.exceptions import SdoCommunicationError

from podlib import connect, wait_until

# CiA 305 table 1 (bit timing table 0): index of 250 kbit/s and of 800 kbit/s (not supported)
BIT_TIMING_250K = 3
BIT_TIMING_800K = 1
# CiA 305 command specifiers of the slave's answers
IDENTIFY_NON_CONFIGURED_SLAVE = 0x50
# the can_bitrate field's code of 250 kbit/s (the EDS's [2041] choices: 125k, 250k, 500k, 1M)
CAN_BITRATE_250K = 1


class Frames:
    """Every frame on the bus as a CAN analyser sees it: (COB-ID, data)."""

    def __init__(self, net):
        self.frames = []
        self.lock = threading.Lock()
        net.notifier.add_listener(self)

    def __call__(self, msg):
        with self.lock:
            self.frames.append((msg.arbitration_id, bytes(msg.data)))

    def since(self, k):
        with self.lock:
            return self.frames[k:]

    def mark(self):
        with self.lock:
            return len(self.frames)


def bus(pod, bitrate=500000):
    net = canopen.Network()
    net.connect(interface="slcan", channel=f"socket://127.0.0.1:{pod['can_port']}", bitrate=bitrate,
                sleep_after_open=0)
    net.lss.RESPONSE_TIMEOUT = 0.3
    return net


def lss_address_from_eds(eds):
    info = canopen.import_od(eds).device_information
    return [info.vendor_number, info.product_number, info.revision_number]


def test_lss_sets_node_id_and_bit_rate(pod, eds):
    net, node = connect(pod, eds)
    net.lss.RESPONSE_TIMEOUT = 0.3
    lss = net.lss
    try:
        ident = [node.sdo["Identity object"][n].raw
                 for n in ("Vendor-ID", "Product code", "Revision number", "Serial number")]
        assert ident[:3] == lss_address_from_eds(eds)
        # commands of the configuration state are ignored while waiting (no answer)
        with pytest.raises(LssError, match="No LSS response"):
            lss.inquire_node_id()
        # another pod's address selects nobody; the pod's own selects it
        assert not _selects(lss, ident[:3] + [ident[3] ^ 1])
        assert lss.send_switch_state_selective(*ident)
        assert lss.inquire_node_id() == pod["node_id"]
        for cs, v in zip((0x5A, 0x5B, 0x5C, 0x5D), ident):
            assert lss.inquire_lss_address(cs) == v
        # bad input: CiA 305 error 1 (out of range / not supported), nothing changes
        for bad in (0, 128, 254):
            with pytest.raises(LssError, match="LSS Error: 1"):
                lss.configure_node_id(bad)
        with pytest.raises(LssError, match="LSS Error: 1"):
            lss.configure_bit_timing(BIT_TIMING_800K)
        lss.store_configuration()  # the pending values are still the present ones
        assert node.sdo["can_node_id"].raw == pod["node_id"]
        assert node.sdo["can_bitrate"].raw == 2  # 500 kbit/s

        lss.configure_node_id(42)
        lss.configure_bit_timing(BIT_TIMING_250K)
        lss.store_configuration()
        lss.send_switch_state_global(lss.WAITING_STATE)
        # stored, but the node-ID is taken at reset communication (CiA 305 / 301)
        assert node.sdo["can_node_id"].raw == 42
        assert node.sdo["can_bitrate"].raw == CAN_BITRATE_250K
        frames = Frames(net)
        k = frames.mark()
        node.nmt.send_command(0x82)  # reset communication
        wait_until(lambda: (0x700 + 42, b"\x00") in frames.since(k), 3, "boot-up of node 42")
        new = net.add_node(42, eds)
        new.sdo.RESPONSE_TIMEOUT = 2.0
        assert new.sdo["Identity object"]["Serial number"].raw == ident[3]
        node.sdo.RESPONSE_TIMEOUT = 0.3
        with pytest.raises(SdoCommunicationError):
            node.sdo["can_node_id"].raw
        # activate the stored bit rate: after the switch delay the pod is at 250 kbit/s
        lss.send_switch_state_global(lss.CONFIGURATION_STATE)
        lss.activate_bit_timing(100)
        time.sleep(0.3)  # twice the switch delay, and some
        new.sdo.RESPONSE_TIMEOUT = 0.3
        with pytest.raises(SdoCommunicationError):
            new.sdo["can_node_id"].raw  # the adapter is still at 500 kbit/s
        net.bus.set_bitrate(250000)
        new.sdo.RESPONSE_TIMEOUT = 2.0
        assert new.sdo["can_node_id"].raw == 42
        new.nmt.wait_for_heartbeat(3)
        assert new.nmt.state == "PRE-OPERATIONAL"
        lss.send_switch_state_global(lss.WAITING_STATE)
    finally:
        net.disconnect()


def _selects(lss, address):
    try:
        return lss.send_switch_state_selective(*address)
    except LssError:
        return False


@pytest.mark.sim_args("--set", "can_node_id=255")
@pytest.mark.emu_args("--set", "can_node_id=255")
def test_a_pod_without_node_id_waits_for_lss_and_fastscan_finds_it(pod, eds):
    assert pod["node_id"] == 255
    net = bus(pod)
    lss = net.lss
    try:
        frames = Frames(net)
        time.sleep(1.5)  # longer than the heartbeat period
        assert frames.since(0) == [], "a pod without a node-ID sends nothing"
        lss.send_identify_non_configured_remote_slave()
        wait_until(lambda: any(i == 0x7E4 and d[0] == IDENTIFY_NON_CONFIGURED_SLAVE
                               for i, d in frames.since(0)), 2, "the non-configured pod's answer")
        found, address = lss.fast_scan()
        assert found
        assert address[:3] == lss_address_from_eds(eds)
        # fastscan's last step put the pod in the configuration state
        assert lss.inquire_node_id() == 255
        lss.configure_node_id(5)
        k = frames.mark()
        lss.send_switch_state_global(lss.WAITING_STATE)
        wait_until(lambda: (0x705, b"\x00") in frames.since(k), 3, "boot-up of node 5")
        node = net.add_node(5, eds)
        node.sdo.RESPONSE_TIMEOUT = 2.0
        assert node.sdo["Identity object"]["Serial number"].raw == address[3]
        node.nmt.wait_for_heartbeat(3)
        # configured, not stored: the stored configuration still has none
        assert node.sdo["can_node_id"].raw == 255
        # a configured pod no longer answers fastscan nor the non-configured identify
        k = frames.mark()
        found, _ = lss.fast_scan()
        assert not found
        lss.send_identify_non_configured_remote_slave()
        time.sleep(0.3)
        assert not any(i == 0x7E4 for i, _ in frames.since(k))
    finally:
        net.disconnect()
