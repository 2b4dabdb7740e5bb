//! `driveset schema import FILE.eds|FILE.dcf` (CiA 306 -> Lenze ECS schema,
//! lint report, exit codes) and `driveset show --to dcf`: exact stdout,
//! stderr and exit codes; the imported schema through `schema check`,
//! `--schemas DIR`, by path, and CiA 301 objects addressed by name and
//! number.

use std::path::Path;

use driveset_test_support::driveset;

const AXIS: &str = "tests/data/eds/fictional-ecs-axis.eds";
const MALFORMED: &str = "tests/data/eds/fictional-malformed.eds";

fn run(args: &[&str]) -> (String, String, i32) {
    let out = driveset()
        .args(args)
        .env("NO_COLOR", "1")
        .output()
        .expect("runs");
    (
        String::from_utf8(out.stdout).expect("utf-8"),
        String::from_utf8(out.stderr).expect("utf-8"),
        out.status.code().expect("exit code"),
    )
}

/// The lint report on the vendor-style fixture, exactly.
const AXIS_LINTS: &str = "\
lint: tests/data/eds/fictional-ecs-axis.eds:25: VendorNumber 0x0000003B is Lenze's CiA vendor ID (0x3B): objects 0x38F0..0x5FFF are Lenze codes C9999..C0000 (code = 24575 - index, FIX32 value x 10000), 0x2000..0x38EF kept by index with their own types
lint: tests/data/eds/fictional-ecs-axis.eds:129: 0x1003sub0: number of entries is UNSIGNED8 (0x0005) writable; it is the structure, not a setting; skipped
lint: tests/data/eds/fictional-ecs-axis.eds:153: 0x1010: store parameters: sub 1 (save all parameters) kept as the store step, [schema.store] keeps = \"on-command\" with \"save\" = 0x65766173 (CiA 301); a set cannot write it
lint: tests/data/eds/fictional-ecs-axis.eds:179: 0x1014: DefaultValue `$NODEID+0x80` depends on the node id; left unset
lint: tests/data/eds/fictional-ecs-axis.eds:192: 0x1018: subindexes 1, 2, 3, 4 differ in type, access, limits or default: each kept subindex is a code of its own (index 0x1018 + subindex) with the facts of its own section
lint: tests/data/eds/fictional-ecs-axis.eds:237: 0x1200: SDO channel parameter: bus configuration ($NODEID COB-IDs), not a drive setting; skipped
lint: tests/data/eds/fictional-ecs-axis.eds:266: 0x1400: PDO communication / mapping parameter: configured by the CANopen master, not a drive setting; skipped
lint: tests/data/eds/fictional-ecs-axis.eds:295: 0x1600: PDO communication / mapping parameter: configured by the CANopen master, not a drive setting; skipped
lint: tests/data/eds/fictional-ecs-axis.eds:321: `; per mille of the rated current` after whitespace read as a comment, as python-canopen reads it (CiA 306 comments are whole lines); DefaultValue is `1500`
lint: tests/data/eds/fictional-ecs-axis.eds:357: `; 3000 rpm` after whitespace read as a comment, as python-canopen reads it (CiA 306 comments are whole lines); DefaultValue is `0x1c9c380`
lint: tests/data/eds/fictional-ecs-axis.eds:359: `; 16000 rpm` after whitespace read as a comment, as python-canopen reads it (CiA 306 comments are whole lines); HighLimit is `0X9896800`
lint: tests/data/eds/fictional-ecs-axis.eds:512: 0x4C63: subindexes 1, 2, 3 differ in type, access, limits or default: each kept subindex is a code of its own (index 0x4C63 + subindex) with the facts of its own section
lint: tests/data/eds/fictional-ecs-axis.eds:550: `; -500 rpm` after whitespace read as a comment, as python-canopen reads it (CiA 306 comments are whole lines); DefaultValue is `-5000000`
lint: tests/data/eds/fictional-ecs-axis.eds:563: 0x4C4F: DataType UNSIGNED16 (0x0006) in the Lenze code range: page 454 transmits Lenze codes as FIX32 (4 bytes); skipped
lint: tests/data/eds/fictional-ecs-axis.eds:571: 0x4C45: DOMAIN object (no fixed size or type); skipped
lint: tests/data/eds/fictional-ecs-axis.eds:582: 0x4C3B: write-only (wo): driveset reads back every value it writes; skipped
lint: tests/data/eds/fictional-ecs-axis.eds:586: 0x4C31: DataType UNSIGNED32 (0x0007) read as FIX32 (page 454: Lenze codes are FIX32, value x 10000)
lint: tests/data/eds/fictional-ecs-axis.eds:599: 0x4C27: ObjFlags bit 0 (refuse write on download): kept read-only
imported tests/data/eds/fictional-ecs-axis.eds: schema fictional-ecs-axis, 25 Lenze codes, 13 objects by index, 18 lints
";

#[test]
fn vendor_style_eds_imports_with_the_exact_lint_list() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("schemas/fictional-ecs-axis.toml");
    let out_arg = out.to_string_lossy().into_owned();
    let (stdout, stderr, code) = run(&["schema", "import", AXIS, "-o", &out_arg]);
    assert_eq!(
        (stdout.as_str(), stderr.as_str(), code),
        ("", AXIS_LINTS, 1)
    );
    let toml = std::fs::read_to_string(&out).expect("written");
    assert_eq!(toml.matches("[[code]]").count(), 38);
    assert!(
        toml.contains(
            "[[code]]\nnumber = 5001\nname = \"max_speed\"\ntitle = \"Max. speed\"\nspec = \"fictional-ecs-axis.eds [4C76] line 352\"\ntype = \"FIX32\"\nmin = \"0\"\nmax = \"16000\"\ndefault = \"3000\"\naccess = \"rw\"\n"
        ),
        "{toml}"
    );
    assert!(
        toml.contains(
            "[[code]]\nnumber = 69655\nindex = 0x1017\nname = \"producer_heartbeat_time\"\n"
        ),
        "{toml}"
    );
    // the same schema on stdout without -o
    let (stdout, stderr, code) = run(&["schema", "import", AXIS]);
    assert_eq!(
        (stdout.as_str(), stderr.as_str(), code),
        (toml.as_str(), AXIS_LINTS, 1)
    );

    // it passes schema check, by path and with --schemas DIR
    let (stdout, _, code) = run(&["schema", "check", &out_arg]);
    assert_eq!(
        (stdout.as_str(), code),
        ("0 findings in 0 of 1 schema file\n", 0)
    );
    let set = dir.path().join("axis.toml");
    std::fs::write(
        &set,
        "schema = \"fictional-ecs-axis\"\n[values]\nmax_speed = 4500\n\"C5020/2\" = -250.5\nproducer_heartbeat_time = 100\nC90227 = 2000\n",
    )
    .expect("write set");
    let set_arg = set.to_string_lossy().into_owned();
    let schemas = dir.path().join("schemas").to_string_lossy().into_owned();
    let (stdout, stderr, code) = run(&["show", &set_arg, "--schemas", &schemas]);
    assert_eq!(
        (stdout.as_str(), stderr.as_str(), code),
        (
            // C5020's subindexes differ in their defaults: each is a code of
            // its own (16777216 + 0x4C63 x 256 + 2); `C5020/2` names it
            "driveset-canonical 1\nschema fictional-ecs-axis\nC5001 45000000\nC69655 100\nC90227 2000\nC21783298 -2505000\n",
            "",
            0
        )
    );
    // a read-only CiA 301 object cannot be set; out of its UNSIGNED16 range neither
    std::fs::write(
        &set,
        "schema = \"schemas/fictional-ecs-axis.toml\"\n[values]\ndevice_type = 1\nproducer_heartbeat_time = 70000\n",
    )
    .expect("write set");
    let (stdout, _, code) = run(&["validate", &set_arg, "--format", "json"]);
    assert_eq!(code, 1, "{stdout}");
    let doc: serde_json::Value = serde_json::from_str(&stdout).expect("json");
    let kinds: Vec<&str> = doc["files"][0]["findings"]
        .as_array()
        .expect("findings")
        .iter()
        .map(|f| f["kind"].as_str().expect("kind"))
        .collect();
    assert_eq!(kinds, ["read-only", "out-of-range"], "{stdout}");
}

#[test]
fn json_lint_report() {
    // (not `-o /dev/null`: driveset writes regular files only, issue 29)
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("axis.toml");
    let (stdout, stderr, code) = run(&[
        "schema",
        "import",
        AXIS,
        "--format",
        "json",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!((stdout.as_str(), code), ("", 1));
    let doc: serde_json::Value = serde_json::from_str(&stderr).expect("json");
    assert_eq!(doc["schema"], "fictional-ecs-axis");
    assert_eq!(doc["lenze_codes"], 25);
    assert_eq!(doc["cia_objects"], 13);
    let lints = doc["lints"].as_array().expect("lints");
    assert_eq!(lints.len(), 18);
    assert_eq!(
        lints[7],
        serde_json::json!({"line": 295, "object": "0x1600", "message": "PDO communication / mapping parameter: configured by the CANopen master, not a drive setting; skipped"})
    );
}

#[test]
fn malformed_files_python_canopen_users_report() {
    let (stdout, stderr, code) = run(&["schema", "import", MALFORMED, "--id", "ecs-malformed"]);
    assert_eq!(code, 1);
    assert_eq!(
        stderr,
        "\
lint: tests/data/eds/fictional-malformed.eds: not a Lenze data sheet (VendorNumber not given, VendorName not given): manufacturer objects 0x2000..0x5FFF kept by index with their own CiA types (no x 10000 scaling)
lint: tests/data/eds/fictional-malformed.eds:12: key HighLimit given twice in [5FF4] (first at line 11); the first value is kept
lint: tests/data/eds/fictional-malformed.eds:15: 0x1200sub1: no main section [1200]; skipped
lint: tests/data/eds/fictional-malformed.eds:26: 0x1014: DefaultValue `0x80+$NODEID` depends on the node id; left unset
lint: tests/data/eds/fictional-malformed.eds:33: 0x5FF5: DefaultValue `010` read as decimal 10 (a leading 0 means octal in C, giving 8)
lint: tests/data/eds/fictional-malformed.eds:34: 0x5FF5: empty LowLimit; left unset
lint: tests/data/eds/fictional-malformed.eds:35: 0x5FF5: HighLimit `00100000` read as decimal 100000 (a leading 0 means octal in C, giving 32768)
imported tests/data/eds/fictional-malformed.eds: schema ecs-malformed, 0 Lenze codes, 3 objects by index, 7 lints
"
    );
    assert!(
        // no vendor said: 0x5FF4 is no Lenze code C0011 (FIX32) but an
        // INTEGER32 of its own, unscaled
        stdout.contains("[[code]]\nnumber = 90100\nindex = 0x5FF4\nname = \"max_speed\"\ntitle = \"Max speed\"\nspec = \"fictional-malformed.eds [5FF4] line 4\"\ntype = \"INTEGER32\"\nmin = \"0\"\nmax = \"26\"\ndefault = \"1\"\naccess = \"rw\"\n"),
        "{stdout}"
    );
}

#[test]
fn unreadable_and_invalid_files_exit_2_with_the_location() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (stdout, stderr, code) = run(&["schema", "import", "tests/data/eds/missing.eds"]);
    assert_eq!(code, 2);
    assert_eq!(stdout, "");
    assert!(
        stderr.starts_with("error: cannot read tests/data/eds/missing.eds: "),
        "{stderr}"
    );
    let bin = dir.path().join("x.eds");
    std::fs::write(&bin, b"[1000]\nDataType=0x0007\nab\0cd\n").expect("write");
    let bin_arg = bin.to_string_lossy().into_owned();
    let (stdout, stderr, code) = run(&["schema", "import", &bin_arg]);
    assert_eq!(
        (stdout.as_str(), stderr, code),
        (
            "",
            format!(
                "error: {bin_arg}:3:3: NUL byte: this is a binary file, not a CiA 306 EDS / DCF\n  = help: give the .eds or .dcf text file shipped with the device\n"
            ),
            2
        )
    );
    let (_, stderr, code) = run(&["schema", "import", "schemas/lenze-ecs.toml"]);
    assert_eq!(
        (stderr.as_str(), code),
        (
            "error: schemas/lenze-ecs.toml: no object section ([1000], [5FF4], [1018sub1], ...): not a CiA 306 EDS / DCF\n  = help: give the .eds or .dcf file shipped with the device\n",
            2
        )
    );
}

#[test]
fn show_to_dcf_writes_the_values_and_refuses_other_families() {
    let dir = tempfile::tempdir().expect("tempdir");
    let schema = dir.path().join("fictional-ecs-axis.toml");
    let schema_arg = schema.to_string_lossy().into_owned();
    let (_, _, code) = run(&["schema", "import", AXIS, "-o", &schema_arg]);
    assert_eq!(code, 1);
    let set = dir.path().join("axis-7.toml");
    std::fs::write(
        &set,
        "schema = \"fictional-ecs-axis.toml\"\ntitle = \"Axis 7\"\n[values]\nmax_speed = 4500\n\"C5020/2\" = -250.5\nC5030 = \"AXIS9\"\nproducer_heartbeat_time = 100\n",
    )
    .expect("write set");
    let set_arg = set.to_string_lossy().into_owned();
    let (stdout, stderr, code) = run(&["show", "--to", "dcf", "--node-id", "7", &set_arg]);
    assert_eq!((stderr.as_str(), code), ("", 0));
    assert_eq!(
        stdout,
        "\
; Device configuration file (CiA 306) written by `driveset show --to dcf`
; from a set of schema fictional-ecs-axis. ParameterValue is the set's raw value: FIX32 codes
; value x 10000, C0135 / C0150 bit-coded (lenze-system-bus-can-sdo.txt, p. 454).

[FileInfo]
FileName=axis-7.dcf
FileVersion=1
FileRevision=0
EDSVersion=4.0
Description=Axis 7
CreatedBy=driveset

[DeviceInfo]
VendorName=Lenze
VendorNumber=0x0000003B
ProductName=FICTIONAL: FICTIONAL Lenze-style vendor ECS-style axis, imported from fictional-ecs-axis.eds
ProductNumber=0x00000001
RevisionNumber=0x00010000
OrderCode=
; bit rates, PDOs, granularity, LSS: not in the schema, so 0 (not claimed); the data sheet says them
BaudRate_10=0
BaudRate_20=0
BaudRate_50=0
BaudRate_125=0
BaudRate_250=0
BaudRate_500=0
BaudRate_800=0
BaudRate_1000=0
SimpleBootUpMaster=0
SimpleBootUpSlave=0
Granularity=0
DynamicChannelsSupported=0
GroupMessaging=0
NrOfRXPDO=0
NrOfTXPDO=0
LSS_Supported=0

[DeviceComissioning]
NodeID=0x07
NodeName=Axis 7

[MandatoryObjects]
SupportedObjects=3
1=0x1000
2=0x1001
3=0x1018

[OptionalObjects]
SupportedObjects=1
1=0x1017

[ManufacturerObjects]
SupportedObjects=3
1=0x4C59
2=0x4C63
3=0x4C76

[1000]
ParameterName=Device type
ObjectType=0x7
DataType=0x0007
AccessType=ro
DefaultValue=131474
PDOMapping=0

[1001]
ParameterName=Error register
ObjectType=0x7
DataType=0x0005
AccessType=ro
DefaultValue=0
PDOMapping=0

[1017]
ParameterName=Producer heartbeat time
ObjectType=0x7
DataType=0x0006
AccessType=rw
DefaultValue=0
LowLimit=0
HighLimit=65535
PDOMapping=0
ParameterValue=100

[1018]
ParameterName=Identity object
ObjectType=0x9
SubNumber=5

[1018sub0]
ParameterName=Highest sub-index supported
ObjectType=0x7
DataType=0x0005
AccessType=ro
DefaultValue=4
PDOMapping=0

[1018sub1]
ParameterName=Vendor-ID
ObjectType=0x7
DataType=0x0007
AccessType=ro
DefaultValue=59
PDOMapping=0

[1018sub2]
ParameterName=Product code
ObjectType=0x7
DataType=0x0007
AccessType=ro
DefaultValue=1
PDOMapping=0

[1018sub3]
ParameterName=Revision number
ObjectType=0x7
DataType=0x0007
AccessType=ro
DefaultValue=65536
PDOMapping=0

[1018sub4]
ParameterName=Serial number
ObjectType=0x7
DataType=0x0007
AccessType=ro
DefaultValue=42
PDOMapping=0

[4C59]
ParameterName=Axis name
ObjectType=0x7
DataType=0x0009
AccessType=rw
DefaultValue=AXIS1
PDOMapping=0
ParameterValue=AXIS9

[4C63]
ParameterName=Fixed speed setpoints
ObjectType=0x8
SubNumber=2

[4C63sub0]
ParameterName=Highest sub-index supported
ObjectType=0x7
DataType=0x0005
AccessType=ro
DefaultValue=3
PDOMapping=0

[4C63sub2]
ParameterName=Fixed speed 2
ObjectType=0x7
DataType=0x0004
AccessType=rw
DefaultValue=10000000
LowLimit=-160000000
HighLimit=160000000
PDOMapping=0
ParameterValue=-2505000

[4C76]
ParameterName=Max. speed
ObjectType=0x7
DataType=0x0004
AccessType=rw
DefaultValue=30000000
LowLimit=0
HighLimit=160000000
PDOMapping=0
ParameterValue=45000000
"
    );
    // the DCF imports back: same codes, its ParameterValues named in one lint
    let dcf = dir.path().join("axis-7.dcf");
    std::fs::write(&dcf, &stdout).expect("write dcf");
    let dcf_arg = dcf.to_string_lossy().into_owned();
    let (back, stderr, code) = run(&["schema", "import", &dcf_arg, "--id", "axis-7-dcf"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.starts_with(&format!("lint: {dcf_arg}: 4 ParameterValue entries ignored: a schema holds defaults and limits, not a configuration\n")),
        "{stderr}"
    );
    assert!(
        back.contains("number = 5001\nname = \"max_speed\""),
        "{back}"
    );

    // an ECS set of the fictional demo schema too
    let (stdout, _, code) = run(&["show", "--to", "dcf", "parameter-sets/ecs/axis-1.toml"]);
    assert_eq!(code, 0);
    assert!(
        stdout.contains("\n[4C76]\nParameterName=Maximum speed (fictional)\nObjectType=0x7\nDataType=0x0004\nAccessType=rw\nDefaultValue=30000000\nLowLimit=0\nHighLimit=160000000\nPDOMapping=0\nParameterValue=45000000\n"),
        "{stdout}"
    );

    // other families are refused
    let (stdout, stderr, code) =
        run(&["show", "--to", "dcf", "parameter-sets/tmd/conveyor-3.toml"]);
    assert_eq!(
        (stdout.as_str(), stderr.as_str(), code),
        (
            "",
            "error: parameter-sets/tmd/conveyor-3.toml: cannot write a DCF: set uses schema `lenze-tmd`, which is not a CANopen (lenze-can-sdo) family; a DCF describes CANopen SDO objects\n  = help: write a DCF from a Lenze ECS set (schema lenze-ecs or one made by `driveset schema import`); use --to toml|yaml|json for other families\n",
            2
        )
    );
    let _ = Path::new(AXIS);
}
