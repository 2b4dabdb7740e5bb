//! Bytes as text, both ways: hex text (a command line's or a file's), and
//! the escaped ASCII form `driveset encode` prints and `driveset decode
//! --ascii` reads (`<EOT>@00112<ENQ>`, `<xx>` for other bytes). Pure: the
//! CLI reads the files and stdin; the spaced hex form is the engine's
//! decode's (`hex_spaced`).

use std::fmt::Write as _;

/// Names of the control characters in the escaped ASCII form.
const NAMES: [(u8, &str); 12] = [
    (0x00, "NUL"),
    (0x02, "STX"),
    (0x03, "ETX"),
    (0x04, "EOT"),
    (0x05, "ENQ"),
    (0x06, "ACK"),
    (0x07, "BEL"),
    (0x0A, "LF"),
    (0x0D, "CR"),
    (0x15, "NAK"),
    (0x1B, "ESC"),
    (0x7F, "DEL"),
];

/// Parses hex text: pairs of hex digits separated by anything blank, `0x`
/// prefixes, `,` and `#` comments to the end of the line. Errors name the
/// line and column (1-based) of `origin`.
pub fn parse_hex(text: &str, origin: &str) -> Result<Vec<u8>, String> {
    // One pass over each line; columns are counted as the scan goes (a
    // column recomputed from the line start for every token made a long
    // one-line capture quadratic: 1 MB took seconds).
    let mut out = Vec::with_capacity(text.len() / 3 + 1);
    for (ln, line) in text.lines().enumerate() {
        let line = match line.find('#') {
            Some(i) => &line[..i],
            None => line,
        };
        let mut chars = line.chars().peekable();
        // 1-based column of the next character `chars` yields
        let mut col = 1usize;
        while let Some(&c) = chars.peek() {
            if c.is_whitespace() || c == ',' {
                chars.next();
                col += 1;
                continue;
            }
            let tok_col = col;
            let mut digits = String::new();
            // optional 0x prefix
            if c == '0' {
                chars.next();
                col += 1;
                if matches!(chars.peek(), Some('x' | 'X')) {
                    chars.next();
                    col += 1;
                } else {
                    digits.push('0');
                }
            }
            while let Some(&d) = chars.peek() {
                if d.is_whitespace() || d == ',' {
                    break;
                }
                if !d.is_ascii_hexdigit() {
                    return Err(format!(
                        "{origin}:{}:{col}: {d:?} is not a hex digit; write bytes as hex pairs like `04 40 30`, comments after `#`",
                        ln + 1
                    ));
                }
                digits.push(d);
                chars.next();
                col += 1;
            }
            if digits.is_empty() {
                return Err(format!(
                    "{origin}:{}:{tok_col}: `0x` without hex digits after it",
                    ln + 1
                ));
            }
            if !digits.len().is_multiple_of(2) {
                return Err(format!(
                    "{origin}:{}:{tok_col}: `{digits}` has an odd number of hex digits ({}); write every byte as two digits (`0{}` ...)",
                    ln + 1,
                    digits.len(),
                    &digits[..1]
                ));
            }
            for k in (0..digits.len()).step_by(2) {
                // Two ASCII hex digits: always parses.
                out.push(u8::from_str_radix(&digits[k..k + 2], 16).unwrap_or(0));
            }
        }
    }
    Ok(out)
}

/// Parses the escaped ASCII form: printable characters stand for themselves,
/// `<NAME>` for a control character (`<EOT>`, `<STX>`, `<CR>` ...) and `<xx>`
/// for any byte in hex (a literal `<` is `<3C>`).
pub fn parse_ascii(text: &str, origin: &str) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    let mut rest = text;
    let mut col = 1usize;
    while let Some(c) = rest.chars().next() {
        if c == '<' {
            let Some(end) = rest.find('>') else {
                return Err(format!(
                    "{origin}:1:{col}: `<` opens no escape; close it with `>` (`<EOT>`, `<04>`), write a literal `<` as `<3C>`"
                ));
            };
            let name = &rest[1..end];
            let byte = NAMES
                .iter()
                .find(|(_, n)| n.eq_ignore_ascii_case(name))
                .map(|(b, _)| *b)
                .or_else(|| {
                    (name.len() == 2)
                        .then(|| u8::from_str_radix(name, 16).ok())
                        .flatten()
                });
            let Some(byte) = byte else {
                let names: Vec<&str> = NAMES.iter().map(|(_, n)| *n).collect();
                return Err(format!(
                    "{origin}:1:{col}: unknown escape `<{name}>`; use two hex digits (`<04>`) or one of {}",
                    names.join(", ")
                ));
            };
            out.push(byte);
            col += name.chars().count() + 2;
            rest = &rest[end + 1..];
        } else {
            if !c.is_ascii() {
                return Err(format!(
                    "{origin}:1:{col}: {c:?} is not ASCII; write other bytes as `<xx>`"
                ));
            }
            out.push(c as u8);
            col += 1;
            rest = &rest[c.len_utf8()..];
        }
    }
    Ok(out)
}

/// The escaped ASCII form: `<EOT>@00112<ENQ>`.
pub fn escaped(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len() * 2);
    for &b in bytes {
        if let Some((_, n)) = NAMES.iter().find(|(x, _)| *x == b) {
            let _ = write!(s, "<{n}>");
        } else if (0x20..0x7F).contains(&b) && b != b'<' {
            s.push(b as char);
        } else {
            let _ = write!(s, "<{b:02X}>");
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hex_forms() {
        assert_eq!(
            parse_hex("04 0x40 3031 # c\n,05", "x").unwrap(),
            vec![4, 0x40, 0x30, 0x31, 5]
        );
        assert!(parse_hex("04 4", "x").unwrap_err().contains("x:1:4"));
        assert!(parse_hex("\n 0g", "x").unwrap_err().contains("x:2:3"));
    }

    #[test]
    fn ascii_round_trip() {
        let b = [4u8, b'@', b'0', 5, b'<', 0x91];
        assert_eq!(escaped(&b), "<EOT>@0<ENQ><3C><91>");
        assert_eq!(parse_ascii(&escaped(&b), "x").unwrap(), b);
        assert!(parse_ascii("<FOO>", "x").is_err());
        assert!(parse_ascii("ab<", "x").unwrap_err().contains("x:1:3"));
    }
}
