//! Tests of the schema model: number lists, learned tables.

use super::{number_list_text, parse_number_list};

#[test]
fn number_lists_parse_and_print_back() {
    let n = parse_number_list("1-3, 7,5,100-102").unwrap();
    assert_eq!(
        n.iter().copied().collect::<Vec<_>>(),
        [1, 2, 3, 5, 7, 100, 101, 102]
    );
    assert_eq!(number_list_text(&n), "1-3,5,7,100-102");
    assert_eq!(
        number_list_text(&parse_number_list("1-999").unwrap()),
        "1-999"
    );
    assert_eq!(
        parse_number_list("5-1").unwrap_err(),
        "`5-1`: a range goes up"
    );
    assert_eq!(
        parse_number_list("x").unwrap_err(),
        "`x` is not a number or a range like 1-99"
    );
    assert_eq!(parse_number_list(" , ").unwrap_err(), "names no parameter");
}

#[test]
fn a_learned_table_is_read_and_not_inherited() {
    use crate::error::SourceFile;
    let mut reg = super::Registry::builtin().unwrap();
    let text = "[schema]\nid = \"l\"\ntitle = \"t\"\nextends = \"lust-vf1000\"\n\n[schema.learned]\nasked = \"1-9,11\"\n";
    let s = reg.add_source(SourceFile::new("l.toml", text)).unwrap();
    let l = s.learned.as_ref().unwrap();
    assert_eq!(number_list_text(&l.asked), "1-9,11");
    assert_eq!(&*l.text, text);
    let over = "[schema]\nid = \"m\"\ntitle = \"t\"\nextends = \"l\"\n";
    let m = reg.add_source(SourceFile::new("m.toml", over)).unwrap();
    assert!(m.learned.is_none());
    let bad = "[schema]\nid = \"b\"\ntitle = \"t\"\nextends = \"lust-vf1000\"\n\n[schema.learned]\nasked = \"9-1\"\n";
    let e = reg.add_source(SourceFile::new("b.toml", bad)).unwrap_err();
    assert_eq!(e.message, "[schema.learned] asked: `9-1`: a range goes up");
    assert_eq!(e.location.line, 7);
}

#[test]
fn an_offline_schema_is_named_by_id_or_file() {
    let mut r = super::Registry::builtin().unwrap();
    assert_eq!(r.id_or_file("lenze-tmd").unwrap().id, "lenze-tmd");
    let fixture = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../parameter-sets/fixtures/fictional-vf1000-demo.toml"
    );
    assert_eq!(r.id_or_file(fixture).unwrap().id, "fictional-vf1000-demo");
    let e = r.id_or_file("no-such-schema").unwrap_err().to_string();
    assert!(
        e.starts_with("--schema no-such-schema: no built-in schema has that id and no such file exists; built-in ids: "),
        "{e}"
    );
    let e = r
        .id_or_file(env!("CARGO_MANIFEST_DIR"))
        .unwrap_err()
        .to_string();
    assert!(e.contains(": cannot load the schema file: "), "{e}");
}
