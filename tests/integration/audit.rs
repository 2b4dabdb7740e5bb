//! The fixes of the independent audit against the specs (issue 13):
//! decoder cases with their exact bytes, values in sets and `encode`, the
//! simulated Tmd's factory C0001.

use predicates::prelude::*;

use driveset_test_support::driveset;

fn decode(args: &[&str], code: i32, stdout: &str) {
    driveset()
        .arg("decode")
        .args(args)
        .assert()
        .code(code)
        .stdout(stdout.to_string())
        .stderr("");
}

/// LECOM 8.B: after C0249 = 7 (ACKed), standard code 173 is C1923, as the
/// simulated Tmd resolves it (crates/driveset-sim/tests/integration/tmd.rs,
/// `factory_c0001_is_0_lecom_reads_and_switches_banks_only`).
#[test]
fn lecom_read_after_bank_7_names_c1923() {
    decode(
        &[
            "--protocol",
            "lecom",
            "--ascii",
            "<EOT>34<STX>H97<ETX>E<ACK><EOT>34A3<ENQ><STX>A350<ETX>t<EOT>",
        ],
        0,
        "0..9        host -> drive   SEND      address 34, code C0249 (lecom_code_bank), value 7, BCC 0x45 ok
9..10       drive -> host   ACK       address 34: SEND of C0249 carried out
            from now on standard addressing of 34 uses code bank 7 (C0249) and input selection 0 (C0248)
10..16      host -> drive   RECEIVE   address 34, code C1923 (serial_fault_time)
            sent as C0173 with code bank 7 (C0249) and input selection 0 (C0248): C1923 (8.B, 8.C)
16..23      drive -> host   VALUE     address 34, code C1923 (serial_fault_time), value 50 ms, BCC 0x74 ok
            sent as C0173 with code bank 7 (C0249) and input selection 0 (C0248): C1923 (8.B, 8.C)
23..24      host -> drive   EOT       end of transmission
",
    );
}

/// 8.C: C0248 = 1 makes C39 subcode 1; a NAKed C0249 write changes nothing;
/// a BROADCAST of C0249 = 4 reaches every station (C02 -> C1002).
#[test]
fn lecom_input_selection_nak_and_broadcast_bank() {
    decode(
        &[
            "--protocol",
            "lecom",
            "--ascii",
            "<EOT>34<STX>H81<ETX>B<ACK><EOT>3439<ENQ><STX>3920<ETX><0B><EOT>",
        ],
        0,
        "0..9        host -> drive   SEND      address 34, code C0248 (lecom_input_selection), value 1, BCC 0x42 ok
9..10       drive -> host   ACK       address 34: SEND of C0248 carried out
            from now on standard addressing of 34 uses code bank 0 (C0249) and input selection 1 (C0248)
10..16      host -> drive   RECEIVE   address 34, code C0039/1 (fixed_setpoint_3)
            sent as C0039 with code bank 0 (C0249) and input selection 1 (C0248): C0039/1 (8.B, 8.C)
16..23      drive -> host   VALUE     address 34, code C0039/1 (fixed_setpoint_3), value 20 Hz, BCC 0x0B ok
            sent as C0039 with code bank 0 (C0249) and input selection 1 (C0248): C0039/1 (8.B, 8.C)
23..24      host -> drive   EOT       end of transmission
",
    );
    decode(
        &[
            "--protocol",
            "lecom",
            "--ascii",
            "<EOT>34<STX>H97<ETX>E<NAK><EOT>34A3<ENQ>",
        ],
        0,
        "0..9        host -> drive   SEND      address 34, code C0249 (lecom_code_bank), value 7, BCC 0x45 ok
9..10       drive -> host   NAK       address 34: SEND of C0249 not carried out, the value is unchanged; read C0068 bits 4..7 or C1962 for the reason
10..16      host -> drive   RECEIVE   address 34, code C0173 (input_voltage_selection)
",
    );
    decode(
        &[
            "--protocol",
            "lecom",
            "--ascii",
            "<EOT>00<STX>H94<ETX>F<EOT>1202<ENQ>",
        ],
        0,
        "0..9        host -> drive   BROADCAST address 00 (broadcast to all), code C0249 (lecom_code_bank), value 4, BCC 0x46 ok: no controller answers a broadcast
9..15       host -> drive   RECEIVE   address 12, code C1002
            sent as C0002 with code bank 4 (C0249) and input selection 0 (C0248): C1002 (8.B, 8.C)
",
    );
}

/// 8.J: no controller acknowledges a broadcast or multicast.
#[test]
fn lecom_ack_to_a_group_or_broadcast_address_is_flagged() {
    decode(
        &["--protocol", "lecom", "--ascii", "<EOT>30<STX>1150<ETX><ACK><ACK>"],
        1,
        "0..10       host -> drive   BROADCAST address 30 (multicast to 31..39), code C0011 (maximum_output_frequency), value 50 Hz, BCC 0x06 ok: no controller answers a broadcast
10..11      drive -> host   ACK       address 30 (multicast to 31..39): carried out: no controller answers a telegram to 30 (multicast to 31..39) (broadcast / multicast, 8.J): this reply cannot come from it
",
    );
    decode(
        &["--protocol", "lecom", "--hex", "04 30 30 02 31 31 35 30 03 06 15"],
        1,
        "0..10       host -> drive   BROADCAST address 00 (broadcast to all), code C0011 (maximum_output_frequency), value 50 Hz, BCC 0x06 ok: no controller answers a broadcast
10..11      drive -> host   NAK       address 00 (broadcast to all): the controller refused the value (NAK); read C0068 bits 4..7 or C1962 for the reason: no controller answers a telegram to 00 (broadcast to all) (broadcast / multicast, 8.J): this reply cannot come from it
",
    );
}

/// LUSTBUS §4.2 / §9.1: no device answers address 31.
#[test]
fn lustbus_reply_to_address_31_is_flagged() {
    decode(
        &[
            "--protocol",
            "lustbus",
            "--ascii",
            "<EOT>_<STX>00105=03E8<ETX>t_<ACK><EOT>",
        ],
        1,
        "0..15       host -> drive   SELECT    address 31 '_' (broadcast), code 00105 (5-FSSIO), value 03E8 = 50 Hz, BCC 0x74 ok: broadcast: every device acts on it, none replies
15..17      drive -> host   ACK       address 31 '_' (broadcast): accepted: no device answers address 31 (broadcast; §4.2, §9.1): this reply cannot answer the SELECT to 31 '_' (broadcast)
17..18      host -> drive   EOT       end of transaction, every receiver resets
",
    );
}

/// LUSTBUS §3: only the addressed device answers.
#[test]
fn lustbus_reply_from_another_address_is_flagged() {
    decode(
        &[
            "--protocol",
            "lustbus",
            "--ascii",
            "<EOT>E00112<ENQ>F<STX>00112=03E8<ETX>r<EOT>",
        ],
        1,
        "0..8        host -> drive   ENQUIRY   address 5 'E', code 00112 (12-rotary_field_frequency)
8..22       drive -> host   VALUE     address 6 'F', code 00112 (12-rotary_field_frequency), value 03E8, BCC 0x72 ok: reply from address 6 'F', but the ENQUIRY asked address 5 'E': only the addressed device answers (§3)
22..23      host -> drive   EOT       end of transaction, every receiver resets
",
    );
}

/// LUSTBUS §3 "ADR NAK: occurs with wrong BCC", §9.2 bit 3.
#[test]
fn lustbus_select_with_a_wrong_bcc_is_answered_nak_serr_08() {
    decode(
        &[
            "--protocol",
            "lustbus",
            "--ascii",
            "<EOT>@<STX>00105=03E8<ETX>x@<NAK><EOT>",
        ],
        1,
        "0..15       host -> drive   SELECT    address 0 '@' (all devices), code 00105 (5-FSSIO), value 03E8 = 50 Hz, BCC bad: expected 0x74, found 0x78: BCC mismatch: the drive answers NAK and sets SERR bit 3 (08h, checksum error; §3, §9.2); read 85 to unlatch it, then repeat the telegram
15..17      drive -> host   NAK       address 0 '@' (all devices): SELECT of 00105 refused: its BCC was wrong (SERR bit 3, 08h, checksum error; §3, §9.2); read 85 to unlatch the device, then repeat it
17..18      host -> drive   EOT       end of transaction, every receiver resets
",
    );
}

/// PT_VF_ERROR (errata L17, L18) and PT_MC_ERROR (L19) as fields.
#[test]
fn error_memory_values_show_number_location_time() {
    decode(
        &[
            "--protocol",
            "lustbus",
            "--schema",
            "parameter-sets/fixtures/fictional-vf1000-demo.toml",
            "--ascii",
            "<EOT>A00192<ENQ>A<STX>00192=0312<ETX><04><EOT>A00192<ENQ>A<STX>00192=0F00<ETX>r<EOT>",
        ],
        0,
        "0..8        host -> drive   ENQUIRY   address 1 'A', code 00192 (92-ERR1)
8..22       drive -> host   VALUE     address 1 'A', code 00192 (92-ERR1), value 0312 = { number = 3, time = 18 }, BCC 0x04 ok
22..30      host -> drive   ENQUIRY   address 1 'A', code 00192 (92-ERR1)
30..44      drive -> host   VALUE     address 1 'A', code 00192 (92-ERR1), value 0F00 = { number = 15, time = 0 } (no error), BCC 0x72 ok
44..45      host -> drive   EOT       end of transaction, every receiver resets
",
    );
    let dir = tempfile::tempdir().unwrap();
    let schema = dir.path().join("mc-error.toml");
    std::fs::write(
        &schema,
        "[schema]\nid = \"fictional-mc-error\"\ntitle = \"FICTIONAL: lust-mc6000 plus an error memory\"\nextends = \"lust-mc6000\"\nfictional = true\n\n[[code]]\nnumber = 95\nname = \"ERR1\"\ntitle = \"Error memory 1\"\nspec = \"fictional\"\ntype = \"PT_MC_ERROR\"\naccess = \"ro\"\nkind = \"eeprom\"\nwidth = 4\n",
    )
    .unwrap();
    decode(
        &[
            "--protocol",
            "lustbus",
            "--schema",
            schema.to_str().unwrap(),
            "--ascii",
            "<EOT>A20095<ENQ>A<STX>20095=0502012C<ETX>w<EOT>",
        ],
        0,
        "0..8        host -> drive   ENQUIRY   address 1 'A', code 20095 (95-ERR1)
8..26       drive -> host   VALUE     address 1 'A', code 20095 (95-ERR1), value 0502012C = { number = 5, location = 2, time = 300 }, BCC 0x77 ok
26..27      host -> drive   EOT       end of transaction, every receiver resets
",
    );
}

/// docs/file-formats.md: `C0068 = "0x0900"`, hex in quotes.
#[test]
fn quoted_hex_values_in_sets() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("q.toml"),
        "schema = \"lenze-tmd\"\n[values]\nC0007 = \"0x4321\"\nC0135 = \"0x0008\"\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("p.toml"),
        "schema = \"lenze-tmd\"\n[values]\nC0007 = 0x4321\nC0135 = 0x0008\n",
    )
    .unwrap();
    driveset()
        .current_dir(dir.path())
        .args(["validate", "q.toml"])
        .assert()
        .code(0)
        .stdout("0 findings in 0 of 1 file\n");
    // the quoted and the bare literal are the same values
    let fp = |f: &str| {
        driveset()
            .current_dir(dir.path())
            .args(["fingerprint", f])
            .assert()
            .code(0)
            .get_output()
            .stdout
            .clone()
    };
    let (q, p) = (fp("q.toml"), fp("p.toml"));
    assert_eq!(q[..71], p[..71]);
    // a quoted hex for a decimal-only type says so
    std::fs::write(
        dir.path().join("d.toml"),
        "schema = \"lenze-tmd\"\n[values]\nC0011 = \"0x10\"\n",
    )
    .unwrap();
    driveset()
        .current_dir(dir.path())
        .args(["validate", "d.toml"])
        .assert()
        .code(1)
        .stdout(predicate::str::starts_with(
            "error[wrong-type]: C0011 (VD) takes a decimal value, not `0x10`\n",
        ));
}

/// PT_FLOAT_IEEE: 1e39 is beyond f32 (set and encode); encode takes
/// exponents as sets do.
#[test]
fn float_range_and_exponents() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("f.toml"),
        format!(
            "schema = {:?}\n[values]\n105 = 1e39\n106 = \"1e39\"\n",
            driveset_test_support::workspace_root()
                .join("parameter-sets/fixtures/fictional-mc6000-demo.toml")
                .display()
                .to_string()
        ),
    )
    .unwrap();
    let out = driveset()
        .current_dir(dir.path())
        .args(["validate", "f.toml"])
        .assert()
        .code(1)
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(out).unwrap();
    assert!(
        text.starts_with("error[out-of-range]: 105-BRRES = 1e39 is outside the f32 range of PT_FLOAT_IEEE (-3.4028235e38 ..= 3.4028235e38)\n"),
        "{text}"
    );
    assert_eq!(
        text.matches("is outside the f32 range of PT_FLOAT_IEEE")
            .count(),
        2,
        "{text}"
    );
    driveset()
        .args([
            "encode",
            "--protocol",
            "lustbus",
            "--family",
            "mc6000",
            "--schema",
            "parameter-sets/fixtures/fictional-mc6000-demo.toml",
            "select address=1 param=105 value=1e39",
        ])
        .assert()
        .code(2)
        .stdout("")
        .stderr("error: value=1e39: outside the f32 range of 105-BRRES (PT_FLOAT_IEEE): -3.4028235e38 to 3.4028235e38\n");
    driveset()
        .args(["encode", "--protocol", "lecom", "send address=1 code=11 value=1e-4"])
        .assert()
        .code(0)
        .stdout("hex:   04 30 31 02 31 31 30 2E 30 30 30 31 03 1C\nascii: <EOT>01<STX>110.0001<ETX><1C>\n");
    driveset()
        .args(["encode", "--protocol", "lecom", "send address=1 code=11 value=1e-5"])
        .assert()
        .code(2)
        .stderr("error: value=1e-5 (= 0.00001): VD: 5 digits after the decimal point, expected 1..=4 (8.E); VD has at most 6 integer digits and 4 decimals (8.E)\n");
    driveset()
        .args([
            "encode",
            "--protocol",
            "sdo",
            "write node=1 code=11 value=1e-4",
        ])
        .assert()
        .code(0)
        .stdout(
            "cob-id: 0x601\ndata:   23 F4 5F 00 01 00 00 00\nslcan:  t601823F45F0001000000<CR>\n",
        );
}

/// Table 1: the simulated Tmd leaves the factory with C0001 = 0 (§4e:
/// LECOM may read only); `c0001=3` (set at the keypad) lets it program.
#[test]
fn simulated_tmd_starts_at_c0001_0() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("t.toml"),
        "schema = \"lenze-tmd\"\n[values]\nC0011 = \"60 Hz\"\n",
    )
    .unwrap();
    let out = driveset()
        .current_dir(dir.path())
        .args([
            "upload",
            "t.toml",
            "--port",
            "sim://tmd?addresses=3",
            "--address",
            "3",
        ])
        .args(["--journal", "j.json"])
        .assert()
        .code(3)
        .get_output()
        .clone();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("C0011 maximum_output_frequency: 50 Hz -> 60 Hz  FAILED: sim://tmd?addresses=3 address 3: write C0011 (raw 600000) refused: no access permission (NAK; C0068 = H0060, bits 4..7 = 6; C1962 = no access permission (8)); the code cannot be written now: inhibit the controller (many codes are writable only at standstill), check the user password C0094, or set C0001 to 2 or 3 at the keypad so LECOM may program the drive (§4e)\n"),
        "{stdout}"
    );
    driveset()
        .current_dir(dir.path())
        .args([
            "upload",
            "t.toml",
            "--port",
            "sim://tmd?addresses=3&c0001=3",
            "--address",
            "3",
        ])
        .args(["--journal", "j2.json"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "C0011 maximum_output_frequency: 50 Hz -> 60 Hz  verified\n",
        ));
    driveset()
        .args([
            "pull",
            "--port",
            "sim://tmd?addresses=3&c0001=12",
            "--address",
            "3",
            "-o",
            "-",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "C0001 takes 0..=11 (Table 1; §4e)",
        ));
}
