"""A strict CiA 306 reading of a DCF `driveset show --to dcf` wrote, then
python-canopen's (tests/integration/eds_quirks.rs).

Strict (CiA 306 §4): no duplicate section or key (configparser strict
mode); [FileInfo], [DeviceInfo] with every key of §4.5 and numeric values
where numbers are asked; [MandatoryObjects] listing 0x1000, 0x1001, 0x1018;
every listed object has its section and every object section is listed in
exactly one object list; SupportedObjects matches the entries; VAR sections
have ParameterName, DataType (a CiA 301 type number) and AccessType;
ARRAY / RECORD sections have SubNumber = the number of their [IIIIsubS]
sections, sub 0 among them; no inline `;` python-canopen would cut.
Then canopen.import_od must load it and every ParameterValue must read back
as the same value. Prints "ok N objects" or the problems; exit 1 on any.

Usage: dcf_check.py FILE.dcf
"""

import configparser
import re
import sys

import canopen

DEVICE_INFO_NUMBERS = [
    "VendorNumber", "ProductNumber", "RevisionNumber",
    "BaudRate_10", "BaudRate_20", "BaudRate_50", "BaudRate_125", "BaudRate_250",
    "BaudRate_500", "BaudRate_800", "BaudRate_1000", "SimpleBootUpMaster",
    "SimpleBootUpSlave", "Granularity", "DynamicChannelsSupported",
    "GroupMessaging", "NrOfRXPDO", "NrOfTXPDO", "LSS_Supported",
]
DEVICE_INFO_TEXT = ["VendorName", "ProductName", "OrderCode"]
TYPES = {0x1, 0x2, 0x3, 0x4, 0x5, 0x6, 0x7, 0x8, 0x9, 0xA, 0xB, 0xF, 0x10, 0x11, 0x15, 0x1B}


def main():
    path = sys.argv[1]
    problems = []
    cp = configparser.RawConfigParser(strict=True, interpolation=None)
    cp.optionxform = str
    with open(path, encoding="utf-8") as f:
        text = f.read()
    for n, line in enumerate(text.splitlines(), 1):
        if not line.startswith(";") and re.search(r"\s;", line):
            problems.append(f"line {n}: python-canopen would cut the value at ` ;`")
    cp.read_string(text)
    for sec in ("FileInfo", "DeviceInfo"):
        if not cp.has_section(sec):
            problems.append(f"no [{sec}]")
    for key in DEVICE_INFO_NUMBERS + DEVICE_INFO_TEXT:
        if not cp.has_option("DeviceInfo", key):
            problems.append(f"[DeviceInfo] has no {key}")
        elif key in DEVICE_INFO_NUMBERS:
            try:
                int(cp.get("DeviceInfo", key), 0)
            except ValueError:
                problems.append(f"[DeviceInfo] {key} is not a number")
    listed = {}
    for sec in ("MandatoryObjects", "OptionalObjects", "ManufacturerObjects"):
        if not cp.has_section(sec):
            problems.append(f"no [{sec}]")
            continue
        n = int(cp.get(sec, "SupportedObjects"), 0)
        entries = [k for k in cp.options(sec) if k != "SupportedObjects"]
        if len(entries) != n:
            problems.append(f"[{sec}] SupportedObjects={n} but {len(entries)} entries")
        for k in entries:
            idx = int(cp.get(sec, k), 0)
            if idx in listed:
                problems.append(f"0x{idx:04X} listed in [{listed[idx]}] and [{sec}]")
            listed[idx] = sec
    for idx in (0x1000, 0x1001, 0x1018):
        if listed.get(idx) != "MandatoryObjects":
            problems.append(f"0x{idx:04X} is not in [MandatoryObjects]")
    mains = {int(s, 16): s for s in cp.sections() if re.fullmatch(r"[0-9A-Fa-f]{4}", s)}
    subs = {}
    for s in cp.sections():
        m = re.fullmatch(r"([0-9A-Fa-f]{4})sub([0-9A-Fa-f]+)", s)
        if m:
            subs.setdefault(int(m.group(1), 16), []).append((int(m.group(2), 16), s))
    for idx in listed:
        if idx not in mains:
            problems.append(f"0x{idx:04X} is listed but has no section")
    for idx, s in mains.items():
        if idx not in listed:
            problems.append(f"[{s}] is in no object list")
        ot = int(cp.get(s, "ObjectType", fallback="0x7"), 0)
        if not cp.has_option(s, "ParameterName"):
            problems.append(f"[{s}] has no ParameterName")
        var_sections = [s] if ot == 7 else [x for _, x in subs.get(idx, [])]
        if ot in (8, 9):
            have = subs.get(idx, [])
            if int(cp.get(s, "SubNumber"), 0) != len(have):
                problems.append(f"[{s}] SubNumber={cp.get(s, 'SubNumber')} but {len(have)} sub sections")
            if 0 not in [n for n, _ in have]:
                problems.append(f"[{s}] has no sub 0")
        for v in var_sections:
            for key in ("ParameterName", "DataType", "AccessType"):
                if not cp.has_option(v, key):
                    problems.append(f"[{v}] has no {key}")
            if cp.has_option(v, "DataType") and int(cp.get(v, "DataType"), 0) not in TYPES:
                problems.append(f"[{v}] DataType {cp.get(v, 'DataType')} is no CiA 301 type")
            if cp.get(v, "AccessType", fallback="ro").lower() not in ("ro", "wo", "rw", "rwr", "rww", "const"):
                problems.append(f"[{v}] AccessType {cp.get(v, 'AccessType')}")
    od = canopen.import_od(path, 1)
    values = 0
    for idx, s in mains.items():
        for sec, sub in [(s, None)] + [(x, n) for n, x in subs.get(idx, [])]:
            if not cp.has_option(sec, "ParameterValue"):
                continue
            var = od[idx] if sub is None else od[idx][sub]
            text = cp.get(sec, "ParameterValue")
            want = text if var.data_type == 0x9 else (bytes.fromhex(text) if var.data_type == 0xA else int(text, 0))
            if var.value != want:
                problems.append(f"[{sec}] ParameterValue {text!r} reads as {var.value!r}")
            values += 1
    for p in problems:
        print(p)
    print(f"ok {len(mains)} objects, {values} values" if not problems else f"{len(problems)} problems")
    sys.exit(1 if problems else 0)


main()
