//! `driveset validate --format junit`: JUnit XML for CI test reports (one
//! testsuite per file, one testcase per finding, failures carrying
//! file:line:col), parsed with an XML parser.

use driveset_test_support::driveset;

fn write(dir: &std::path::Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

#[test]
fn junit_has_a_suite_per_file_and_a_case_per_finding() {
    let tmp = tempfile::tempdir().unwrap();
    let bad = write(
        tmp.path(),
        "bad<&>.toml",
        "schema = \"lenze-tmd\"\n[values]\nC0011 = \"999 Hz\"\nC9999 = 1\n",
    );
    let good = write(
        tmp.path(),
        "good.toml",
        "schema = \"lenze-tmd\"\n[values]\nC0011 = \"60 Hz\"\n",
    );
    let broken = write(
        tmp.path(),
        "broken.toml",
        "schema = \"lenze-tmd\"\n[values\n",
    );
    let out = driveset()
        .args(["validate", "--format", "junit", &bad, &good, &broken])
        .assert()
        .code(2)
        .get_output()
        .stdout
        .clone();
    let xml = String::from_utf8(out).unwrap();
    let doc = roxmltree::Document::parse(&xml).unwrap_or_else(|e| panic!("{e}\n{xml}"));
    let root = doc.root_element();
    assert_eq!(root.tag_name().name(), "testsuites");
    assert_eq!(root.attribute("failures"), Some("2"));
    assert_eq!(root.attribute("errors"), Some("1"));
    let suites: Vec<_> = root
        .children()
        .filter(|n| n.has_tag_name("testsuite"))
        .collect();
    let names: Vec<_> = suites
        .iter()
        .map(|s| s.attribute("name").unwrap())
        .collect();
    assert_eq!(names, [bad.as_str(), good.as_str(), broken.as_str()]);

    // the bad file: one testcase per finding, failures point at file:line:col
    let cases: Vec<_> = suites[0]
        .children()
        .filter(|n| n.has_tag_name("testcase"))
        .collect();
    assert_eq!(cases.len(), 2);
    assert_eq!(suites[0].attribute("tests"), Some("2"));
    assert_eq!(suites[0].attribute("failures"), Some("2"));
    let failures: Vec<_> = cases
        .iter()
        .map(|c| {
            assert_eq!(c.attribute("classname"), Some(bad.as_str()));
            assert_eq!(c.attribute("file"), Some(bad.as_str()));
            c.children().find(|n| n.has_tag_name("failure")).unwrap()
        })
        .collect();
    assert_eq!(failures[0].attribute("type"), Some("out-of-range"));
    let msg = failures[0].attribute("message").unwrap();
    assert!(msg.starts_with(&format!("{bad}:3:9: ")), "{msg}");
    assert!(msg.contains("999 Hz"), "{msg}");
    assert_eq!(cases[0].attribute("line"), Some("3"));
    let text = failures[0].text().unwrap();
    assert!(text.contains("help: "), "{text}");
    assert!(text.contains("C0011 = \"999 Hz\""), "{text}");
    assert_eq!(failures[1].attribute("type"), Some("unknown-code"));
    assert!(
        failures[1]
            .attribute("message")
            .unwrap()
            .starts_with(&format!("{bad}:4:1: "))
    );

    // the clean file: one passing testcase
    let ok: Vec<_> = suites[1].children().filter(|n| n.is_element()).collect();
    assert_eq!(ok.len(), 1);
    assert_eq!(ok[0].attribute("name"), Some("valid"));
    assert!(ok[0].children().all(|n| !n.is_element()));

    // the unparsable file: an error testcase with its place
    let err = suites[2]
        .descendants()
        .find(|n| n.has_tag_name("error"))
        .unwrap();
    assert_eq!(err.attribute("type"), Some("input-error"));
    assert!(
        err.attribute("message")
            .unwrap()
            .starts_with(&format!("{broken}:2:"))
    );
}

#[test]
fn junit_of_clean_sets_exits_zero() {
    let out = driveset()
        .args(["validate", "--format", "junit", "parameter-sets/tmd"])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let xml = String::from_utf8(out).unwrap();
    let doc = roxmltree::Document::parse(&xml).unwrap();
    assert_eq!(doc.root_element().attribute("failures"), Some("0"));
    assert!(
        doc.descendants()
            .filter(|n| n.has_tag_name("testsuite"))
            .count()
            >= 3
    );
    assert_eq!(
        doc.descendants()
            .filter(|n| n.has_tag_name("failure"))
            .count(),
        0
    );
}
