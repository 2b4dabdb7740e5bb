//! Owns the mapping between `file://` URIs (RFC 8089, percent-encoded
//! UTF-8) and the paths the set reader opens.

use std::path::{Path, PathBuf};

use lsp_types::Uri;

/// The path of a `file://` URI; `None` for another scheme or a bad escape.
pub fn to_path(uri: &Uri) -> Option<PathBuf> {
    let rest = uri.as_str().strip_prefix("file://")?;
    // an authority other than empty or localhost is another machine's file
    let rest = rest.strip_prefix("localhost").unwrap_or(rest);
    if !rest.starts_with('/') {
        return None;
    }
    let bytes = rest.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        match bytes[i] {
            b'%' => {
                let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
                out.push(u8::from_str_radix(hex, 16).ok()?);
                i += 3;
            }
            b'?' | b'#' => break,
            b => {
                out.push(b);
                i += 1;
            }
        }
    }
    Some(PathBuf::from(String::from_utf8(out).ok()?))
}

/// The `file://` URI of an absolute path.
pub fn from_path(path: &Path) -> Option<Uri> {
    let s = path.to_str()?;
    if !s.starts_with('/') {
        return None;
    }
    let mut out = String::from("file://");
    for b in s.bytes() {
        if b.is_ascii_alphanumeric() || b"/-._~".contains(&b) {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_round_trip_through_percent_encoding() {
        let p = Path::new("/tmp/sets dir/ä#1.toml");
        let u = from_path(p).unwrap();
        assert_eq!(u.as_str(), "file:///tmp/sets%20dir/%C3%A4%231.toml");
        assert_eq!(to_path(&u).unwrap(), p);
        let u: Uri = "file://localhost/a/b.yaml".parse().unwrap();
        assert_eq!(to_path(&u).unwrap(), Path::new("/a/b.yaml"));
        let u: Uri = "untitled:Untitled-1".parse().unwrap();
        assert_eq!(to_path(&u), None);
    }
}
