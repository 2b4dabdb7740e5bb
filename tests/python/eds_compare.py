"""Compares a schema `driveset schema import` wrote with python-canopen's
reading of the same CiA 306 file (tests/integration/eds_quirks.rs).

For every code of the schema: the object python-canopen builds at the same
index / subindex (Lenze codes at 24575 - code, p. 454; `index` and
`subindex` as written; `subcodes = n` as subindexes 1..n) must have the
schema's CiA data type (`data_type`, else the type's own), access (ro /
const as read-only) and, where the schema gives them, the same raw default
and limits (FIX32 x 10000). Prints one line per disagreement and
"N variables agree"; exit 1 on any disagreement.

Usage: eds_compare.py FILE.eds SCHEMA.toml
"""

import configparser
import re
import sys
import tomllib
from decimal import Decimal

import canopen

TYPES = {
    "FIX32": 0x0004, "INTEGER32": 0x0004, "BITCODED": 0x0007, "UNSIGNED32": 0x0007,
    "UNSIGNED8": 0x0005, "UNSIGNED16": 0x0006, "INTEGER8": 0x0002, "INTEGER16": 0x0003,
    "VS": 0x0009, "VO": 0x000A,
}


def raw(code, text):
    if code["type"] == "VS":
        return text
    if code["type"] == "VO":
        return bytes.fromhex(text)
    v = Decimal(text)
    if code["type"] == "FIX32":
        v *= 10000
    return int(v)


def main():
    od = canopen.import_od(sys.argv[1], 1)
    cp = configparser.RawConfigParser(inline_comment_prefixes=(";",), strict=False)
    cp.optionxform = str.lower
    cp.read(sys.argv[1], encoding="latin-1")
    notes = []

    def eds_text(index, sub, key):
        for sec in ([f"{index:04X}", f"{index:04x}"] if sub is None else [f"{index:04X}sub{sub:X}", f"{index:04X}sub{sub}"]):
            if cp.has_section(sec) and cp.has_option(sec, key.lower()):
                return cp.get(sec, key.lower())
        return None

    with open(sys.argv[2], "rb") as f:
        schema = tomllib.load(f)
    bad, good = [], 0
    for code in schema.get("code", []):
        index = code.get("index", 24575 - code["number"])
        if "subindex" in code:
            places = [code["subindex"]]
        elif "subcodes" in code:
            places = list(range(1, code["subcodes"] + 1))
        else:
            places = [None]
        for sub in places:
            where = f"0x{index:04X}" + ("" if sub is None else f"sub{sub}")
            try:
                var = od[index] if sub is None else od[index][sub]
            except KeyError:
                bad.append(f"{where}: python-canopen has no such object")
                continue
            want_dt = code.get("data_type", TYPES.get(code["type"]))
            if var.data_type != want_dt:
                bad.append(f"{where}: DataType 0x{var.data_type:04X}, schema 0x{want_dt:04X}")
            ro = var.access_type in ("ro", "const")
            if ro != (code.get("access") == "ro"):
                flags = eds_text(index, sub, "ObjFlags")
                if not ro and flags is not None and int(flags, 0) & 1:
                    notes.append(f"{where}: rw kept read-only (ObjFlags bit 0)")
                else:
                    bad.append(f"{where}: AccessType {var.access_type}, schema {code.get('access')}")
            for key, attr in (("default", "default"), ("min", "min"), ("max", "max")):
                if key not in code:
                    continue
                theirs = getattr(var, attr, None)
                if isinstance(theirs, bool):
                    theirs = int(theirs)
                eds_key = {"default": "DefaultValue", "min": "LowLimit", "max": "HighLimit"}[key]
                text = eds_text(index, sub, eds_key) or ""
                if theirs is None and re.fullmatch(r"[+-]?0[0-9]+", text.strip()):
                    notes.append(f"{where}: {eds_key} {text} (leading zeros) read as decimal")
                    continue
                if raw(code, code[key]) != theirs:
                    bad.append(f"{where}: {key} {theirs!r}, schema {code[key]!r}")
            if "subcodes" not in code and var.name.strip() not in code.get("title", ""):
                bad.append(f"{where}: ParameterName {var.name!r}, schema title {code.get('title')!r}")
            good += 1
    for line in notes:
        print("note:", line)
    for line in bad:
        print(line)
    print(f"{good} variables agree" if not bad else f"{len(bad)} disagreements")
    sys.exit(1 if bad else 0)


main()
