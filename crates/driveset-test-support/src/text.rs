//! Checks on what a command printed.

/// Whether `text` shows `value` as a value of its own: not inside another
/// number, word, hash or decimal fraction (a timing `0.742 s` or a
/// fingerprint holding the digits does not count, so the check cannot
/// fail by chance).
pub fn shows_value(text: &str, value: &str) -> bool {
    let part = |c: Option<char>| c.is_some_and(|c| c.is_ascii_alphanumeric() || c == '.');
    text.match_indices(value).any(|(i, _)| {
        !part(text[..i].chars().next_back()) && !part(text[i + value.len()..].chars().next())
    })
}
