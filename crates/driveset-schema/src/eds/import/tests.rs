//! Tests of the EDS import: exact lints, codes and limits of small
//! byte-built data sheets.

use super::*;

fn opts() -> ImportOptions {
    ImportOptions {
        id: Some("ecs-test".into()),
        file: "t.eds".into(),
    }
}

fn lints(i: &Imported) -> Vec<String> {
    i.lints.iter().map(|l| l.render("t.eds")).collect()
}

/// The code block of `number` in the written schema.
fn block(toml: &str, number: u32) -> String {
    let start = toml
        .find(&format!("[[code]]\nnumber = {number}\n"))
        .unwrap_or_else(|| panic!("no code {number} in\n{toml}"));
    let rest = &toml[start..];
    let end = rest[1..].find("\n[[code]]").map_or(rest.len(), |e| e + 1);
    rest[..end].trim_end().to_string()
}

/// What python-canopen's users report (issues #313, #385, #49/#50):
/// empty PDOMapping, `$NODEID+0x580`, `001`, no [FileInfo] /
/// [DeviceInfo], duplicate keys, lowercase keys, hex in any case.
const MALFORMED: &str = "\
[5FF4]
parametername=Max speed
ObjectType=0x7
datatype=0x0004
AccessType=RW
DefaultValue=001
LowLimit=0X0
HighLimit=0x1a
HighLimit=99
PDOMapping=

[1200]
ParameterName=Server SDO parameter
ObjectType=0x9
SubNumber=2

[1200sub1]
ParameterName=COB-ID server to client
DataType=0x0007
AccessType=ro
DefaultValue=$NODEID+0x580

[1014]
ParameterName=COB-ID EMCY
ObjectType=0x7
DataType=0x0007
AccessType=ro
DefaultValue=0x80+$NODEID
PDOMapping=

[5FF5]
ParameterName=Jog speed
DataType=0x0004
AccessType=rww
DefaultValue=010
LowLimit=
HighLimit=00100000

[5FF6sub1]
ParameterName=orphan
DataType=0x0004
AccessType=rw
[DeviceInfo]
VendorNumber=0x0000003B
";

/// Appended to a test file: a Lenze data sheet (lint at `line`).
const LENZE: &str = "[DeviceInfo]\nVendorName=Lenze\n";

fn lenze_lint(line: usize) -> String {
    format!(
        "t.eds:{line}: VendorName `Lenze` names Lenze (no VendorNumber to tell): objects 0x38F0..0x5FFF are Lenze codes C9999..C0000 (code = 24575 - index, FIX32 value x 10000), 0x2000..0x38EF kept by index with their own types"
    )
}

#[test]
fn malformed_vendor_file_exact_lints_and_codes() {
    let i = import(MALFORMED.as_bytes(), &opts()).unwrap();
    assert_eq!(
        lints(&i),
        vec![
            "t.eds:9: key HighLimit given twice in [5FF4] (first at line 8); the first value is kept",
            "t.eds:12: 0x1200: SDO channel parameter: bus configuration ($NODEID COB-IDs), not a drive setting; skipped",
            "t.eds:28: 0x1014: DefaultValue `0x80+$NODEID` depends on the node id; left unset",
            "t.eds:35: 0x5FF5: DefaultValue `010` read as decimal 10 (a leading 0 means octal in C, giving 8)",
            "t.eds:36: 0x5FF5: empty LowLimit; left unset",
            "t.eds:37: 0x5FF5: HighLimit `00100000` read as decimal 100000 (a leading 0 means octal in C, giving 32768)",
            "t.eds:39: 0x5FF6sub1: no main section [5FF6]; skipped",
            "t.eds:44: VendorNumber 0x0000003B is Lenze's CiA vendor ID (0x3B): objects 0x38F0..0x5FFF are Lenze codes C9999..C0000 (code = 24575 - index, FIX32 value x 10000), 0x2000..0x38EF kept by index with their own types",
        ]
    );
    assert_eq!((i.lenze_codes, i.cia_objects), (2, 1));
    assert_eq!(
        block(&i.toml, 11),
        "[[code]]\nnumber = 11\nname = \"max_speed\"\ntitle = \"Max speed\"\nspec = \"t.eds [5FF4] line 1\"\ntype = \"FIX32\"\nmin = \"0\"\nmax = \"0.0026\"\ndefault = \"0.0001\"\naccess = \"rw\""
    );
    assert_eq!(
        block(&i.toml, 10),
        "[[code]]\nnumber = 10\nname = \"jog_speed\"\ntitle = \"Jog speed\"\nspec = \"t.eds [5FF5] line 31\"\ntype = \"FIX32\"\nmax = \"10\"\ndefault = \"0.001\"\naccess = \"rw\""
    );
    assert_eq!(
        block(&i.toml, 0x1_1014),
        "[[code]]\nnumber = 69652\nindex = 0x1014\nname = \"cob_id_emcy\"\ntitle = \"COB-ID EMCY\"\nspec = \"t.eds [1014] line 23\"\ntype = \"UNSIGNED32\"\naccess = \"ro\""
    );
    assert!(
        i.toml.contains("[schema]\nid = \"ecs-test\"\n"),
        "{}",
        i.toml
    );
}

#[test]
fn fix32_bitcoded_limits_and_twos_complement() {
    let text = "\
[5F78]
ParameterName=C0135
DataType=0x0004
AccessType=rw
DefaultValue=0x0401
[5FFE]
ParameterName=Offset
DataType=0x0004
AccessType=rw
DefaultValue=0xFFFFFFFF
LowLimit=-2147483648
HighLimit=2147483647
[5FFD]
ParameterName=Offset
DataType=0x0004
AccessType=const
DefaultValue=5
LowLimit=9
HighLimit=1
";
    let text = format!("{text}{LENZE}");
    let i = import(text.as_bytes(), &opts()).unwrap();
    assert_eq!(
        lints(&i),
        vec![
            "t.eds:1: 0x5F78: DataType INTEGER32 (0x0004): typed BITCODED (u32) as page 454 says of C0135 / C0150".to_string(),
            "t.eds:13: 0x5FFD: LowLimit 0.0009 is above HighLimit 0.0001; both left unset".to_string(),
            lenze_lint(21),
        ]
    );
    assert_eq!(
        block(&i.toml, 135),
        "[[code]]\nnumber = 135\nname = \"code_0135\"\ntitle = \"C0135\"\nspec = \"t.eds [5F78] line 1\"\ntype = \"BITCODED\"\ndata_type = 0x0004\ndefault = \"1025\"\naccess = \"rw\"\nrole = \"control-word\""
    );
    assert_eq!(
        block(&i.toml, 1),
        "[[code]]\nnumber = 1\nname = \"offset\"\ntitle = \"Offset\"\nspec = \"t.eds [5FFE] line 6\"\ntype = \"FIX32\"\nmin = \"-214748.3648\"\nmax = \"214748.3647\"\ndefault = \"-0.0001\"\naccess = \"rw\""
    );
    // a name used twice gets the code appended
    assert_eq!(
        block(&i.toml, 2),
        "[[code]]\nnumber = 2\nname = \"offset_code_0002\"\ntitle = \"Offset\"\nspec = \"t.eds [5FFD] line 13\"\ntype = \"FIX32\"\ndefault = \"0.0005\"\naccess = \"ro\""
    );
}

#[test]
fn compact_sub_obj_and_mixed_records() {
    let text = "\
[4C63]
ParameterName=Setpoints
ObjectType=0x8
CompactSubObj=3
DataType=0x0004
AccessType=rw
DefaultValue=10000
[6000]
ParameterName=Mixed
ObjectType=0x9
SubNumber=2
[6000sub1]
ParameterName=a
DataType=0x0007
AccessType=rw
[6000sub2]
ParameterName=b
DataType=0x0005
AccessType=rw
[6001]
ParameterName=Flag
DataType=0x0001
AccessType=rw
DefaultValue=1
";
    let text = format!("{text}{LENZE}");
    let i = import(text.as_bytes(), &opts()).unwrap();
    assert_eq!(
        lints(&i),
        vec![
            "t.eds:8: 0x6000: subindexes 1, 2 differ in type, access, limits or default: each kept subindex is a code of its own (index 0x6000 + subindex) with the facts of its own section".to_string(),
            "t.eds:20: 0x6001: BOOLEAN kept as UNSIGNED8 (one byte, 0 or 1)".to_string(),
            lenze_lint(26),
        ]
    );
    // a record whose subindexes differ in type: each its own code
    assert_eq!(
        block(&i.toml, 0x100_0000 + 0x6000 * 256 + 1),
        "[[code]]\nnumber = 23068673\nindex = 0x6000\nsubindex = 1\nname = \"mixed_a\"\ntitle = \"Mixed: a\"\nspec = \"t.eds [6000sub1] line 12\"\ntype = \"UNSIGNED32\"\naccess = \"rw\""
    );
    assert_eq!(
        block(&i.toml, 0x100_0000 + 0x6000 * 256 + 2),
        "[[code]]\nnumber = 23068674\nindex = 0x6000\nsubindex = 2\nname = \"mixed_b\"\ntitle = \"Mixed: b\"\nspec = \"t.eds [6000sub2] line 16\"\ntype = \"UNSIGNED8\"\naccess = \"rw\""
    );
    assert_eq!(
        block(&i.toml, 5020),
        "[[code]]\nnumber = 5020\nname = \"setpoints\"\ntitle = \"Setpoints\"\nspec = \"t.eds [4C63] line 1\"\ntype = \"FIX32\"\nsubcodes = 3\ndefault = \"1\"\naccess = \"rw\""
    );
    assert_eq!(
        block(&i.toml, 0x1_6001),
        "[[code]]\nnumber = 90113\nindex = 0x6001\nname = \"flag\"\ntitle = \"Flag\"\nspec = \"t.eds [6001] line 20\"\ntype = \"UNSIGNED8\"\ndata_type = 0x0001\nmin = \"0\"\nmax = \"1\"\ndefault = \"1\"\naccess = \"rw\""
    );
}

#[test]
fn nothing_importable_and_not_an_eds_are_errors() {
    let e = import(b"[1400]\nParameterName=x\n", &opts()).unwrap_err();
    assert_eq!(e.message, "no object of the file could be imported");
    let e = import(b"hello\n", &opts()).unwrap_err();
    assert_eq!(
        e.message,
        "no object section ([1000], [5FF4], [1018sub1], ...): not a CiA 306 EDS / DCF"
    );
}

#[test]
fn builtin_ids_are_refused() {
    let o = ImportOptions {
        id: Some("lenze-ecs".into()),
        file: "t.eds".into(),
    };
    let e = import(MALFORMED.as_bytes(), &o).unwrap_err();
    assert_eq!(e.message, "schema id `lenze-ecs` is a built-in schema");
}

#[test]
fn default_ids() {
    assert_eq!(default_id("dir/ECS Axis_v1.2.eds"), "ecs-axis-v1-2");
    assert_eq!(default_id("x/.eds"), "imported-eds");
    assert_eq!(default_id("fictional-ecs-axis.eds"), "fictional-ecs-axis");
}

const FIXTURE: &[u8] = include_bytes!("../../../../../tests/data/eds/fictional-ecs-axis.eds");

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]
    /// Never panics on any input; an imported schema always passes
    /// `schema check` (import() checks it itself and errs otherwise).
    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..600)) {
        let _ = import(&bytes, &opts());
    }

    /// The vendor fixture with one line replaced by random text.
    #[test]
    fn mutated_fixture_never_fails_internally(line in 0usize..700, junk in "[ -~]{0,40}") {
        let text = String::from_utf8_lossy(FIXTURE);
        let mut lines: Vec<&str> = text.lines().collect();
        if line < lines.len() {
            lines[line] = &junk;
        }
        let joined = lines.join("\n");
        if let Err(e) = import(joined.as_bytes(), &opts()) {
            proptest::prop_assert!(!e.message.starts_with("internal error"), "{}", e.message);
        }
    }
}
