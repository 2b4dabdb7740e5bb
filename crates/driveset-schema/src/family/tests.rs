use super::*;

#[test]
fn names_parse_back_and_aliases_resolve() {
    for f in Family::ALL {
        assert_eq!(Family::parse(f.name()), Ok(f));
        assert_eq!(
            Family::from_schema_protocol(f.descriptor().schema_protocol),
            Some(f)
        );
    }
    assert_eq!(Family::parse("MC7000"), Ok(Family::Mc6000));
    assert_eq!(Family::parse("vf"), Ok(Family::Vf1000));
    assert_eq!(
        Family::parse("xyz").unwrap_err(),
        "unknown drive family `xyz`: use one of mc6000, vf1000, tmd, ecs"
    );
    assert_eq!(BusProtocol::parse("SDO"), Some(BusProtocol::CanSdo));
    assert_eq!(BusProtocol::parse("can"), Some(BusProtocol::CanSdo));
    assert_eq!(
        BusProtocol::Lustbus.families().collect::<Vec<_>>(),
        [Family::Mc6000, Family::Vf1000]
    );
}

#[test]
fn a_port_names_a_family_by_name_alias_or_schema_id() {
    for f in Family::ALL {
        let d = f.descriptor();
        assert_eq!(Family::from_port_name(d.name), Some(f));
        assert_eq!(
            Family::from_port_name(d.schema_id),
            Some(f),
            "{}",
            d.schema_id
        );
        for a in d.aliases {
            assert_eq!(Family::from_port_name(a), Some(f));
        }
    }
    assert_eq!(Family::from_port_name("MC7000"), Some(Family::Mc6000));
    assert_eq!(
        Family::from_port_name("fictional-tmd-demo"),
        Some(Family::Tmd)
    );
    assert_eq!(Family::from_port_name("Lenze_ECS"), Some(Family::Ecs));
    assert_eq!(Family::from_port_name("lustbus"), None);
    assert_eq!(Family::from_port_name("xyz"), None);
    // the dialects name their families, in const contexts too
    const MC: Family = Family::from_dialect(Dialect::Mc);
    assert_eq!(MC, Family::Mc6000);
    const LECOM: Option<Family> = BusProtocol::Lecom.only_family();
    assert_eq!(LECOM, Some(Family::Tmd));
}

#[test]
fn addresses_follow_the_specs() {
    let l = BusProtocol::Lustbus;
    assert_eq!(
        l.check_address(0).unwrap_err().problem,
        AddressProblem::Group
    );
    assert_eq!(
        l.check_address(31).unwrap_err().problem,
        AddressProblem::Group
    );
    assert_eq!(
        l.check_address(32).unwrap_err().problem,
        AddressProblem::OutOfRange
    );
    assert!(l.check_address(30).is_ok());
    let c = BusProtocol::Lecom;
    for g in [0, 10, 50, 90] {
        assert_eq!(
            c.check_address(g).unwrap_err().problem,
            AddressProblem::Group
        );
    }
    assert!(c.check_address(99).is_ok());
    assert_eq!(
        c.check_address(100).unwrap_err().problem,
        AddressProblem::OutOfRange
    );
    assert_eq!(
        BusProtocol::CanSdo.check_address(0).unwrap_err().problem,
        AddressProblem::OutOfRange
    );
    assert!(BusProtocol::CanSdo.check_address(127).is_ok());
}

#[test]
fn address_refusals_carry_their_rule() {
    let e = BusProtocol::Lustbus.check_address(31).unwrap_err();
    assert_eq!(
        e.to_string(),
        "address 31: LUSTBUS address 0 is the group address and 31 the broadcast address; a drive needs its own address 1..30"
    );
    assert_eq!(e.kind(), "group-address");
    assert_eq!(e.hint(), "give the drive its own address 1..30");
    let e = Family::Tmd.descriptor().check_address(100).unwrap_err();
    assert_eq!(
        e.to_string(),
        "address 100: LECOM station addresses are 1..99"
    );
    assert_eq!(e.kind(), "address-out-of-range");
    assert_eq!(e.hint(), "give the drive its own address 1..99");
    assert_eq!(
        Family::Ecs
            .descriptor()
            .check_address(128)
            .unwrap_err()
            .rule,
        "CAN node ids are 1..127"
    );
    assert_eq!(BusProtocol::Lustbus.wire_addresses(), 0..=31);
    assert_eq!(Family::Vf1000.descriptor().broadcast_address(), Some(31));
    assert_eq!(Family::Tmd.descriptor().broadcast_address(), Some(0));
    assert_eq!(Family::Ecs.descriptor().broadcast_address(), None);
}

#[test]
fn lustbus_facts_come_from_the_descriptor() {
    let mc = Family::Mc6000.descriptor();
    let vf = Family::Vf1000.descriptor();
    for d in [mc, vf] {
        assert_eq!(d.compatible(), [81, 82, 83, 84, 85, 91]);
        assert!(d.is_compatible(85) && d.is_compatible(91));
        assert!(!d.is_compatible(86) && !d.is_compatible(80));
        assert_eq!(d.type_code, Some(91));
        assert_eq!(d.type_code, Some(TYPE));
        assert!(!d.on_can());
    }
    for f in [Family::Tmd, Family::Ecs] {
        let d = f.descriptor();
        assert!(d.compatible().is_empty() && !d.is_compatible(81));
        assert_eq!((d.type_code, d.dialect, d.learning), (None, None, None));
        assert_eq!(d.learned_id(Some("1"), None, 0), None);
    }
    assert!(Family::Ecs.descriptor().on_can());
    assert!(vf.broadcast_as_own && !mc.broadcast_as_own);
    assert_eq!(mc.dataset_code(), Some(80));
    assert_eq!(vf.dataset_code(), None);
    assert_eq!(mc.dialect, Some(Dialect::Mc));
    assert_eq!(Family::from_dialect(Dialect::Vf1000), Family::Vf1000);
    assert_eq!(Family::from_dialect(Dialect::Mc), Family::Mc6000);
    assert_eq!(mc.max_parameter(), Some(999));
    assert_eq!(vf.max_parameter(), Some(99));
    assert_eq!(vf.learning.map(|l| l.default_params()), Some(1..=99));
    assert_eq!(
        mc.learned_id(Some("6.1"), Some("V 2.30/a"), 0xab),
        Some("learned-mc6000-type61-V_2_30_a".to_string())
    );
    assert_eq!(
        vf.learned_id(None, None, 0xab),
        Some("learned-vf1000-typeunknown-d000000ab".to_string())
    );
    assert_eq!(Family::from_learned_stem("vf1000"), Some(Family::Vf1000));
    assert_eq!(Family::from_learned_stem("tmd"), None);
}

#[test]
fn reaction_and_pacing_figures() {
    let mc = Family::Mc6000.descriptor();
    assert_eq!(
        mc.reaction.longest(Keypad::Fitted),
        Duration::from_millis(30)
    );
    assert_eq!(
        mc.reaction.longest(Keypad::Absent),
        Duration::from_millis(25)
    );
    let vf = Family::Vf1000.descriptor();
    assert_eq!(
        vf.reaction.longest(Keypad::Fitted),
        Duration::from_millis(60)
    );
    assert!(vf.reaction.from_spec());
    assert!(!Family::Tmd.descriptor().reaction.from_spec());
    assert_eq!(mc.dataset.map(|d| d.code), Some(80));
    assert_eq!(vf.long_ack(71, 1), Some(Duration::from_secs(10)));
    assert_eq!(vf.long_ack(71, 0), None);
}

fn parsed(text: &str) -> std::sync::Arc<crate::Schema> {
    let mut r = crate::Registry::new();
    r.add_source(crate::error::SourceFile::new("t.toml", text))
        .expect("test schema parses")
}

#[test]
fn the_floor_holds_whatever_a_schema_file_says() {
    use crate::{BitRole, ControlState, RawValue, Role};
    // 416 as a "setpoint" with bit 0 an "inhibit" bit, 4-PROG without a
    // role: the floor makes 416 a control word whose bit 0 starts and
    // PROG a command, and adds the reset bit
    let mc = parsed(
        r#"
[schema]
id = "f"
title = "f"
protocol = "lustbus-mc"
code_style = "lust"

[[code]]
number = 4
name = "PROG"

[[code]]
number = 416
name = "SCTL1"
type = "PT_USIGN16"
role = "setpoint"

[[code.bits]]
name = "hold"
bits = [0, 0]
role = "inhibit"
"#,
    );
    assert_eq!(mc.role_of(4), Some(Role::Command));
    let c = mc.code(416).expect("416");
    assert_eq!(c.role, Some(Role::ControlWord));
    let roles: Vec<(u32, Option<BitRole>)> = c.bits.iter().map(|b| (b.lsb, b.role)).collect();
    assert_eq!(
        roles,
        [(0, Some(BitRole::Start)), (7, Some(BitRole::Reset))]
    );
    assert_eq!(
        mc.control_state(c, &RawValue::Int(1)),
        ControlState::Moving(vec!["hold".into()])
    );
    assert_eq!(
        mc.control_state(c, &RawValue::Int(0)),
        ControlState::Stopped
    );
    // Tmd C0040 whose file widens the stopped values to 0 and 1
    let tmd = parsed(
        r#"
[schema]
id = "g"
title = "g"
protocol = "lecom"
code_style = "lenze"

[[code]]
number = 40
name = "c40"
type = "VD"
stopped = [0, 1]
"#,
    );
    let c = tmd.code(40).expect("40");
    assert_eq!(c.role, Some(Role::ControlWord));
    assert_eq!(c.stopped, [0]);
    assert!(!tmd.control_state(c, &RawValue::Int(10_000)).is_safe());
    assert!(tmd.control_state(c, &RawValue::Int(0)).is_safe());
    // every floor code of the built-in schemas carries its floor role
    let r = crate::Registry::builtin().expect("built-in schemas parse");
    for f in Family::ALL {
        let s = r.get(f.descriptor().schema_id).expect("schema");
        for fl in f.descriptor().floor {
            if let Some(c) = s.code(fl.code) {
                assert_eq!(c.role, Some(fl.role), "{} {}", s.id, fl.code);
            }
        }
    }
}

#[test]
fn the_built_in_schemas_agree_with_their_descriptors() {
    let r = crate::Registry::builtin().expect("built-in schemas parse");
    for f in Family::ALL {
        let d = f.descriptor();
        let s = r.get(d.schema_id).expect(d.schema_id);
        assert_eq!(s.family, f, "{}", d.schema_id);
        let codes = s
            .identify
            .as_ref()
            .map(|i| i.codes.clone())
            .unwrap_or_default();
        assert_eq!(codes, d.identify, "{}", d.schema_id);
        if let Some(h) = d.dataset {
            assert_eq!(s.code(h.code).map(|c| c.name.as_str()), Some(h.name));
        }
    }
}

#[test]
fn one_pacing_rule_for_planner_and_client() {
    let s = parsed(
        r#"
[schema]
id = "t"
title = "t"
protocol = "lustbus-vf1000"
code_style = "lust"

[[code]]
number = 10
name = "ONE"
kind = "eeprom"
width = 1

[[code]]
number = 11
name = "UNKNOWN"

[[code]]
number = 12
name = "RAM"
kind = "ram-control"
width = 2

[[code]]
number = 13
name = "FSEL"
kind = "fsel-isel"
width = 2
"#,
    );
    let vf = Family::Vf1000.descriptor();
    let ms = Duration::from_millis;
    let c = |n| s.code(n).expect("code");
    assert_eq!(vf.ack_delay(c(10), ValueChange::Differs), ms(60));
    assert_eq!(vf.ack_delay(c(10), ValueChange::Same), ms(0));
    assert_eq!(vf.ack_delay(c(11), ValueChange::Differs), ms(120));
    assert_eq!(vf.ack_delay(c(12), ValueChange::Differs), ms(0));
    assert_eq!(vf.ack_delay(c(13), ValueChange::Differs), ms(120));
    assert_eq!(vf.store_time(c(10)), ms(0));
    let mc = Family::Mc6000.descriptor();
    assert_eq!(mc.store_time(c(10)), ms(15));
    assert_eq!(mc.store_time(c(11)), ms(60));
    assert_eq!(mc.store_time(c(12)), ms(0));
    assert_eq!(mc.ack_delay(c(10), ValueChange::Differs), ms(0));
}

#[test]
fn a_protocol_names_its_only_family_when_it_has_one() {
    assert_eq!(BusProtocol::Lecom.only_family(), Some(Family::Tmd));
    assert_eq!(BusProtocol::CanSdo.only_family(), Some(Family::Ecs));
    assert_eq!(BusProtocol::Lustbus.only_family(), None);
}

#[test]
fn only_the_lustbus_inverter_takes_a_new_rate_at_a_restart_only() {
    let only: Vec<Family> = Family::ALL
        .into_iter()
        .filter(|f| f.descriptor().rate_at_restart_only())
        .collect();
    assert_eq!(only, [Family::Vf1000]);
    assert!(Family::Mc6000.descriptor().line_rates.online.is_some());
}

/// The identify rules stay inside the identify codes: what is read
/// without a schema's codes, the software version code and the probe's
/// codes are among the family's own identification codes; the probe
/// reads no software version.
#[test]
fn identify_rules_stay_within_the_identify_codes() {
    for f in Family::ALL {
        let d = f.descriptor();
        let rules = d.identify_rules;
        for n in rules.without_schema {
            assert!(d.identify.contains(n), "{}: {n}", d.name);
        }
        if let Some(n) = rules.software {
            assert!(d.identify.contains(&n), "{}: {n}", d.name);
        }
        for n in rules.probe {
            assert!(d.identify.contains(n), "{}: {n}", d.name);
            assert_ne!(rules.software, Some(*n), "{}: {n}", d.name);
        }
    }
}

#[test]
fn a_bus_line_rates_are_its_families_rates() {
    for bus in BusProtocol::ALL {
        let all: std::collections::BTreeSet<u32> = bus
            .families()
            .flat_map(|f| f.descriptor().line_rates.rates.iter().copied())
            .collect();
        let mut want: Vec<u32> = all.into_iter().collect();
        want.reverse();
        assert_eq!(bus.line_rates(), want.as_slice(), "{bus}");
    }
}

/// The device type code: LUSTBUS families read 91-TYPE, the others name
/// none and fall back on it; learned ids are told by the one prefix every
/// learned file name starts with.
#[test]
fn device_type_code_and_learned_ids() {
    for f in Family::ALL {
        let d = f.descriptor();
        assert_eq!(d.device_type_code(), d.type_code.unwrap_or(TYPE), "{f}");
        if let Some(l) = d.learning {
            assert!(Learning::is_learned_id(&l.file_prefix(None)), "{f}");
        }
    }
    assert!(!Learning::is_learned_id("lust-mc6000"));
}

/// A learned file is found by the prefix of the TYPE it was named for,
/// whatever characters the TYPE has: both slug it the one way.
#[test]
fn a_learned_file_starts_with_the_prefix_of_its_type() {
    assert_eq!(Learning::type_slug(Some("MC 6000/A")), "MC6000A");
    assert_eq!(Learning::type_slug(Some("x-1_2")), "x-1_2");
    assert_eq!(Learning::type_slug(None), "unknown");
    for f in Family::ALL {
        let Some(l) = f.descriptor().learning else {
            continue;
        };
        for ty in [Some("MC 6000/A"), Some("1234"), Some("ä b"), None] {
            let id = l.file_id(ty, Some("2.1 b"), 7);
            assert!(id.starts_with(&l.file_prefix(ty)), "{f} {ty:?}: {id}");
        }
    }
}
