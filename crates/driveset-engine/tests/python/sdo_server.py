"""SDO server side of driveset's CAN interoperability test
(crates/driveset-engine/tests/integration/interop_canopen.rs).

A `canopen` LocalNode (an SDO server driveset did not write) with a Lenze
ECS style object dictionary, on python-can's `slcan` interface. The Rust
test puts driveset_sim::slcan_hub between this script and driveset's
`slcan://` link: two simulated adapters joined by one bus.

Lenze mapping (ECS manual EDBCSXA064 EN 3.2 p. 454): index = 24575 - code,
subindex 0; FIX32 codes as INTEGER32 (value x 10000), C0135 / C0150
bit-coded as UNSIGNED32. C5001..C5016 are the FICTIONAL codes of
parameter-sets/fixtures/fictional-ecs-demo.toml. C5010 and C0150 are
read-only here (driveset's schema does not say so, so driveset sends the
write and the server aborts it with 0x06010002).

Protocol on stdin / stdout, one line each:
  -> (start)  "ready"              once the bus is open and the node serves
  <- "dump"   -> "C5001 45000000" ... one line per object in code order,
                 then "wrote C5001 50000000" ... one line per accepted write
                 in arrival order, then "end"
  <- "quit"   -> "bye", exit 0 (also on end of input)

With a third argument, the object dictionary is instead imported from that
CiA 306 EDS with canopen's own importer (canopen.import_od), and the dump
lists every variable the EDS gives a value: "0x4C76/0 30000000" (index /
subindex, raw; strings as JSON), writes as "wrote 0x4C76/0 45000000".

Usage: sdo_server.py PTY_PATH NODE_ID [EDS]
"""

import json
import sys
import threading

import can
import canopen
from canopen.objectdictionary import ODRecord, ODVariable, ObjectDictionary
from canopen.objectdictionary.datatypes import INTEGER32, UNSIGNED8, UNSIGNED32

# (code, data type, access, initial raw value)
OBJECTS = [
    (135, UNSIGNED32, "rw", 0x00000401),
    (150, UNSIGNED32, "ro", 0x00008421),
    (5001, INTEGER32, "rw", 45_000_000),  # 4500 rpm
    (5002, INTEGER32, "rw", 0),  # 0 rpm
    (5003, INTEGER32, "rw", 2_500),  # 0.250 s
    (5004, INTEGER32, "rw", 2_500),  # 0.250 s
    (5005, INTEGER32, "rw", 500),  # 0.050 s
    (5006, INTEGER32, "rw", 2_000_000),  # 200 %
    (5007, INTEGER32, "rw", 145_000),  # 14.5
    (5008, INTEGER32, "rw", 120_000),  # 12.0 ms
    (5009, INTEGER32, "rw", 250_000),  # 25.0 1/s
    (5010, INTEGER32, "ro", 45_000_000),  # 4500 rpm, read-only here
    (5011, INTEGER32, "rw", 68_000),  # 6.8 A
    (5012, INTEGER32, "rw", 45_000),  # 4.50 Nm
    (5013, INTEGER32, "rw", 40_000),  # 4
    (5014, INTEGER32, "rw", 800_000),  # 80 ms
    (5015, INTEGER32, "rw", 5_000),  # 0.5000 rev
    (5016, INTEGER32, "rw", 0),  # speed control
]


STORE_INDEX = 0x1010


def index(code):
    """Page 454: index = 24575 - code."""
    return 24575 - code


def build_od():
    od = ObjectDictionary()
    for code, data_type, access, initial in OBJECTS:
        v = ODVariable(f"C{code:04d}", index(code), 0)
        v.data_type = data_type
        v.access_type = access
        v.default = initial
        od.add_object(v)
    # CiA 301 0x1010 store parameters: the FICTIONAL store step the demo
    # fixture declares ([schema.store]); a write of it is not a setting and
    # is left out of the dump's writes
    store = ODRecord("Store parameters", STORE_INDEX)
    for sub, name, data_type, access, initial in [
        (0, "Highest sub-index supported", UNSIGNED8, "ro", 1),
        (1, "Save all parameters", UNSIGNED32, "rw", 1),
    ]:
        v = ODVariable(name, STORE_INDEX, sub)
        v.data_type = data_type
        v.access_type = access
        v.default = initial
        store.add_member(v)
    od.add_object(store)
    return od


def eds_variables(od):
    """Every variable of an imported dictionary, in (index, subindex) order."""
    out = []
    for obj in od.values():
        members = obj.values() if hasattr(obj, "values") else [obj]
        for var in members:
            out.append(var)
    return sorted(out, key=lambda v: (v.index, v.subindex))


def shown(raw):
    return json.dumps(raw) if isinstance(raw, str) else str(raw)


def main(argv):
    path = argv[1]
    node_id = int(argv[2])
    eds = argv[3] if len(argv) > 3 else None

    od = canopen.import_od(eds, node_id) if eds else build_od()
    node = canopen.LocalNode(node_id, od)
    writes = []
    lock = threading.Lock()

    def on_write(index, subindex, od, data):
        # Called only for writes the server accepts (after its access check).
        raw = od.decode_raw(data)
        if index == STORE_INDEX and not eds:
            return
        with lock:
            if eds:
                writes.append(f"0x{index:04X}/{subindex} {shown(raw)}")
            else:
                writes.append(f"C{24575 - index:04d} {raw}")

    node.add_write_callback(on_write)

    bus = can.Bus(interface="slcan", channel=path, bitrate=500000, sleep_after_open=0)
    network = canopen.Network(bus)
    network.connect()
    network.add_node(node)
    print("ready", flush=True)
    try:
        for line in sys.stdin:
            command = line.strip()
            if command == "dump" and eds:
                for var in eds_variables(od):
                    try:
                        data = node.get_data(var.index, var.subindex)
                    except Exception:  # no value in the EDS
                        continue
                    print(f"0x{var.index:04X}/{var.subindex} {shown(var.decode_raw(data))}")
                with lock:
                    for line in writes:
                        print(f"wrote {line}")
                print("end", flush=True)
            elif command == "dump":
                for code, _, _, _ in OBJECTS:
                    data = node.get_data(index(code), 0)
                    raw = od[index(code)].decode_raw(data)
                    print(f"C{code:04d} {raw}")
                with lock:
                    for line in writes:
                        print(f"wrote {line}")
                print("end", flush=True)
            elif command == "quit":
                break
            elif command:
                print(f"unknown command {command!r}", flush=True)
    finally:
        network.disconnect()
    print("bye", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
