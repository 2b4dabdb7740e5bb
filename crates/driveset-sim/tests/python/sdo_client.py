"""SDO client side of driveset's CAN interoperability test.

Talks to simulated Lenze ECS drives (driveset-sim's slcan adapter on a
pseudo terminal) with python-can's `slcan` interface and the `canopen`
package's SDO client, and prints one line per exchange. The Rust test
(crates/driveset-sim/tests/integration/ecs_python_interop.rs) compares the lines
exactly.

Lenze mapping (ECS manual EDBCSXA064 EN 3.2 p. 454): index = 24575 - code,
subindex 0 for codes without subcodes; FIX32 = signed 32 bit, value x 10000;
C0135 / C0150 bit-coded, unsigned 32 bit, no factor.

Usage: sdo_client.py PTY_PATH [NODE_ID]
"""

import sys

import can
import canopen
from canopen.objectdictionary import ObjectDictionary, ODVariable
from canopen.objectdictionary.datatypes import INTEGER32, UNSIGNED32


def index(code):
    """Page 454: index = 24575 - code."""
    return 24575 - code


def fix32_text(raw):
    """Exact decimal text of a FIX32 raw integer, 4 decimals."""
    sign = "-" if raw < 0 else ""
    whole, frac = divmod(abs(raw), 10000)
    return f"{sign}{whole}.{frac:04d}"


def variable(name, code, data_type):
    v = ODVariable(name, index(code), 0)
    v.data_type = data_type
    v.access_type = "rw"
    return v


def abort_line(prefix, action):
    try:
        action()
    except canopen.SdoAbortedError as e:
        print(f"{prefix} abort 0x{e.code:08X}")
        return
    print(f"{prefix} NOT ABORTED")


def main(argv):
    path = argv[1]
    node_id = int(argv[2]) if len(argv) > 2 else 1

    od = ObjectDictionary()
    od.add_object(variable("max_speed", 5001, INTEGER32))
    od.add_object(variable("min_speed", 5002, INTEGER32))
    od.add_object(variable("code_0135", 135, UNSIGNED32))
    od.add_object(variable("code_0150", 150, UNSIGNED32))

    bus = can.Bus(interface="slcan", channel=path, bitrate=500000, sleep_after_open=0)
    network = canopen.Network(bus)
    network.connect()
    try:
        node = canopen.RemoteNode(node_id, od)
        network.add_node(node)
        node.sdo.RESPONSE_TIMEOUT = 2.0
        sdo = node.sdo

        raw = sdo["max_speed"].raw
        print(f"read C5001 index=0x{index(5001):04X} raw={raw} value={fix32_text(raw)}")

        sdo["min_speed"].raw = 12345678
        print("write C5002 raw=12345678 ok")
        raw = sdo["min_speed"].raw
        print(f"read C5002 raw={raw} value={fix32_text(raw)}")

        abort_line(
            "write C5017",
            lambda: sdo.download(index(5017), 0, (5).to_bytes(4, "little", signed=True)),
        )

        def too_high():
            sdo["max_speed"].raw = 160000001

        abort_line("write C5001 raw=160000001", too_high)

        raw = sdo["code_0150"].raw
        print(f"read C0150 raw=0x{raw:08X}")

        sdo["code_0135"].raw = 0x00000401
        print(f"write C0135 raw=0x{sdo['code_0135'].raw:08X} ok")

        sdo.download(index(5003), 0, (25000).to_bytes(4, "little", signed=True), force_segment=True)
        raw = int.from_bytes(sdo.upload(index(5003), 0), "little", signed=True)
        print(f"write C5003 segmented raw={raw} ok")

        abort_line(
            "write C5004 segmented 8 bytes",
            lambda: sdo.download(index(5004), 0, bytes(range(1, 9))),
        )
        abort_line("read C9999", lambda: sdo.upload(index(9999), 0))
        print("done")
    finally:
        network.disconnect()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
