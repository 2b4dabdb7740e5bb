//! The 100-drive line of the line benchmark (`line.rs`) and the
//! rehearsal benchmark (`crates/driveset-cli/benches/rehearse.rs`): its
//! manifest and sets, written into a directory. 25 MC6000 on LUSTBUS
//! 19200, 25 VF1000 on LUSTBUS 9600, 25 Tmd on LECOM 9600, 25 ECS on CAN
//! 500 kbit/s; sets = the demo line's bases plus a per-drive overlay.

use std::path::Path;

/// The buses: name, port, protocol, rate line, base set.
pub const BUSES: [(&str, &str, &str, &str, &str); 4] = [
    // name, port, protocol, rate line, base set
    (
        "mc",
        "sim://mc6000",
        "lustbus",
        "baud = 19200",
        "mc6000-base.toml",
    ),
    (
        "vf",
        "sim://vf1000",
        "lustbus",
        "baud = 9600",
        "vf1000-base.toml",
    ),
    (
        "tmd",
        "sim://tmd?c0001=3",
        "lecom",
        "baud = 9600",
        "tmd-base.toml",
    ),
    (
        "ecs",
        "sim://ecs",
        "can",
        "bitrate = 500000",
        "ecs-base.toml",
    ),
];

/// Write the manifest (`line.toml`) and `per_bus` sets a bus into `dir`;
/// the manifest's path.
pub fn write_line(dir: &Path, per_bus: usize) -> std::path::PathBuf {
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../parameter-sets/demo-line/sets");
    let base = base.canonicalize().expect("demo-line sets");
    let mut m = String::from("[line]\nname = \"bench-line\"\n\n");
    for (name, port, proto, rate, _) in BUSES {
        m.push_str(&format!(
            "[[bus]]\nname = \"{name}\"\nport = \"{port}\"\nprotocol = \"{proto}\"\n{rate}\n\n"
        ));
    }
    for (bus, _, _, _, base_set) in BUSES {
        let schema = std::fs::read_to_string(base.join(base_set))
            .unwrap()
            .lines()
            .find(|l| l.starts_with("schema = "))
            .unwrap()
            .replace("../../", &format!("{}/../../", base.display()));
        let addrs: Vec<u8> = match bus {
            "tmd" => (1..=99).filter(|a| a % 10 != 0).take(per_bus).collect(),
            _ => (1..=per_bus as u8).collect(),
        };
        for a in addrs {
            let own = match bus {
                // the bus runs at 19200 (BUSES): the set's 81-SBAUD says so
                // too, or the manifest check refuses it (mc6000-base.toml
                // gives 9600, for the demo line's bus shared with VF1000s)
                "mc" => format!(
                    "SADDR = {a}\nSBAUD = \"19200 Baud\"\nKPSC1 = \"0.0{}25 Nm/(rad/s)\"\n",
                    a % 9 + 1
                ),
                "vf" => format!("SIOA = {a}\n5 = \"{}.5 Hz\"\n", 10 + a),
                "tmd" => format!("C0012 = \"{}.0 s\"\n", 2 + a % 7),
                _ => format!("C5001 = \"{} rpm\"\n", 3000 + 10 * u32::from(a)),
            };
            let file = format!("{bus}-{a}.toml");
            std::fs::write(
                dir.join(&file),
                format!(
                    "{schema}\nextends = \"{}\"\n\n[values]\n{own}",
                    base.join(base_set).display()
                ),
            )
            .unwrap();
            m.push_str(&format!(
                "[[drive]]\nname = \"{bus}-{a}\"\nbus = \"{bus}\"\naddress = {a}\nset = \"{file}\"\n\n"
            ));
        }
    }
    let path = dir.join("line.toml");
    std::fs::write(&path, m).unwrap();
    path
}
