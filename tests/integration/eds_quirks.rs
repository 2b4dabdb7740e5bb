//! The EDS quirk corpus (tests/data/eds/quirks/, one small FICTIONAL data
//! sheet per quirk vendor files carry): `driveset schema import` of each,
//! object by object against what a CiA 306 reader says (exact lints and
//! code blocks here; python-canopen's own reading of the same files in
//! `python_canopen_reads_what_the_importer_imported`), and every DCF
//! `driveset show --to dcf` writes from them through a strict CiA 306
//! reading and python-canopen's importer (tests/python/dcf_check.py).
//!
//! CiA 402 roles: `cia402_objects_keep_their_profile_identity` checks the
//! facts the ECS role floor (docs/safety) applies to (index, number, CiA
//! type); the role assertions themselves belong with that floor.

use std::path::Path;

use driveset_test_support::{driveset, python_or_skip, workspace_root};

const Q: &str = "tests/data/eds/quirks";

/// `schema import FILE -o DIR/NAME.toml`: (schema text, stderr, exit code).
fn import(dir: &Path, name: &str) -> (String, String, i32) {
    let out = dir.join(format!("{name}.toml"));
    let o = driveset()
        .args(["schema", "import", &format!("{Q}/{name}.eds"), "-o"])
        .arg(&out)
        .env("NO_COLOR", "1")
        .output()
        .expect("runs");
    (
        std::fs::read_to_string(&out).unwrap_or_default(),
        String::from_utf8(o.stderr).expect("utf-8"),
        o.status.code().expect("exit code"),
    )
}

/// The `[[code]]` block of `number`.
fn block(toml: &str, number: u32) -> String {
    let start = toml
        .find(&format!("[[code]]\nnumber = {number}\n"))
        .unwrap_or_else(|| panic!("no code {number} in\n{toml}"));
    let rest = &toml[start..];
    let end = rest[1..].find("\n[[code]]").map_or(rest.len(), |e| e + 1);
    rest[..end].trim_end().to_string()
}

/// `validate --format json` of a set written to DIR/set.toml: exit code and
/// the findings as (kind, message).
fn validate(dir: &Path, set_text: &str) -> (i32, Vec<(String, String)>) {
    let set = dir.join("set.toml");
    std::fs::write(&set, set_text).expect("write set");
    let o = driveset()
        .args(["validate", "--format", "json"])
        .arg(&set)
        .output()
        .expect("validate");
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let findings = doc["files"][0]["findings"]
        .as_array()
        .expect("findings")
        .iter()
        .map(|f| {
            (
                f["kind"].as_str().expect("kind").to_string(),
                f["message"].as_str().expect("message").to_string(),
            )
        })
        .collect();
    (o.status.code().expect("exit code"), findings)
}

fn codes(toml: &str) -> usize {
    toml.matches("[[code]]").count()
}

fn lenze_lint(name: &str, line: usize, number: &str) -> String {
    format!(
        "lint: {Q}/{name}.eds:{line}: VendorNumber {number} is Lenze's CiA vendor ID (0x3B): objects 0x38F0..0x5FFF are Lenze codes C9999..C0000 (code = 24575 - index, FIX32 value x 10000), 0x2000..0x38EF kept by index with their own types\n"
    )
}

#[test]
fn a_record_is_never_filled_from_its_neighbours() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (toml, stderr, code) = import(dir.path(), "record-dropped-subs");
    assert_eq!(
        (stderr.as_str(), code),
        (
            format!(
                "{}lint: {Q}/record-dropped-subs.eds:29: 0x5FE0sub2: DataType UNSIGNED16 (0x0006) in the Lenze code range: page 454 transmits Lenze codes as FIX32 (4 bytes); skipped\n\
                 lint: {Q}/record-dropped-subs.eds:43: 0x5FE0sub3: ObjFlags bit 1 (refuse read on scan): driveset reads every code it holds; skipped\n\
                 imported {Q}/record-dropped-subs.eds: schema record-dropped-subs, 1 Lenze codes, 0 objects by index, 3 lints\n",
                lenze_lint("record-dropped-subs", 6, "0x0000003B")
            )
            .as_str(),
            1
        )
    );
    // sub 1 keeps its own facts; subcodes = 1: the dropped UNSIGNED16
    // "block torque" (sub 2) and sub 3 cannot be named, nor get sub 1's type
    assert_eq!(codes(&toml), 1);
    assert_eq!(
        block(&toml, 31),
        "[[code]]\nnumber = 31\nname = \"block_detection\"\ntitle = \"Block detection\"\nspec = \"record-dropped-subs.eds [5FE0] line 8\"\ntype = \"FIX32\"\nsubcodes = 1\nmin = \"0\"\nmax = \"10\"\ndefault = \"0.5\"\naccess = \"rw\""
    );
    let (code, findings) = validate(
        dir.path(),
        "schema = \"record-dropped-subs.toml\"\n[values]\n\"C0031/1\" = 2\n\"C0031/2\" = 500\n",
    );
    assert_eq!(
        (code, findings),
        (
            1,
            vec![(
                "unknown-code".to_string(),
                "C0031 has subcodes 1..=1; `C0031/2` names none of them".to_string()
            )]
        )
    );
}

#[test]
fn per_subindex_defaults_and_limits_are_kept_per_subindex() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (toml, stderr, code) = import(dir.path(), "per-subindex-values");
    assert_eq!(
        (stderr.as_str(), code),
        (
            format!(
                "{}lint: {Q}/per-subindex-values.eds:7: 0x1018: subindexes 1, 2, 3 differ in type, access, limits or default: each kept subindex is a code of its own (index 0x1018 + subindex) with the facts of its own section\n\
                 lint: {Q}/per-subindex-values.eds:40: 0x5FD8: subindexes 1, 2 differ in type, access, limits or default: each kept subindex is a code of its own (index 0x5FD8 + subindex) with the facts of its own section\n\
                 imported {Q}/per-subindex-values.eds: schema per-subindex-values, 3 Lenze codes, 3 objects by index, 3 lints\n",
                lenze_lint("per-subindex-values", 5, "0x0000003B")
            )
            .as_str(),
            1
        )
    );
    assert_eq!(codes(&toml), 6);
    // 0x1018: each subindex its own code with its own default
    let id = |index: u32, sub: u32| 0x100_0000 + index * 256 + sub;
    for (sub, name, title, default) in [
        (1, "vendor_id", "Vendor-ID", "59"),
        (2, "product_code", "Product code", "16"),
        (3, "revision_number", "Revision number", "131073"),
    ] {
        assert_eq!(
            block(&toml, id(0x1018, sub)),
            format!(
                "[[code]]\nnumber = {}\nindex = 0x1018\nsubindex = {sub}\nname = \"identity_object_{name}\"\ntitle = \"Identity object: {title}\"\nspec = \"per-subindex-values.eds [1018sub{sub}] line {}\"\ntype = \"UNSIGNED32\"\ndefault = \"{default}\"\naccess = \"ro\"",
                id(0x1018, sub),
                [0, 19, 26, 33][sub as usize]
            )
        );
    }
    // a Lenze ARRAY with limits and defaults per subindex: C0039/1, C0039/2
    assert_eq!(
        block(&toml, id(0x5FD8, 1)),
        "[[code]]\nnumber = 23058433\nindex = 0x5FD8\nsubindex = 1\nname = \"fixed_speeds_jog_1\"\ntitle = \"Fixed speeds: JOG 1\"\nspec = \"per-subindex-values.eds [5FD8sub1] line 52\"\ntype = \"FIX32\"\nmin = \"0\"\nmax = \"100\"\ndefault = \"20\"\naccess = \"rw\""
    );
    assert_eq!(
        block(&toml, id(0x5FD8, 2)),
        "[[code]]\nnumber = 23058434\nindex = 0x5FD8\nsubindex = 2\nname = \"fixed_speeds_jog_2\"\ntitle = \"Fixed speeds: JOG 2\"\nspec = \"per-subindex-values.eds [5FD8sub2] line 61\"\ntype = \"FIX32\"\nmin = \"-100\"\nmax = \"0\"\ndefault = \"-20\"\naccess = \"rw\""
    );
    // an ARRAY whose subindexes agree stays one code with subcodes
    assert_eq!(
        block(&toml, 59),
        "[[code]]\nnumber = 59\nname = \"analog_gains\"\ntitle = \"Analog gains\"\nspec = \"per-subindex-values.eds [5FC4] line 70\"\ntype = \"FIX32\"\nsubcodes = 2\nmin = \"0\"\nmax = \"10\"\ndefault = \"1\"\naccess = \"rw\""
    );
    // C0039/2 names the subindex code; its own limits apply (JOG 2 is
    // -100..0, JOG 1 0..100)
    let (code, findings) = validate(
        dir.path(),
        "schema = \"per-subindex-values.toml\"\n[values]\n\"C0039/1\" = 50\n\"C0039/2\" = 50\n",
    );
    let kinds: Vec<&str> = findings.iter().map(|f| f.0.as_str()).collect();
    assert_eq!((code, kinds), (1, vec!["out-of-range"]), "{findings:?}");
}

#[test]
fn lenze_codes_only_from_a_lenze_data_sheet() {
    let dir = tempfile::tempdir().expect("tempdir");
    // another vendor: own CiA types, no x 10000
    let (toml, stderr, code) = import(dir.path(), "other-vendor");
    assert_eq!(
        (stderr.as_str(), code),
        (
            format!(
                "lint: {Q}/other-vendor.eds:5: not a Lenze data sheet (VendorNumber 0x000000AB, VendorName `FICTIONAL Other Drives`): manufacturer objects 0x2000..0x5FFF kept by index with their own CiA types (no x 10000 scaling)\n\
                 imported {Q}/other-vendor.eds: schema other-vendor, 0 Lenze codes, 2 objects by index, 1 lints\n"
            )
            .as_str(),
            1
        )
    );
    assert_eq!(
        block(&toml, 0x1_2000),
        "[[code]]\nnumber = 73728\nindex = 0x2000\nname = \"block_torque\"\ntitle = \"Block torque\"\nspec = \"other-vendor.eds [2000] line 7\"\ntype = \"UNSIGNED16\"\nmin = \"0\"\nmax = \"1000\"\ndefault = \"800\"\naccess = \"rw\""
    );
    assert_eq!(
        block(&toml, 0x1_5FF4),
        "[[code]]\nnumber = 90100\nindex = 0x5FF4\nname = \"ramp_time\"\ntitle = \"Ramp time\"\nspec = \"other-vendor.eds [5FF4] line 16\"\ntype = \"INTEGER32\"\nmin = \"-100\"\nmax = \"100000\"\ndefault = \"2500\"\naccess = \"rw\""
    );
    assert!(!toml.contains("type = \"FIX32\""), "{toml}");
    // Lenze by VendorName; 0x3000 would be C12287: kept by index, no C10000+
    let (toml, stderr, code) = import(dir.path(), "lenze-by-name");
    assert_eq!(
        (stderr.as_str(), code),
        (
            format!(
                "lint: {Q}/lenze-by-name.eds:4: VendorName `Lenze (FICTIONAL fixture)` names Lenze (no VendorNumber to tell): objects 0x38F0..0x5FFF are Lenze codes C9999..C0000 (code = 24575 - index, FIX32 value x 10000), 0x2000..0x38EF kept by index with their own types\n\
                 imported {Q}/lenze-by-name.eds: schema lenze-by-name, 1 Lenze codes, 1 objects by index, 1 lints\n"
            )
            .as_str(),
            1
        )
    );
    assert_eq!(
        block(&toml, 11),
        "[[code]]\nnumber = 11\nname = \"ramp_time\"\ntitle = \"Ramp time\"\nspec = \"lenze-by-name.eds [5FF4] line 6\"\ntype = \"FIX32\"\ndefault = \"2.5\"\naccess = \"rw\""
    );
    assert_eq!(
        block(&toml, 0x1_3000),
        "[[code]]\nnumber = 77824\nindex = 0x3000\nname = \"extension_value\"\ntitle = \"Extension value\"\nspec = \"lenze-by-name.eds [3000] line 13\"\ntype = \"INTEGER32\"\ndefault = \"7\"\naccess = \"rw\""
    );
    assert!(!toml.contains("number = 12287"), "{toml}");
}

#[test]
fn cia402_objects_keep_their_profile_identity() {
    // The family's role floor (0x6040 control word, 0x6060 mode, 0x607A /
    // 0x60FF / 0x6071 targets) finds these by index and number; the role
    // assertions belong with that floor (issue 17).
    let dir = tempfile::tempdir().expect("tempdir");
    let (toml, stderr, code) = import(dir.path(), "cia402");
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.ends_with("schema cia402, 0 Lenze codes, 5 objects by index, 1 lints\n"),
        "{stderr}"
    );
    for (index, line, name, title, ty, default) in [
        (
            0x6040,
            7,
            "controlword",
            "Controlword",
            "UNSIGNED16",
            Some("0"),
        ),
        (
            0x6060,
            14,
            "modes_of_operation",
            "Modes of operation",
            "INTEGER8",
            Some("0"),
        ),
        (
            0x6071,
            33,
            "target_torque",
            "Target torque",
            "INTEGER16",
            None,
        ),
        (
            0x607A,
            21,
            "target_position",
            "Target position",
            "INTEGER32",
            None,
        ),
        (
            0x60FF,
            27,
            "target_velocity",
            "Target velocity",
            "INTEGER32",
            None,
        ),
    ] {
        let default = default.map_or(String::new(), |d| format!("default = \"{d}\"\n"));
        assert_eq!(
            block(&toml, 0x1_0000 + index),
            format!(
                "[[code]]\nnumber = {}\nindex = 0x{index:04X}\nname = \"{name}\"\ntitle = \"{title}\"\nspec = \"cia402.eds [{index:04X}] line {line}\"\ntype = \"{ty}\"\n{default}access = \"rw\"",
                0x1_0000 + index
            )
        );
    }
}

#[test]
fn semicolons_end_a_value_only_after_whitespace() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (toml, stderr, code) = import(dir.path(), "semicolons");
    assert_eq!(
        (stderr.as_str(), code),
        (
            format!(
                "{}lint: {Q}/semicolons.eds:11: `; 5.0000` after whitespace read as a comment, as python-canopen reads it (CiA 306 comments are whole lines); DefaultValue is `50000`\n\
                 lint: {Q}/semicolons.eds:12: line starts with `#`: CiA 306 comments start with `;`; read as a comment, as python-canopen does\n\
                 lint: {Q}/semicolons.eds:13: `;tab before` after whitespace read as a comment, as python-canopen reads it (CiA 306 comments are whole lines); HighLimit is `1000000`\n\
                 imported {Q}/semicolons.eds: schema semicolons, 2 Lenze codes, 0 objects by index, 4 lints\n",
                lenze_lint("semicolons", 4, "0x3B")
            )
            .as_str(),
            1
        )
    );
    assert_eq!(
        block(&toml, 16),
        "[[code]]\nnumber = 16\nname = \"c0016_block_detection_torque_and_time\"\ntitle = \"C0016 Block detection; torque and time\"\nspec = \"semicolons.eds [5FEF] line 6\"\ntype = \"FIX32\"\nmax = \"100\"\ndefault = \"5\"\naccess = \"rw\""
    );
    assert_eq!(
        block(&toml, 17),
        "[[code]]\nnumber = 17\nname = \"name_with_semicolons\"\ntitle = \"Name;with;semicolons\"\nspec = \"semicolons.eds [5FEE] line 15\"\ntype = \"VS\"\ndefault = \"A;B\"\naccess = \"rw\""
    );
}

#[test]
fn encodings_line_ends_and_bad_names() {
    let dir = tempfile::tempdir().expect("tempdir");
    let ramp = |file: &str, line: usize, title: &str| {
        format!(
            "[[code]]\nnumber = 11\nname = \"{}\"\ntitle = \"{title}\"\nspec = \"{file}.eds [5FF4] line {line}\"\ntype = \"FIX32\"\ndefault = \"2.5\"\naccess = \"rw\"",
            if title == "Ramp time" {
                "ramp_time"
            } else {
                "hochlaufzeit_ueber_rampe"
            }
        )
    };
    // CR-only line ends
    let (toml, stderr, code) = import(dir.path(), "cr-only");
    assert_eq!(code, 1, "{stderr}");
    assert_eq!(block(&toml, 11), ramp("cr-only", 5, "Ramp time"));
    // UTF-16 LE with a byte order mark
    let (toml, stderr, code) = import(dir.path(), "utf16le-bom");
    assert_eq!(code, 1, "{stderr}");
    assert_eq!(
        block(&toml, 11),
        ramp("utf16le-bom", 5, "Hochlaufzeit \u{fc}ber Rampe")
    );
    // without one: refused with where and what to do
    let (toml, stderr, code) = import(dir.path(), "utf16le-no-bom");
    assert_eq!(
        (toml.as_str(), stderr.as_str(), code),
        (
            "",
            format!("error: {Q}/utf16le-no-bom.eds:1:2: UTF-16 LE text without a byte order mark\n  = help: save the data sheet as UTF-8, or as UTF-16 with a byte order mark\n").as_str(),
            2
        )
    );
    // unparsable SubNumber, object-shaped names out of range
    let (toml, stderr, code) = import(dir.path(), "bad-names");
    assert_eq!(
        (stderr.as_str(), code),
        (
            format!(
                "{}lint: {Q}/bad-names.eds:9: 0x5FE0: SubNumber `two` is not a number of entries (0..255); the 2 [5FE0subN] sections are used\n\
                 lint: {Q}/bad-names.eds:21: section [10000] is shaped like an object but its index has more than 4 hex digits (CiA 306 §4.6: [IIII] or [IIIIsubS], IIII 4 hex digits, S 0..FF); its entries are ignored\n\
                 lint: {Q}/bad-names.eds:26: section [5FF4sub100] is shaped like an object but its subindex is above FF (CiA 306 §4.6: [IIII] or [IIIIsubS], IIII 4 hex digits, S 0..FF); its entries are ignored\n\
                 imported {Q}/bad-names.eds: schema bad-names, 1 Lenze codes, 0 objects by index, 4 lints\n",
                lenze_lint("bad-names", 4, "0x0000003B")
            )
            .as_str(),
            1
        )
    );
    assert_eq!(codes(&toml), 1);
    assert!(toml.contains("number = 31\n"), "{toml}");
}

/// The corpus files python-canopen can open (not UTF-16, which it reads in
/// the locale's encoding; not bad-names, whose `[5FF4sub100]` without
/// `[5FF4]` makes its importer raise KeyError), with the vendor fixture.
const CANOPEN_READABLE: [&str; 7] = [
    "record-dropped-subs",
    "per-subindex-values",
    "other-vendor",
    "lenze-by-name",
    "cia402",
    "semicolons",
    "cr-only",
];

#[test]
fn python_canopen_reads_what_the_importer_imported() {
    let Some(python) = python_or_skip("canopen EDS comparison") else {
        return;
    };
    let dir = tempfile::tempdir().expect("tempdir");
    let script = workspace_root().join("tests/python/eds_compare.py");
    let mut files: Vec<(String, std::path::PathBuf)> = Vec::new();
    for name in CANOPEN_READABLE {
        let (_, stderr, code) = import(dir.path(), name);
        assert_eq!(code, 1, "{stderr}");
        files.push((
            format!("{Q}/{name}.eds"),
            dir.path().join(format!("{name}.toml")),
        ));
    }
    let axis = dir.path().join("fictional-ecs-axis.toml");
    let o = driveset()
        .args([
            "schema",
            "import",
            "tests/data/eds/fictional-ecs-axis.eds",
            "-o",
        ])
        .arg(&axis)
        .output()
        .expect("import");
    assert_eq!(o.status.code(), Some(1));
    files.push(("tests/data/eds/fictional-ecs-axis.eds".into(), axis));
    let mut agreed = Vec::new();
    for (eds, schema) in &files {
        let o = std::process::Command::new(&python)
            .arg(&script)
            .arg(workspace_root().join(eds))
            .arg(schema)
            .output()
            .expect("python");
        let out = String::from_utf8_lossy(&o.stdout).into_owned();
        assert_eq!(
            o.status.code(),
            Some(0),
            "{eds}\n{out}{}",
            String::from_utf8_lossy(&o.stderr)
        );
        agreed.push(out.lines().last().unwrap_or("").to_string());
    }
    assert_eq!(
        agreed,
        [
            "1 variables agree",
            "7 variables agree",
            "2 variables agree",
            "2 variables agree",
            "5 variables agree",
            "2 variables agree",
            "1 variables agree",
            "38 variables agree",
        ]
    );
}

#[test]
fn every_dcf_driveset_writes_passes_a_strict_reading_and_python_canopen() {
    let python = python_or_skip("canopen DCF check");
    let dir = tempfile::tempdir().expect("tempdir");
    let mut sets: Vec<(String, std::path::PathBuf)> = Vec::new();
    let mut add = |name: &str, values: &str| {
        let (_, stderr, code) = import(dir.path(), name);
        assert_eq!(code, 1, "{stderr}");
        let set = dir.path().join(format!("{name}-set.toml"));
        std::fs::write(
            &set,
            format!("schema = \"{name}.toml\"\n[values]\n{values}"),
        )
        .expect("write");
        sets.push((name.to_string(), set));
    };
    add("record-dropped-subs", "\"C0031/1\" = 2\n");
    add("per-subindex-values", "\"C0039/1\" = 50\n\"C0059/2\" = 3\n");
    add("other-vendor", "block_torque = 500\nramp_time = 3000\n");
    add("lenze-by-name", "ramp_time = 3\nextension_value = 9\n");
    add("cia402", "");
    add(
        "semicolons",
        "name_with_semicolons = \"X;Y\"\nc0016_block_detection_torque_and_time = 7.5\n",
    );
    add("cr-only", "ramp_time = 1\n");
    add("utf16le-bom", "hochlaufzeit_ueber_rampe = 1\n");
    add("bad-names", "\"C0031/2\" = 4\n");
    sets.push((
        "lenze-ecs".into(),
        workspace_root().join("parameter-sets/ecs/axis-1.toml"),
    ));
    let mut dcfs = Vec::new();
    for (name, set) in &sets {
        let o = driveset()
            .args(["show", "--to", "dcf", "--node-id", "5"])
            .arg(set)
            .output()
            .expect("show");
        assert_eq!(
            o.status.code(),
            Some(0),
            "{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let text = String::from_utf8(o.stdout).expect("utf-8");
        // every DCF lists the mandatory objects and fills [DeviceInfo]
        assert!(
            text.contains(
                "\n[MandatoryObjects]\nSupportedObjects=3\n1=0x1000\n2=0x1001\n3=0x1018\n"
            ),
            "{name}\n{text}"
        );
        assert!(text.contains("\nLSS_Supported=0\n"), "{name}\n{text}");
        let dcf = dir.path().join(format!("{name}.dcf"));
        std::fs::write(&dcf, &text).expect("write dcf");
        dcfs.push((name.clone(), dcf, text));
    }
    // own DataTypes and `;` as written
    let text_of = |n: &str| &dcfs.iter().find(|d| d.0 == n).expect("dcf").2;
    assert!(text_of("other-vendor").contains("\n[2000]\nParameterName=Block torque\nObjectType=0x7\nDataType=0x0006\nAccessType=rw\nDefaultValue=800\nLowLimit=0\nHighLimit=1000\nPDOMapping=0\nParameterValue=500\n"));
    assert!(text_of("semicolons").contains("\n[5FEE]\nParameterName=Name;with;semicolons\nObjectType=0x7\nDataType=0x0009\nAccessType=rw\nDefaultValue=A;B\nPDOMapping=0\nParameterValue=X;Y\n"));
    assert!(text_of("per-subindex-values").contains("\n[DeviceInfo]\nVendorName=Lenze\nVendorNumber=0x0000003B\nProductName=FICTIONAL Lenze-style vendor, imported from per-subindex-values.eds\nProductNumber=0x00000010\nRevisionNumber=0x00020001\n"));
    let Some(python) = python else {
        return;
    };
    let script = workspace_root().join("tests/python/dcf_check.py");
    let mut results = Vec::new();
    for (name, dcf, _) in &dcfs {
        let o = std::process::Command::new(&python)
            .arg(&script)
            .arg(dcf)
            .output()
            .expect("python");
        let out = String::from_utf8_lossy(&o.stdout).into_owned();
        assert_eq!(
            o.status.code(),
            Some(0),
            "{name}\n{out}{}",
            String::from_utf8_lossy(&o.stderr)
        );
        results.push(format!("{name}: {}", out.trim_end()));
    }
    assert_eq!(
        results,
        [
            "record-dropped-subs: ok 4 objects, 1 values",
            "per-subindex-values: ok 5 objects, 2 values",
            "other-vendor: ok 5 objects, 2 values",
            "lenze-by-name: ok 5 objects, 2 values",
            "cia402: ok 3 objects, 0 values",
            "semicolons: ok 5 objects, 2 values",
            "cr-only: ok 4 objects, 1 values",
            "utf16le-bom: ok 4 objects, 1 values",
            "bad-names: ok 4 objects, 1 values",
            "lenze-ecs: ok 17 objects, 14 values",
        ]
    );
}

/// The ECS role floor (CiA 402, issue 17) reaches an imported schema: a set
/// that puts 0x6040 into "enable operation" (15) is refused by `validate`,
/// a stopped control word ("shutdown", 6) passes.
#[test]
fn an_imported_cia402_controlword_carries_its_profile_role() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (_, stderr, code) = import(dir.path(), "cia402");
    assert_eq!(code, 1, "{stderr}");
    let validate = |value: u32| {
        std::fs::write(
            dir.path().join("s.toml"),
            format!("schema = \"cia402.toml\"\n[values]\ncontrolword = {value}\n"),
        )
        .unwrap();
        let o = driveset()
            .current_dir(dir.path())
            .args(["validate", "s.toml"])
            .env("NO_COLOR", "1")
            .output()
            .expect("runs");
        (
            String::from_utf8(o.stdout).expect("utf-8"),
            o.status.code().expect("exit code"),
        )
    };
    let (out, code) = validate(15);
    assert_eq!(code, 1, "{out}");
    assert!(
        out.starts_with(
            "error[control-word-not-stopped]: 0x6040 = { switch_on = 1, enable_operation = 1, fault_reset = 0 } would start or enable the drive (switch_on, enable_operation set)\n --> s.toml:3:15\n"
        ),
        "{out}"
    );
    assert_eq!(validate(6), ("0 findings in 0 of 1 file\n".to_string(), 0));
}
