//! `schema check` findings and schema loading errors.

use driveset_schema::error::SourceFile;
use driveset_schema::*;

fn check(text: &str) -> Vec<(String, usize, usize)> {
    let mut r = Registry::builtin().unwrap();
    let s = r
        .add_source(SourceFile::new("x.toml", text))
        .expect("schema parses");
    check_schema(&s)
        .into_iter()
        .map(|f| (f.message, f.location.line, f.location.column))
        .collect()
}

const HEAD: &str = "[schema]\nid = \"fictional-x\"\ntitle = \"FICTIONAL: x\"\nprotocol = \"lecom\"\ncode_style = \"lenze\"\nfictional = true\n";

#[test]
fn fixture_and_builtins_check() {
    let mut r = Registry::builtin().unwrap();
    let p =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/fictional-test.toml");
    let s = r.load_file(&p).unwrap();
    assert_eq!(check_schema(&s), vec![]);
    for s in r.schemas() {
        assert_eq!(check_schema(s), vec![], "{}", s.id);
    }
}

#[test]
fn untyped_code_with_facts_and_bits_is_not_an_error() {
    // the spec gives a default and bit fields but no type: the facts cannot be
    // range-checked, which is honest, not a schema error
    let text = format!(
        "{HEAD}
[[code]]
number = 1
name = \"a\"
title = \"A\"
spec = \"s\"
min = \"0\"
max = \"10\"
default = \"20\"
[[code.bits]]
name = \"x\"
bits = [0, 3]

[[code]]
number = 2
name = \"b\"
title = \"B\"
spec = \"s\"
type = \"PT_USIGN8\"
min = \"0\"
max = \"10\"
default = \"20\"

[[code]]
number = 3
name = \"c\"
title = \"C\"
spec = \"s\"
type = \"VD\"
[[code.bits]]
name = \"y\"
bits = [0, 3]
"
    );
    assert_eq!(
        check(&text),
        vec![
            ("code 2: default is outside [min, max]".to_string(), 28, 11),
            (
                "code 3 has bit fields but its type is not an integer type of known width".into(),
                31,
                10
            ),
        ]
    );
}

#[test]
fn every_schema_check() {
    let text = format!(
        "{HEAD}
[[code]]
number = 1
name = \"a\"
title = \"A\"
spec = \"s\"
type = \"PT_USIGN8\"
min = \"10\"
max = \"5\"
default = \"300\"
[code.values]
0 = \"Off\"
1 = \"off\"
256 = \"Big\"

[[code]]
number = 1
name = \"a\"
title = \"A again\"
spec = \"s\"
type = \"NOPE\"

[[code]]
number = 2
name = \"b\"
aliases = [\"a\"]
title = \"B\"
spec = \"s\"
type = \"PT_FIXPOINT16\"
default = \"0.07\"
values_ref = \"missing\"

[[code]]
number = 3
name = \"c\"
title = \"C\"
spec = \"s\"
type = \"PT_BINARY8\"
[[code.bits]]
name = \"x\"
bits = [0, 3]
[[code.bits]]
name = \"y\"
bits = [2, 9]

[[rule]]
kind = \"less-or-equal\"
left = 1
right = 99
message = \"m\"
"
    );
    let got = check(&text);
    let want: Vec<(String, usize, usize)> = vec![
        ("code 1: `default` is invalid: C0001 = 300 is outside the range of PT_USIGN8 (0 ..= 255)".into(), 16, 11),
        ("code 1: min is greater than max".into(), 14, 7),
        ("label \"off\" appears twice in code 1".into(), 19, 1),
        ("code 1: value 256 (\"Big\") is outside the raw range 0 ..= 255".into(), 20, 1),
        ("code 1 is defined twice".into(), 23, 10),
        ("name `a` of code 1 is already used by code 1".into(), 24, 8),
        ("code 1: unknown type `NOPE`".into(), 27, 8),
        ("name `a` of code 2 is already used by code 1".into(), 32, 12),
        ("code 2: `default` is invalid: C0002 = 0.07 is not representable in steps of 0.05; nearest are 0.05 and 0.1".into(), 36, 11),
        ("code 2 refers to unknown enumeration `missing`".into(), 37, 14),
        ("code 3 bit field y: bit 9 is outside the 8-bit value".into(), 50, 8),
        ("code 3: bit field y overlaps x".into(), 50, 8),
        ("rule refers to unknown code 99".into(), 53, 8),
    ];
    assert_eq!(got, want);
}

#[test]
fn fictional_marking() {
    let t = "[schema]\nid = \"fictional-y\"\ntitle = \"FICTIONAL: y\"\nprotocol = \"lecom\"\ncode_style = \"lenze\"\n";
    assert_eq!(
        check(t),
        vec![(
            "schema `fictional-y` is named fictional- but not marked `fictional = true`".into(),
            1,
            1
        )]
    );
    let t = "[schema]\nid = \"real\"\ntitle = \"Real\"\nprotocol = \"lecom\"\ncode_style = \"lenze\"\nfictional = true\n";
    assert_eq!(
        check(t),
        vec![
            (
                "schema `real` is marked fictional but its id does not start with `fictional-`"
                    .into(),
                6,
                13
            ),
            (
                "fixture schema `real` has a title not starting with FICTIONAL".into(),
                2,
                6
            ),
        ]
    );
}

#[test]
fn fixture_extends_fills_unset_facts() {
    let mut r = Registry::builtin().unwrap();
    r.add_source(SourceFile::new(
        "base.toml",
        "[schema]\nid = \"basey\"\ntitle = \"Base\"\nprotocol = \"lecom\"\ncode_style = \"lenze\"\n[[code]]\nnumber = 5\nname = \"five\"\ntitle = \"Five\"\nspec = \"s\"\nunit = \"Hz\"\n",
    ))
    .unwrap();
    let s = r
        .add_source(SourceFile::new(
            "fx.toml",
            "[schema]\nid = \"fictional-basey\"\ntitle = \"FICTIONAL: b\"\nextends = \"basey\"\nfictional = true\n[[code]]\nnumber = 5\ntype = \"VD\"\nunit = \"rpm\"\n[[code]]\nnumber = 6\nname = \"six\"\ntitle = \"Six\"\nspec = \"f\"\ntype = \"VD\"\n",
        ))
        .unwrap();
    let five = s.code(5).unwrap();
    assert_eq!(
        (five.unit.as_deref(), s.type_of(five)),
        (Some("Hz"), Some(ValueType::VD))
    );
    assert!(s.code_by_name("six").is_some());
    let f: Vec<String> = check_schema(&s).into_iter().map(|f| f.message).collect();
    assert_eq!(
        f,
        vec!["fixture changes `unit` of code 5, which the base schema already gives".to_string()]
    );
    let e = r
        .add_source(SourceFile::new("fx2.toml", "[schema]\nid = \"fictional-q\"\ntitle = \"FICTIONAL\"\nextends = \"nope\"\nfictional = true\n"))
        .unwrap_err();
    assert_eq!(
        (e.message.as_str(), e.location.line, e.location.column),
        ("base schema `nope` is not known", 4, 11)
    );
}

#[test]
fn schema_structure_errors() {
    let mut r = Registry::new();
    let e = r.add_source(SourceFile::new("s.toml", "[schema]\nid = \"a\"\ntitle = \"t\"\nprotocol = \"lecom\"\ncode_style = \"lenze\"\n[[code]]\nnumber = 1\nnmae = \"x\"\n")).unwrap_err();
    assert_eq!(
        (e.message.as_str(), e.location.line, e.location.column),
        ("unknown key `nmae` in code 1", 8, 1)
    );
    let e = r
        .add_source(SourceFile::new(
            "s.toml",
            "[schema]\nid = \"a\"\ntitle = \"t\"\nprotocol = \"can\"\n",
        ))
        .unwrap_err();
    assert_eq!(e.message, "unknown protocol `can`");
}

#[test]
fn the_same_schema_text_twice_is_one_schema_but_a_different_one_clashes() {
    let mut r = Registry::builtin().unwrap();
    let text = format!(
        "{HEAD}\n[[code]]\nnumber = 5001\nname = \"a\"\ntitle = \"A\"\nspec = \"fictional\"\ntype = \"VD\"\n"
    );
    let first = r
        .add_source(SourceFile::new("embedded/x.toml", text.as_str()))
        .unwrap();
    // Reached again from disk under another path: the same schema, no clash.
    let again = r
        .add_source(SourceFile::new("parameter-sets/x.toml", text.as_str()))
        .unwrap();
    assert!(std::sync::Arc::ptr_eq(&first, &again));
    // A different file claiming the same id is still an error that names both.
    let other = text.replace("title = \"A\"", "title = \"B\"");
    let err = r
        .add_source(SourceFile::new("other/x.toml", other.as_str()))
        .unwrap_err();
    assert_eq!(
        err.message,
        "schema id `fictional-x` is already defined by embedded/x.toml"
    );
    assert_eq!((err.location.line, err.location.column), (2, 6));
}

const CAN_HEAD: &str = "[schema]\nid = \"fictional-can\"\ntitle = \"FICTIONAL: can\"\nprotocol = \"lenze-can-sdo\"\ncode_style = \"lenze\"\nfictional = true\n[schema.can]\nindex_base = 24575\n";

#[test]
fn cia_objects_kept_by_index() {
    // number defaults to 65536 + index; an object inside the Lenze code
    // range is one of its own type (a non-Lenze device's), but two codes on
    // one object and `index` on LECOM are findings
    let text = format!(
        "{CAN_HEAD}
[[code]]
index = 0x1017
name = \"heartbeat\"
title = \"Producer heartbeat time\"
spec = \"s\"
type = \"UNSIGNED16\"
max = \"65535\"

[[code]]
index = 0x5FF4
name = \"inside\"
title = \"Inside the Lenze range\"
spec = \"s\"
type = \"INTEGER32\"

[[code]]
number = 11
name = \"c11\"
title = \"C0011\"
spec = \"s\"
type = \"FIX32\"
"
    );
    assert_eq!(
        check(&text),
        vec![(
            "code 11 reaches SDO index 0x5FF4, as code 90100 does".to_string(),
            26,
            10
        ),]
    );
    let mut r = Registry::builtin().unwrap();
    let s = r
        .add_source(SourceFile::new("x.toml", text.as_str()))
        .unwrap();
    let c = s.code(0x1_1017).expect("number 65536 + index");
    assert_eq!((c.index, c.name.as_str()), (Some(0x1017), "heartbeat"));
    assert_eq!(s.display_code(0x1_1017, Some(2)), "0x1017/2");
    assert_eq!(s.display_code(11, None), "C0011");

    let wrong = format!(
        "{CAN_HEAD}
[[code]]
index = 0x1017
number = 4119
name = \"heartbeat\"
title = \"t\"
spec = \"s\"
"
    );
    let e = Registry::builtin()
        .unwrap()
        .add_source(SourceFile::new("x.toml", wrong.as_str()))
        .unwrap_err();
    assert_eq!(
        (e.message.as_str(), e.location.line),
        (
            "code with `index` = 0x1017 has number 4119, not 69655 (65536 + index)",
            12
        )
    );

    // one subindex as a code: number 16777216 + index x 256 + subindex; a
    // whole object and one of its subindexes are one object twice; one
    // subindex has no subcodes; data_type must carry the type
    let subs = format!(
        "{CAN_HEAD}
[[code]]
index = 0x1018
subindex = 1
name = \"vendor_id\"
title = \"Identity: Vendor-ID\"
spec = \"s\"
type = \"UNSIGNED32\"
default = \"59\"
access = \"ro\"

[[code]]
index = 0x1018
name = \"identity\"
title = \"Identity\"
spec = \"s\"
type = \"UNSIGNED32\"
subcodes = 4

[[code]]
index = 0x6000
subindex = 2
subcodes = 2
name = \"b\"
title = \"b\"
spec = \"s\"
type = \"UNSIGNED8\"
data_type = 0x0007
"
    );
    assert_eq!(
        check(&subs),
        vec![
            (
                "code 69656 reaches SDO index 0x1018, as code 17831937 does".to_string(),
                21,
                9
            ),
            (
                "code 23068674: data_type 0x0007 does not carry type UNSIGNED8".to_string(),
                29,
                9
            ),
            (
                "code 23068674: one `subindex` has no `subcodes`".to_string(),
                29,
                9
            ),
        ]
    );
    let s = Registry::builtin()
        .unwrap()
        .add_source(SourceFile::new("x.toml", subs.as_str()))
        .unwrap();
    let c = s.code(0x100_0000 + 0x1018 * 256 + 1).expect("vendor_id");
    assert_eq!(
        (c.index, c.subindex, c.name.as_str()),
        (Some(0x1018), Some(1), "vendor_id")
    );
    assert_eq!(s.display_code(c.number, None), "0x1018sub1");
    let wrong_sub = format!(
        "{CAN_HEAD}\n[[code]]\nindex = 0x1018\nsubindex = 1\nnumber = 69656\nname = \"v\"\n"
    );
    let e = Registry::builtin()
        .unwrap()
        .add_source(SourceFile::new("x.toml", wrong_sub.as_str()))
        .unwrap_err();
    assert_eq!(
        e.message,
        "code with `index` = 0x1018, `subindex` = 1 has number 69656, not 17831937 (16777216 + index x 256 + subindex)"
    );
    let no_index = format!("{CAN_HEAD}\n[[code]]\nnumber = 5\nsubindex = 1\nname = \"v\"\n");
    let e = Registry::builtin()
        .unwrap()
        .add_source(SourceFile::new("x.toml", no_index.as_str()))
        .unwrap_err();
    assert_eq!(
        (e.message.as_str(), e.location.line),
        ("`subindex` without `index`", 12)
    );

    let lecom = format!(
        "{HEAD}
[[code]]
index = 0x1017
name = \"heartbeat\"
title = \"t\"
spec = \"s\"
"
    );
    assert_eq!(
        check(&lecom),
        vec![(
            "code 69655: `index` is for lenze-can-sdo schemas only".to_string(),
            9,
            9
        )]
    );
}

#[test]
fn roles_are_checked() {
    let text = format!(
        "{HEAD}
[[code]]
number = 1
name = \"a\"
title = \"A\"
spec = \"s\"
type = \"VH\"
width = 2
[[code.bits]]
name = \"go\"
bits = [0, 1]
role = \"start\"

[[code]]
number = 2
name = \"b\"
title = \"B\"
spec = \"s\"
role = \"setpoint\"
stopped = [0]
access = \"ro\"

[[code]]
number = 3
name = \"c\"
title = \"C\"
spec = \"s\"
type = \"VH\"
width = 2
role = \"password\"
[[code.bits]]
name = \"x\"
bits = [0, 0]
"
    );
    assert_eq!(
        check(&text),
        vec![
            (
                "code 1 bit field go has role `start`, which belongs to a `control-word` code, but the code's role is not set".to_string(),
                18,
                8
            ),
            ("code 1 bit field go has role `start` but is 2 bits wide".to_string(), 18, 8),
            ("code 2 has `stopped` values but is not a control word".to_string(), 21, 10),
            ("code 2 has role `command` but is read-only".to_string(), 25, 8),
            ("code 3 is a password but has bit fields".to_string(), 36, 8),
        ]
    );
    // unknown roles and the old `password = true` are load errors naming the fix
    let mut r = Registry::builtin().unwrap();
    for (body, msg, help) in [
        (
            "role = \"brake\"",
            "unknown role `brake` in code 9",
            "use one of: control-word, setpoint, command, operating-mode, control-source, bus-address, baud-rate, status, password",
        ),
        (
            "role = \"identify\"",
            "unknown role `identify` in code 9",
            "identify codes are listed in `[schema.identify] codes`, not by a role key",
        ),
        (
            "password = true",
            "`password` in code 9 is now a role",
            "write `role = \"password\"` instead",
        ),
    ] {
        let e = r
            .add_source(SourceFile::new(
                "y.toml",
                format!("{HEAD}\n[[code]]\nnumber = 9\nname = \"n\"\n{body}\n"),
            ))
            .unwrap_err();
        assert_eq!((e.message.as_str(), e.help.as_str()), (msg, help));
    }
    // the built-in schemas carry the roles the planner, pull and the CLI read
    let r = Registry::builtin().unwrap();
    let tmd = r.get("lenze-tmd").unwrap();
    let numbers =
        |role: Role| -> Vec<u32> { tmd.codes_with_role(role).map(|c| c.number).collect() };
    assert_eq!(numbers(Role::Command), vec![2, 43]);
    assert_eq!(numbers(Role::ControlWord), vec![40, 135]);
    assert_eq!(numbers(Role::Setpoint), vec![46, 47, 140]);
    assert_eq!(numbers(Role::Identify), vec![93, 99, 200]);
    assert_eq!(numbers(Role::Password), vec![94]);
    assert_eq!(numbers(Role::Status), vec![68, 150]);
    assert_eq!(
        tmd.running_indicator(),
        Some(RunningIndicator {
            code: 150,
            bit: 1,
            from: Role::Status
        })
    );
    let vf = r.get("lust-vf1000").unwrap();
    assert_eq!(
        vf.running_indicator(),
        Some(RunningIndicator {
            code: 3,
            bit: 7,
            from: Role::ControlWord
        })
    );
    assert_eq!(r.get("lenze-ecs").unwrap().running_indicator(), None);
    let c0135 = tmd.code(135).unwrap();
    assert_eq!(
        tmd.control_state(c0135, &RawValue::Int(0x0200)),
        ControlState::Inhibited("controller_inhibit".into())
    );
    assert_eq!(
        tmd.control_state(c0135, &RawValue::Int(0x0A00)),
        ControlState::Command(vec!["trip_reset".into()])
    );
    assert_eq!(
        tmd.control_state(c0135, &RawValue::Int(0)),
        ControlState::NotInhibited(vec!["quick_stop".into(), "controller_inhibit".into()])
    );
}
