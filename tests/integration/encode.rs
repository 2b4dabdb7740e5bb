//! `driveset encode`: exact output and exit codes (generated from reviewed runs).

use driveset_test_support::driveset;

#[test]
fn lustbus_6_1_1_1_enquiry() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"lustbus"#,
            r#"enquiry address=0 code=00112"#,
        ])
        .assert()
        .code(0)
        .stdout(
            r#"hex:   04 40 30 30 31 31 32 05
ascii: <EOT>@00112<ENQ>
"#,
        )
        .stderr(r#""#);
}

#[test]
fn lustbus_6_2_2_select_raw_hex() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"lustbus"#,
            r#"select address=0 code=00105 value=0x03E8"#,
        ])
        .assert()
        .code(0)
        .stdout(
            r#"hex:   04 40 02 30 30 31 30 35 3D 30 33 45 38 03 74
ascii: <EOT>@<STX>00105=03E8<ETX>t
"#,
        )
        .stderr(r#""#);
}

#[test]
fn lustbus_6_2_2_select_decimal_via_schema() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"lustbus"#,
            r#"select address=0 family=vf1000 param=5 value=50.00"#,
        ])
        .assert()
        .code(0)
        .stdout(
            r#"hex:   04 40 02 30 30 31 30 35 3D 30 33 45 38 03 74
ascii: <EOT>@<STX>00105=03E8<ETX>t
"#,
        )
        .stderr(r#""#);
}

#[test]
fn lustbus_7_2_1_rsio_raw() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"lustbus"#,
            r#"select address=1 family=mc6000 param=428 value=0x842666"#,
        ])
        .assert()
        .code(0)
        .stdout(
            r#"hex:   04 41 02 32 30 34 32 38 3D 38 34 32 36 36 36 03 0A
ascii: <EOT>A<STX>20428=842666<ETX><LF>
"#,
        )
        .stderr(r#""#);
}

#[test]
fn lustbus_rsio_exact_decimal() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"lustbus"#,
            r#"--family"#,
            r#"mc6000"#,
            r#"select address=1 param=428 value=132.5"#,
        ])
        .assert()
        .code(0)
        .stdout(
            r#"hex:   04 41 02 32 30 34 32 38 3D 38 34 38 30 30 30 03 06
ascii: <EOT>A<STX>20428=848000<ETX><ACK>
"#,
        )
        .stderr(r#""#);
}

#[test]
fn lustbus_rsio_unrepresentable() {
    driveset()
        .args([r#"encode"#, r#"--protocol"#, r#"lustbus"#, r#"select address=1 family=mc6000 param=428 value=132.15"#])
        .assert()
        .code(2)
        .stdout("")
        .stderr(r#"error: value=132.15: 428-RSIO (PT_INT32Q16) has steps of 1/65536; 132.15 is not representable; nearest values: 132.149993896484375 and 132.1500091552734375
"#);
}

#[test]
fn lustbus_6_1_1_1_value_reply() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"lustbus"#,
            r#"reply address=0 code=00112 value=0x03E8"#,
        ])
        .assert()
        .code(0)
        .stdout(
            r#"hex:   40 02 30 30 31 31 32 3D 30 33 45 38 03 72
ascii: @<STX>00112=03E8<ETX>r
"#,
        )
        .stderr(r#""#);
}

#[test]
fn lustbus_decimal_without_family() {
    driveset()
        .args([r#"encode"#, r#"--protocol"#, r#"lustbus"#, r#"select address=1 code=00085 value=5"#])
        .assert()
        .code(2)
        .stdout("")
        .stderr(r#"error: value=5: give the value as raw hex (value=0x03E8), or name the family (family=vf1000|mc6000) so the parameter's type can convert a decimal
"#);
}

#[test]
fn lustbus_param_needs_family() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"lustbus"#,
            r#"enquiry address=1 param=428"#,
        ])
        .assert()
        .code(2)
        .stdout("")
        .stderr(
            r#"error: param=428 needs the device family: add family=vf1000 or family=mc6000
"#,
        );
}

#[test]
fn lustbus_bad_address() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"lustbus"#,
            r#"enquiry address=40 code=00112"#,
        ])
        .assert()
        .code(2)
        .stdout("")
        .stderr(
            r#"error: address=40: LUSTBUS addresses are 0..31 (0 all devices, 31 broadcast)
"#,
        );
}

#[test]
fn lecom_8h_receive() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"lecom"#,
            r#"receive address=1 code=46"#,
        ])
        .assert()
        .code(0)
        .stdout(
            r#"hex:   04 30 31 34 36 05
ascii: <EOT>0146<ENQ>
"#,
        )
        .stderr(r#""#);
}

#[test]
fn lecom_8i_send() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"lecom"#,
            r#"send address=34 code=11 value=95.2"#,
        ])
        .assert()
        .code(0)
        .stdout(
            r#"hex:   04 33 34 02 31 31 39 35 2E 32 03 13
ascii: <EOT>34<STX>1195.2<ETX><13>
"#,
        )
        .stderr(r#""#);
}

#[test]
fn lecom_8j_broadcast() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"lecom"#,
            r#"broadcast address=00 code=40 value=0"#,
        ])
        .assert()
        .code(0)
        .stdout(
            r#"hex:   04 30 30 02 34 30 30 03 37
ascii: <EOT>00<STX>400<ETX>7
"#,
        )
        .stderr(r#""#);
}

#[test]
fn lecom_send_vh() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"lecom"#,
            r#"send address=7 code=C1002/0 value=H1234"#,
        ])
        .assert()
        .code(0)
        .stdout(
            r#"hex:   04 30 37 02 45 3C 48 31 32 33 34 03 36
ascii: <EOT>07<STX>E<3C>H1234<ETX>6
"#,
        )
        .stderr(r#""#);
}

#[test]
fn lecom_send_to_broadcast_refused() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"lecom"#,
            r#"send address=00 code=40 value=0"#,
        ])
        .assert()
        .code(2)
        .stdout("")
        .stderr(
            r#"error: address=00: SEND to 00, a broadcast address (8.J); build a Broadcast instead
"#,
        );
}

#[test]
fn lecom_missing_value() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"lecom"#,
            r#"send address=34 code=11"#,
        ])
        .assert()
        .code(2)
        .stdout("")
        .stderr(
            r#"error: send needs value=...
"#,
        );
}

#[test]
fn lecom_bad_value() {
    driveset()
        .args([r#"encode"#, r#"--protocol"#, r#"lecom"#, r#"send address=34 code=11 value=9.12345"#])
        .assert()
        .code(2)
        .stdout("")
        .stderr(r#"error: value=9.12345: VD: 5 digits after the decimal point, expected 1..=4 (8.E); valid: 95.2 (VD), H0900 or 0x0900 (VH), Stext (VS), O0102 (VO)
"#);
}

#[test]
fn sdo_write_c0011() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"sdo"#,
            r#"sdo write node=1 code=11 value=50.0"#,
        ])
        .assert()
        .code(0)
        .stdout(
            r#"cob-id: 0x601
data:   23 F4 5F 00 20 A1 07 00
slcan:  t601823F45F0020A10700<CR>
"#,
        )
        .stderr(r#""#);
}

#[test]
fn sdo_read_c5001() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"sdo"#,
            r#"sdo read node=1 code=5001"#,
        ])
        .assert()
        .code(0)
        .stdout(
            r#"cob-id: 0x601
data:   40 76 4C 00 00 00 00 00
slcan:  t601840764C0000000000<CR>
"#,
        )
        .stderr(r#""#);
}

#[test]
fn sdo_bad_node() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"sdo"#,
            r#"write node=0 code=11 value=1"#,
        ])
        .assert()
        .code(2)
        .stdout("")
        .stderr(
            r#"error: node=0: CAN node ids are 1..127
"#,
        );
}

#[test]
fn unknown_verb() {
    driveset()
        .args([
            r#"encode"#,
            r#"--protocol"#,
            r#"lustbus"#,
            r#"selekt address=1"#,
        ])
        .assert()
        .code(2)
        .stdout("")
        .stderr(
            r#"error: unknown telegram kind `selekt`; valid: enquiry, select, reply, ack, nak, eot
"#,
        );
}

#[test]
fn unknown_key() {
    driveset()
        .args([r#"encode"#, r#"--protocol"#, r#"lustbus"#, r#"select adress=1 code=00105 value=0x1"#])
        .assert()
        .code(2)
        .stdout("")
        .stderr(r#"error: unknown key `adress` for select; valid keys: address, code, param, family, device, value
"#);
}

#[test]
fn unknown_protocol() {
    driveset()
        .args([r#"encode"#, r#"--protocol"#, r#"modbus"#, r#"read"#])
        .assert()
        .code(2)
        .stdout("")
        .stderr(
            r#"error: invalid value 'modbus' for '--protocol <PROTOCOL>'
  [possible values: lustbus, lecom, can]

For more information, try '--help'.
"#,
        );
}

#[test]
fn raw_writes_only_the_bytes() {
    driveset()
        .args([
            "encode",
            "--protocol",
            "lustbus",
            "--raw",
            "enquiry address=0 code=00112",
        ])
        .assert()
        .code(0)
        .stdout(&b"\x04@00112\x05"[..]);
    driveset()
        .args([
            "encode",
            "--protocol",
            "sdo",
            "--raw",
            "write node=1 code=11 value=50.0",
        ])
        .assert()
        .code(0)
        .stdout("t601823F45F0020A10700\r");
}
