//! Property tests: the set parser never panics; raw -> display -> parse is the identity.

use std::path::Path;

use driveset_schema::value::{
    ALL_TYPES, Repr, ValueType, decimal_to_raw, float_text_to_raw, raw_to_engineering,
};
use driveset_schema::*;
use proptest::prelude::*;

fn fixtures() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures")
}

const VALID_TOML: &str = "schema = \"fictional-test.toml\"\nextends = \"base.toml\"\n[values]\nC0011 = \"60.0 Hz\"\nC0007 = { E1 = \"JOG1\", E2 = 2 }\n\"C0039/1\" = -3.5\nC0135 = { quick_stop = true }\nC0200 = \"abc\"\nC0400 = 1.5\ngain = 0.1\n";
const VALID_YAML: &str = "schema: fictional-test.toml\nextends: [base.toml]\nvalues:\n  C0011: 60.0 Hz\n  C0007: {E1: JOG1, E2: 2}\n  C0039/1: -3.5\n  C0135:\n    quick_stop: true\n  C0200: \"abc\"\n";

fn run(name: &str, text: &str) {
    static REG: std::sync::OnceLock<Registry> = std::sync::OnceLock::new();
    let mut r = REG.get_or_init(|| Registry::builtin().unwrap()).clone();
    if let Ok(l) = load_set_str(&fixtures().join(name), text, &mut r) {
        for f in &l.findings {
            let _ = f.render_human();
        }
        if let Some(s) = &l.resolved {
            let _ = s.fingerprint();
            if let Some(schema) = &l.schema {
                let _ = export(s, schema, None, Format::Yaml);
                let _ = diff_defaults(s, schema);
            }
        }
    }
}

fn mutate(base: &str, edits: &[(usize, u8, u8)]) -> String {
    let mut bytes = base.as_bytes().to_vec();
    for &(pos, op, b) in edits {
        let i = pos % (bytes.len() + 1);
        match op % 3 {
            0 if i < bytes.len() => bytes[i] = b,
            1 => bytes.insert(i, b),
            _ if i < bytes.len() => {
                bytes.remove(i);
            }
            _ => {}
        }
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn parser_never_panics_on_arbitrary_text(s in "\\PC{0,200}") {
        run("p.toml", &s);
        run("p.yaml", &s);
    }

    #[test]
    fn parser_never_panics_on_mutated_sets(edits in proptest::collection::vec((0usize..400, 0u8..3, b' '..=b'~'), 1..8)) {
        run("p.toml", &mutate(VALID_TOML, &edits));
        run("p.yaml", &mutate(VALID_YAML, &edits));
    }

    #[test]
    fn raw_display_parse_round_trip(idx in 0usize..ALL_TYPES.len(), seed in any::<u64>(), width in prop_oneof![Just(1u8), Just(2), Just(4)]) {
        let ty: ValueType = ALL_TYPES[idx];
        let w = (ty == ValueType::VH).then_some(width);
        match ty.repr() {
            Repr::Scaled(_) => {
                let (lo, hi) = ty.raw_range(w).unwrap();
                let span = (hi - lo) as u64 + 1;
                let raw = lo + (seed % span) as i64;
                let text = raw_to_engineering(ty, raw);
                let d = Decimal::parse(&text).unwrap();
                prop_assert_eq!(decimal_to_raw(ty, w, &d), Ok(raw), "{} {}", ty.name(), text);
            }
            Repr::Float => {
                let bits = seed as u32;
                prop_assume!(f32::from_bits(bits).is_finite());
                let text = raw_to_engineering(ty, i64::from(bits));
                prop_assert_eq!(float_text_to_raw(&text), Ok(i64::from(bits)), "{}", text);
            }
            Repr::Text | Repr::Octets => {}
        }
    }
}

#[test]
fn edge_raw_values_round_trip() {
    for ty in ALL_TYPES {
        for w in [None, Some(1u8), Some(4)] {
            let Some((lo, hi)) = ty.raw_range(w) else {
                continue;
            };
            if ty.repr() == Repr::Float {
                continue;
            }
            for raw in [lo, hi, 0, 1, hi - 1] {
                let text = raw_to_engineering(ty, raw);
                assert_eq!(
                    decimal_to_raw(ty, w, &Decimal::parse(&text).unwrap()),
                    Ok(raw),
                    "{} {text}",
                    ty.name()
                );
            }
        }
    }
}

/// Everything a set renders to outside the 0600 journal: fingerprint,
/// canonical text, the three exports, every validate message rendered
/// (human with snippet, and one-line), and the diffs against a set without
/// the secret and against one with another frequency (semantic and
/// unified).
fn rendered(text: &str, other: &ResolvedSet) -> Vec<String> {
    static REG: std::sync::OnceLock<Registry> = std::sync::OnceLock::new();
    let mut r = REG.get_or_init(|| Registry::builtin().unwrap()).clone();
    let l = load_set_str(Path::new("secret.toml"), text, &mut r).expect("loads");
    let mut out: Vec<String> = l
        .findings
        .iter()
        .flat_map(|f| [f.render_human(), f.to_string()])
        .collect();
    let schema = l.schema.expect("schema");
    if let Some(s) = &l.resolved {
        out.push(s.fingerprint());
        out.push(s.canonical());
        for fmt in [Format::Toml, Format::Yaml, Format::Json] {
            out.push(export(s, &schema, Some("t"), fmt));
        }
        for (x, y) in [(s, other), (other, s)] {
            out.push(diff(x, y, &schema).expect("diff").to_string());
            out.push(unified_diff(x, y, &schema, "x", "y"));
        }
        out.push(diff_defaults(s, &schema).expect("defaults").to_string());
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Tmd C0094 (user password, 0..=999, role `password`): any two values,
    /// valid or not, render the same everywhere (the secret is present /
    /// absent, never its value).
    #[test]
    fn outputs_do_not_depend_on_a_secrets_value(
        a in 0u32..=999,
        b in 0u32..=999,
        big_a in 1000u32..=1_000_000,
        big_b in 1000u32..=1_000_000,
        freq in 0u32..=240,
        alias in any::<bool>(),
    ) {
        let key = if alias { "user_password" } else { "C0094" };
        let text = |pw: u32| {
            format!("schema = \"lenze-tmd\"\n[values]\nC0011 = \"{freq} Hz\"\n{key} = {pw}  # the password\nC0012 = 5\n")
        };
        let mut r = Registry::builtin().unwrap();
        let other = load_set_str(
            Path::new("other.toml"),
            "schema = \"lenze-tmd\"\n[values]\nC0011 = \"61 Hz\"\nC0012 = 5\n",
            &mut r,
        )
        .unwrap()
        .resolved
        .unwrap();
        let ra = rendered(&text(a), &other);
        prop_assert_eq!(&ra, &rendered(&text(b), &other));
        for s in &ra {
            prop_assert!(!s.contains(&format!("{key} = {a}")), "{}", s);
            prop_assert!(!s.contains(&format!("C0094 {}\n", a * 10_000)), "{}", s);
        }
        // out of range: the findings say so, without the value
        let rb = rendered(&text(big_a), &other);
        prop_assert_eq!(&rb, &rendered(&text(big_b), &other));
        prop_assert!(rb.iter().any(|s| s.contains("C0094 (user_password) = <secret>: the value is not valid for this code (out-of-range)")));
        for s in &rb {
            prop_assert!(!s.contains(&format!("{key} = {big_a}")), "{}", s);
            prop_assert!(!s.contains(&format!("C0094 {big_a}")), "{}", s);
        }
    }
}
