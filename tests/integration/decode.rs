//! `driveset decode`: exact output and exit codes (generated from reviewed runs).

use driveset_test_support::driveset;

#[test]
fn lustbus_6_1_1_1_vf1000_enquiry() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lustbus"#, r#"--hex"#, r#"04 40 30 30 31 31 32 05  40 02 30 30 31 31 32 3D 30 33 45 38 03 72  04"#])
        .assert()
        .code(0)
        .stdout(r#"0..8        host -> drive   ENQUIRY   address 0 '@' (all devices), code 00112 (12-rotary_field_frequency)
8..22       drive -> host   VALUE     address 0 '@' (all devices), code 00112 (12-rotary_field_frequency), value 03E8, BCC 0x72 ok
22..23      host -> drive   EOT       end of transaction, every receiver resets
"#)
        .stderr(r#""#);
}

#[test]
fn lustbus_6_1_1_2_mc_enquiry_int32q16() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lustbus"#, r#"--hex"#, r#"04 40 32 30 30 37 37 05 40 02 32 30 30 37 37 3D 30 34 46 41 34 30 30 30 03 0B 04"#])
        .assert()
        .code(0)
        .stdout(r#"0..8        host -> drive   ENQUIRY   address 0 '@' (all devices), code 20077 (77-SPEED)
8..26       drive -> host   VALUE     address 0 '@' (all devices), code 20077 (77-SPEED), value 04FA4000 = 1274.25 1/min, BCC 0x0B ok
26..27      host -> drive   EOT       end of transaction, every receiver resets
"#)
        .stderr(r#""#);
}

#[test]
fn lustbus_6_2_2_vf1000_select_fixpoint16() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lustbus"#, r#"--ascii"#, r#"<EOT>@<STX>00105=03E8<ETX>t@<ACK><EOT>"#])
        .assert()
        .code(0)
        .stdout(r#"0..15       host -> drive   SELECT    address 0 '@' (all devices), code 00105 (5-FSSIO), value 03E8 = 50 Hz, BCC 0x74 ok
15..17      drive -> host   ACK       address 0 '@' (all devices): SELECT of 00105 accepted
17..18      host -> drive   EOT       end of transaction, every receiver resets
"#)
        .stderr(r#""#);
}

#[test]
fn lustbus_6_2_2_fixture_schema_types_parameter_12() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lustbus"#, r#"--schema"#, r#"parameter-sets/fixtures/fictional-vf1000-demo.toml"#, r#"--hex"#, r#"40 02 30 30 31 31 32 3D 30 33 45 38 03 72"#])
        .assert()
        .code(0)
        .stdout(r#"0..14       drive -> host   VALUE     address 0 '@' (all devices), code 00112 (12-rotary_field_frequency), value 03E8 = 50 Hz, BCC 0x72 ok
"#)
        .stderr(r#""#);
}

#[test]
fn lustbus_7_2_1_rsio_select() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lustbus"#, r#"--family"#, r#"mc6000"#, r#"--ascii"#, r#"<EOT>A<STX>20428=842666<ETX><LF>A<ACK><EOT>"#])
        .assert()
        .code(0)
        .stdout(r#"0..17       host -> drive   SELECT    address 1 'A', code 20428 (428-RSIO), value 842666 = 132.149993896484375 1/min, BCC 0x0A ok
17..19      drive -> host   ACK       address 1 'A': SELECT of 20428 accepted
19..20      host -> drive   EOT       end of transaction, every receiver resets
"#)
        .stderr(r#""#);
}

#[test]
fn lustbus_nak_then_siof_bits() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lustbus"#, r#"--family"#, r#"mc6000"#, r#"--ascii"#, r#"<EOT>B<STX>20300=9<ETX>6B<NAK><EOT><EOT>B00085<ENQ>B<STX>00085=80<ETX><0B><EOT>"#])
        .assert()
        .code(0)
        .stdout(r#"0..12       host -> drive   SELECT    address 2 'B', code 20300 (300-CFCON), value 9, BCC 0x36 ok
12..14      drive -> host   NAK       address 2 'B': SELECT of 20300 refused; read 85 (SIOF/SERR) for the cause, which also unlatches the device
14..15      host -> drive   EOT       end of transaction, every receiver resets
15..23      host -> drive   ENQUIRY   address 2 'B', code 00085 (85-SERR)
23..35      drive -> host   VALUE     address 2 'B', code 00085 (85-SERR), value 80 = 0x80, BCC 0x0B ok: Invalid value (reading 85 cleared it)
            bit 7 Invalid value: The transfer parameter value is not permissible; what to do: Choose a different value
35..36      host -> drive   EOT       end of transaction, every receiver resets
"#)
        .stderr(r#""#);
}

#[test]
fn lustbus_bad_bcc_and_garbage_exit_1() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lustbus"#, r#"--hex"#, r#"FF 00 6A 75 6E 6B 04 43 30 30 30 39 31 05 43 02 30 30 30 39 31 3D 31 32 33 34 03 00 04"#])
        .assert()
        .code(1)
        .stdout(r#"0..6        -               GARBAGE   6 byte(s) FF 00 6A 75 6E 6B belong to no telegram; skipped
6..14       host -> drive   ENQUIRY   address 3 'C', code 00091 (91 TYPE)
14..28      drive -> host   VALUE     address 3 'C', code 00091 (91 TYPE), value 1234, BCC bad: expected 0x02, found 0x00: BCC mismatch: the host discards this reply; repeat the ENQUIRY
28..29      host -> drive   EOT       end of transaction, every receiver resets
"#)
        .stderr(r#""#);
}

#[test]
fn lustbus_broadcast_select() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lustbus"#, r#"--ascii"#, r#"<EOT>_<STX>20416=0<ETX>?<EOT>"#])
        .assert()
        .code(0)
        .stdout(r#"0..12       host -> drive   SELECT    address 31 '_' (broadcast), code 20416 (416-SCTL1), value 0, BCC 0x3F ok: broadcast: every device acts on it, none replies
12..13      host -> drive   EOT       end of transaction, every receiver resets
"#)
        .stderr(r#""#);
}

#[test]
fn lustbus_capture_file_mc6000_session() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lustbus"#, r#"--family"#, r#"mc6000"#, r#"tests/data/captures/mc6000-eeprom-busy.hex"#])
        .assert()
        .code(0)
        .stdout(r#"0..8        host -> drive   ENQUIRY   address 1 'A', code 00085 (85-SERR)
8..19       drive -> host   VALUE     address 1 'A', code 00085 (85-SERR), value 1 = 0x01, BCC 0x32 ok: Power on (reading 85 cleared it)
            bit 0 Power on: Bit is set for each ON; what to do: No error, information about device new start
19..20      host -> drive   EOT       end of transaction, every receiver resets
20..32      host -> drive   SELECT    address 1 'A', code 20300 (300-CFCON), value 2, BCC 0x3D ok
32..34      drive -> host   ACK       address 1 'A': SELECT of 20300 accepted
34..35      host -> drive   EOT       end of transaction, every receiver resets
35..47      host -> drive   SELECT    address 1 'A', code 20417 (417-RSSL1), value 3, BCC 0x3D ok
47..49      drive -> host   NAK       address 1 'A': SELECT of 20417 refused; read 85 (SIOF/SERR) for the cause, which also unlatches the device
49..50      host -> drive   EOT       end of transaction, every receiver resets
50..58      host -> drive   ENQUIRY   address 1 'A', code 00085 (85-SERR)
58..69      drive -> host   VALUE     address 1 'A', code 00085 (85-SERR), value 4 = 0x04, BCC 0x37 ok: EEPROM busy (reading 85 cleared it)
            bit 2 EEPROM busy: EEPROM is currently doing a memory burn in; what to do: Wait (> 60 ms) and repeat telegram
69..70      host -> drive   EOT       end of transaction, every receiver resets
70..82      host -> drive   SELECT    address 1 'A', code 20417 (417-RSSL1), value 3, BCC 0x3D ok
82..84      drive -> host   ACK       address 1 'A': SELECT of 20417 accepted
84..85      host -> drive   EOT       end of transaction, every receiver resets
85..93      host -> drive   ENQUIRY   address 1 'A', code 20077 (77-SPEED)
93..110     drive -> host   VALUE     address 1 'A', code 20077 (77-SPEED), value 4FA4000 = 1274.25 1/min, BCC 0x3B ok
110..111    host -> drive   EOT       end of transaction, every receiver resets
"#)
        .stderr(r#""#);
}

#[test]
fn lecom_8h_receive_c46_value_checksum_fault_no_such_code() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lecom"#, r#"--ascii"#, r#"<EOT>0146<ENQ><STX>4635.4<ETX><1D><EOT>0146<ENQ><STX>46?<ETX>><EOT>0146<ENQ><STX>46<EOT>"#])
        .assert()
        .code(0)
        .stdout(r#"0..6        host -> drive   RECEIVE   address 01, code C0046 (frequency_setpoint)
6..15       drive -> host   VALUE     address 01, code C0046 (frequency_setpoint), value 35.4 Hz, BCC 0x1D ok
15..21      host -> drive   RECEIVE   address 01, code C0046 (frequency_setpoint)
21..27      drive -> host   ?         address 01, code C0046 (frequency_setpoint), BCC 0x3E ok: the controller saw a checksum (parity) fault in the request; repeat it
27..33      host -> drive   RECEIVE   address 01, code C0046 (frequency_setpoint)
33..37      drive -> host   NO CODE   address 01, code C0046 (frequency_setpoint): the code does not exist in this controller (wrong device family or firmware?)
"#)
        .stderr(r#""#);
}

#[test]
fn lecom_8h_receive_c68_h0900() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lecom"#, r#"--ascii"#, r#"<EOT>2568<ENQ><STX>68H0900<ETX>L"#])
        .assert()
        .code(0)
        .stdout(r#"0..6        host -> drive   RECEIVE   address 25, code C0068 (operating_status_bit_word)
6..16       drive -> host   VALUE     address 25, code C0068 (operating_status_bit_word), value H0900, BCC 0x4C ok
            fault (tens digit of LECOM fault number): 0 (no fault)
            last communication error: no fault
            control via LECOM enabled: yes
            actual frequency above threshold C17: no
            direction of rotation: CW
            power stage transistors energized: yes
            quick stop active: no
            current limit: no
            setpoint frequency reached: no
            fault occurred: no
"#)
        .stderr(r#""#);
}

#[test]
fn lecom_8i_send_c11_ack_and_nak() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lecom"#, r#"--hex"#, r#"04 33 34 02 31 31 39 35 2E 32 03 13 06 04 33 34 02 31 31 39 35 2E 32 03 13 15"#])
        .assert()
        .code(0)
        .stdout(r#"0..12       host -> drive   SEND      address 34, code C0011 (maximum_output_frequency), value 95.2 Hz, BCC 0x13 ok
12..13      drive -> host   ACK       address 34: SEND of C0011 carried out
13..25      host -> drive   SEND      address 34, code C0011 (maximum_output_frequency), value 95.2 Hz, BCC 0x13 ok
25..26      drive -> host   NAK       address 34: SEND of C0011 not carried out, the value is unchanged; read C0068 bits 4..7 or C1962 for the reason
"#)
        .stderr(r#""#);
}

#[test]
fn lecom_8j_broadcast_c40() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lecom"#, r#"--ascii"#, r#"<EOT>00<STX>400<ETX>7<EOT>30<STX>400<ETX>7"#])
        .assert()
        .code(0)
        .stdout(r#"0..9        host -> drive   BROADCAST address 00 (broadcast to all), code C0040 (controller_inhibit), value 0 = "Controller inhibited", BCC 0x37 ok: no controller answers a broadcast
9..18       host -> drive   BROADCAST address 30 (multicast to 31..39), code C0040 (controller_inhibit), value 0 = "Controller inhibited", BCC 0x37 ok: no controller answers a broadcast
"#)
        .stderr(r#""#);
}

#[test]
fn lecom_bad_bcc_flagged() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lecom"#, r#"--ascii"#, r#"<EOT>34<STX>1195.2<ETX><00>"#])
        .assert()
        .code(1)
        .stdout(r#"0..12       host -> drive   SEND      address 34, code C0011 (maximum_output_frequency), value 95.2 Hz, BCC bad: expected 0x13, found 0x00: BCC mismatch: the receiver discards this telegram
"#)
        .stderr(r#""#);
}

#[test]
fn lecom_c1962_extended_error() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lecom"#, r#"--ascii"#, r#"<EOT>01VF<ENQ><STX>VF14<ETX><16><EOT>"#])
        .assert()
        .code(0)
        .stdout(r#"0..6        host -> drive   RECEIVE   address 01, code C1962 (extended_code_number)
6..13       drive -> host   VALUE     address 01, code C1962 (extended_code_number), value 14 = "Invalid variable", BCC 0x16 ok: error 14: invalid variable
13..14      host -> drive   EOT       end of transmission
"#)
        .stderr(r#""#);
}

#[test]
fn slcan_sdo_write_c0011_50() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"slcan"#, r#"--ascii"#, r#"t601823F45F0020A10700<CR>t581860F45F0000000000<CR>"#])
        .assert()
        .code(0)
        .stdout(r#"0..22       host -> drive   WRITE     node 1, code C0011 (index 0x5FF4 subindex 0), value 0x0007A120 = 50 (FIX32 500000/10000)
22..44      drive -> host   WRITE OK  node 1, code C0011 (index 0x5FF4 subindex 0): write of C0011 acknowledged
"#)
        .stderr(r#""#);
}

#[test]
fn slcan_sdo_read_and_abort() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"slcan"#, r#"--ascii"#, r#"S6<CR>O<CR><CR>t605840F45F0000000000<CR>t585880F45F0000000206<CR>t5858200000000<CR><BEL>"#])
        .assert()
        .code(1)
        .stdout(r#"0..3        host -> adapter COMMAND   set bitrate 500000 bit/s
3..5        host -> adapter COMMAND   open the channel
5..6        adapter -> host OK        CR: command accepted (or an empty command line)
6..28       host -> drive   READ      node 5, code C0011 (index 0x5FF4 subindex 0)
28..50      drive -> host   ABORT     node 5, code C0011 (index 0x5FF4 subindex 0): the drive refuses: 0x06020000 Object does not exist in the object dictionary
            what to do: the drive has no such code: check the code number and the drive family/firmware
50..65      -               ERROR     slcan 't' line has the wrong length 14: "t5858200000000"
65..66      adapter -> host BELL      the adapter refused the last command
"#)
        .stderr(r#""#);
}

#[test]
fn empty_capture() {
    driveset()
        .args([
            r#"decode"#,
            r#"--protocol"#,
            r#"lustbus"#,
            r#"--hex"#,
            r#""#,
        ])
        .assert()
        .code(0)
        .stdout(
            r#"(no bytes)
"#,
        )
        .stderr(r#""#);
}

#[test]
fn bad_hex_odd_digits() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lustbus"#, r#"--hex"#, r#"04 4 30"#])
        .assert()
        .code(2)
        .stdout("")
        .stderr(r#"error: --hex:1:4: `4` has an odd number of hex digits (1); write every byte as two digits (`04` ...)
"#);
}

#[test]
fn bad_hex_file_line_col() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lecom"#, r#"tests/data/captures/bad.hex"#])
        .assert()
        .code(2)
        .stdout("")
        .stderr(r#"error: tests/data/captures/bad.hex:3:5: 'g' is not a hex digit; write bytes as hex pairs like `04 40 30`, comments after `#`
"#);
}

#[test]
fn no_input() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lustbus"#])
        .assert()
        .code(2)
        .stdout("")
        .stderr(r#"error: no capture given: pass --hex "04 40 ...", --ascii "<EOT>...", a FILE, or - for stdin
"#);
}

#[test]
fn unknown_schema() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lustbus"#, r#"--schema"#, r#"no-such"#, r#"--hex"#, r#"04"#])
        .assert()
        .code(2)
        .stdout("")
        .stderr(r#"error: --schema no-such: no built-in schema has that id and no such file exists; built-in ids: lenze-ecs, lenze-tmd, lust-mc6000, lust-vf1000
"#);
}

#[test]
fn schema_for_other_protocol() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lustbus"#, r#"--schema"#, r#"lenze-tmd"#, r#"--hex"#, r#"04"#])
        .assert()
        .code(2)
        .stdout("")
        .stderr(r#"error: --schema lenze-tmd: schema lenze-tmd is for another protocol or family than --protocol lustbus
"#);
}

#[test]
fn family_only_for_lustbus() {
    driveset()
        .args([
            r#"decode"#,
            r#"--protocol"#,
            r#"lecom"#,
            r#"--family"#,
            r#"vf1000"#,
            r#"--hex"#,
            r#"04"#,
        ])
        .assert()
        .code(2)
        .stdout("")
        .stderr(
            r#"error: --family applies to --protocol lustbus only
"#,
        );
}

#[test]
fn bad_ascii_escape() {
    driveset()
        .args([r#"decode"#, r#"--protocol"#, r#"lustbus"#, r#"--ascii"#, r#"<EOT>@<XYZ>"#])
        .assert()
        .code(2)
        .stdout("")
        .stderr(r#"error: --ascii:1:7: unknown escape `<XYZ>`; use two hex digits (`<04>`) or one of NUL, STX, ETX, EOT, ENQ, ACK, BEL, LF, CR, NAK, ESC, DEL
"#);
}

#[test]
fn json_one_object_per_event_with_the_fields() {
    let out = driveset()
        .args([
            "decode",
            "--protocol",
            "lustbus",
            "--format",
            "json",
            "--hex",
            "04 40 32 30 30 37 37 05 40 02 32 30 30 37 37 3D 30 34 46 41 34 30 30 30 03 0B 04",
        ])
        .assert()
        .code(0)
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(out).unwrap();
    let events: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(events.len(), 3);
    let v = &events[1];
    assert_eq!(v["start"], 8);
    assert_eq!(v["end"], 26);
    assert_eq!(v["direction"], "drive -> host");
    assert_eq!(v["kind"], "VALUE");
    assert_eq!(v["address"], "0 '@' (all devices)");
    assert_eq!(v["code"], "20077");
    assert_eq!(v["name"], "77-SPEED");
    assert_eq!(v["raw_value"], "04FA4000");
    assert_eq!(v["value"], "1274.25 1/min");
    assert_eq!(v["bcc"]["ok"], true);
    assert_eq!(v["bcc"]["found"], "0x0B");
    assert_eq!(
        v["bytes"],
        "40 02 32 30 30 37 37 3D 30 34 46 41 34 30 30 30 03 0B"
    );
    assert_eq!(events[0]["kind"], "ENQUIRY");
    assert_eq!(events[2]["kind"], "EOT");
}

#[test]
fn json_garbage_has_error_and_no_direction() {
    let out = driveset()
        .args([
            "decode",
            "--protocol",
            "lecom",
            "--format",
            "json",
            "--hex",
            "FF 00",
        ])
        .assert()
        .code(1)
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
    assert_eq!(v["kind"], "GARBAGE");
    assert!(v.get("direction").is_none());
    assert_eq!(v["error"], "2 byte(s) FF 00 belong to no telegram; skipped");
}

#[test]
fn raw_stdin_round_trip_with_encode() {
    let bytes = driveset()
        .args([
            "encode",
            "--protocol",
            "lustbus",
            "--raw",
            "select address=0 code=00105 value=0x03E8",
        ])
        .assert()
        .code(0)
        .get_output()
        .stdout
        .clone();
    driveset()
        .args(["decode", "--protocol", "lustbus", "--raw", "-"])
        .write_stdin(bytes)
        .assert()
        .code(0)
        .stdout(
            "0..15       host -> drive   SELECT    address 0 '@' (all devices), code 00105 (5-FSSIO), value 03E8 = 50 Hz, BCC 0x74 ok\n",
        );
}

#[test]
fn unknown_protocol() {
    driveset()
        .args(["decode", "--protocol", "modbus", "--hex", "04"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains(
            "invalid value 'modbus' for '--protocol <PROTOCOL>'",
        ));
}

/// Every field of decode's JSON lines, text: none may hold the secret.
fn assert_no_secret(out: &[u8], value: &str, hex: &str) {
    let text = String::from_utf8_lossy(out);
    assert!(!text.contains(value), "{text}");
    assert!(!text.contains(hex), "{text}");
    assert!(!text.contains("raw_value"), "{text}");
}

#[test]
fn a_lecom_password_is_masked_in_text_and_json_both_directions() {
    // SEND C0094 = 777, ACK, RECEIVE C0094, the drive's answer 777
    let capture = "<EOT>11<STX>94777<ETX>9<ACK><EOT>1194<ENQ><STX>94777<ETX>9";
    let out = driveset()
        .args(["decode", "--protocol", "lecom", "--ascii", capture])
        .assert()
        .code(0)
        .stdout(
            "0..11       host -> drive   SEND      address 11, code C0094 (user_password), value <secret>, BCC ok
11..12      drive -> host   ACK       address 11: SEND of C0094 carried out
12..18      host -> drive   RECEIVE   address 11, code C0094 (user_password)
18..26      drive -> host   VALUE     address 11, code C0094 (user_password), value <secret>, BCC ok
",
        )
        .get_output()
        .clone();
    assert_no_secret(&out.stdout, "777", "37 37 37");
    let out = driveset()
        .args([
            "decode",
            "--protocol",
            "lecom",
            "--format",
            "json",
            "--ascii",
            capture,
        ])
        .assert()
        .code(0)
        .get_output()
        .clone();
    let lines: Vec<&str> = std::str::from_utf8(&out.stdout).unwrap().lines().collect();
    assert_eq!(
        lines[0],
        r#"{"start":0,"end":11,"direction":"host -> drive","kind":"SEND","address":"11","code":"C0094","name":"user_password","value":"<secret>","bcc":{"ok":true,"found":"<secret>","expected":"<secret>"},"bytes":"<secret>","secret":true}"#
    );
    assert_eq!(
        lines[3],
        r#"{"start":18,"end":26,"direction":"drive -> host","kind":"VALUE","address":"11","code":"C0094","name":"user_password","value":"<secret>","bcc":{"ok":true,"found":"<secret>","expected":"<secret>"},"bytes":"<secret>","secret":true}"#
    );
    assert_no_secret(&out.stdout, "777", "37 37 37");
}

#[test]
fn a_lecom_password_with_a_bad_bcc_hides_the_bcc_bytes_too() {
    let out = driveset()
        .args(["decode", "--protocol", "lecom", "--ascii", "<EOT>11<STX>94777<ETX>8"])
        .assert()
        .code(1)
        .stdout("0..11       host -> drive   SEND      address 11, code C0094 (user_password), value <secret>, BCC bad: bad telegram (what is wrong is not shown: it carries a secret)\n")
        .get_output()
        .clone();
    assert_no_secret(&out.stdout, "777", "0x39");
}

#[test]
fn a_lustbus_password_is_masked_in_text_and_json_both_directions() {
    // SELECT 70-PASS (PT_PASSWORD in the fictional VF1000 fixture) = 04D2,
    // ENQUIRY of it and the device's answer
    let capture = "<EOT>A<STX>00170=04D2<ETX>z<EOT>A00170<ENQ>A<STX>00170=04D2<ETX>z<EOT>";
    let schema = "parameter-sets/fixtures/fictional-vf1000-demo.toml";
    let out = driveset()
        .args([
            "decode", "--protocol", "lustbus", "--family", "vf1000", "--schema", schema,
            "--ascii", capture,
        ])
        .assert()
        .code(0)
        .stdout(
            "0..15       host -> drive   SELECT    address 1 'A', code 00170 (70-PASS), value <secret>, BCC ok
15..23      host -> drive   ENQUIRY   address 1 'A', code 00170 (70-PASS)
23..37      drive -> host   VALUE     address 1 'A', code 00170 (70-PASS), value <secret>, BCC ok
37..38      host -> drive   EOT       end of transaction, every receiver resets
",
        )
        .get_output()
        .clone();
    assert_no_secret(&out.stdout, "04D2", "30 34 44 32");
    let out = driveset()
        .args([
            "decode",
            "--protocol",
            "lustbus",
            "--family",
            "vf1000",
            "--schema",
            schema,
            "--format",
            "json",
            "--ascii",
            capture,
        ])
        .assert()
        .code(0)
        .get_output()
        .clone();
    let lines: Vec<&str> = std::str::from_utf8(&out.stdout).unwrap().lines().collect();
    assert_eq!(
        lines[0],
        r#"{"start":0,"end":15,"direction":"host -> drive","kind":"SELECT","address":"1 'A'","code":"00170","name":"70-PASS","value":"<secret>","bcc":{"ok":true,"found":"<secret>","expected":"<secret>"},"bytes":"<secret>","secret":true}"#
    );
    assert_no_secret(&out.stdout, "04D2", "30 34 44 32");
}
