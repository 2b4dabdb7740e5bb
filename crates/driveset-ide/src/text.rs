//! Owns an open document's text as the editor holds it: edits applied
//! incrementally (a range replaced, or the whole text) and positions (line,
//! UTF-16 code unit: LSP's default position encoding, docs/editors.md) to
//! byte offsets and back. Plain data: the language server converts its
//! positions to and from [`LineCol`].

use std::ops::Range;

/// A position in a text: its line (0-based) and the column in UTF-16 code
/// units within that line (0-based), as an editor counts them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord)]
pub struct LineCol {
    /// The line.
    pub line: u32,
    /// The column, in UTF-16 code units.
    pub col: u32,
}

impl LineCol {
    /// The position at `line`, `col`.
    pub fn new(line: u32, col: u32) -> Self {
        LineCol { line, col }
    }
}

/// The text of one open document and where its lines start.
#[derive(Debug, Clone, Default)]
pub struct Text {
    text: String,
    line_starts: Vec<usize>,
}

impl Text {
    /// Wrap a full text.
    pub fn new(text: String) -> Self {
        let mut t = Text {
            text,
            line_starts: Vec::new(),
        };
        t.index();
        t
    }

    fn index(&mut self) {
        self.line_starts.clear();
        self.line_starts.push(0);
        for (i, b) in self.text.bytes().enumerate() {
            if b == b'\n' {
                self.line_starts.push(i + 1);
            }
        }
    }

    /// The text.
    pub fn as_str(&self) -> &str {
        &self.text
    }

    /// Replace `range` (or everything, for `None`) with `new`.
    pub fn apply(&mut self, range: Option<Range<LineCol>>, new: &str) {
        match range {
            None => self.text = new.to_string(),
            Some(r) => {
                let start = self.offset(r.start);
                let end = self.offset(r.end).max(start);
                self.text.replace_range(start..end, new);
            }
        }
        self.index();
    }

    /// The byte offset of a position (clamped to the line and the text).
    pub fn offset(&self, p: LineCol) -> usize {
        let Some(&start) = self.line_starts.get(p.line as usize) else {
            return self.text.len();
        };
        let end = self
            .line_starts
            .get(p.line as usize + 1)
            .map_or(self.text.len(), |e| e - 1);
        let line = &self.text[start..end];
        let mut units = 0u32;
        for (i, c) in line.char_indices() {
            if units >= p.col {
                return start + i;
            }
            units += c.len_utf16() as u32;
        }
        end
    }

    /// The position of a byte offset.
    pub fn position(&self, offset: usize) -> LineCol {
        let offset = offset.min(self.text.len());
        let line = match self.line_starts.binary_search(&offset) {
            Ok(i) => i,
            Err(i) => i.saturating_sub(1),
        };
        let start = self.line_starts.get(line).copied().unwrap_or(0);
        let mut o = offset;
        while !self.text.is_char_boundary(o) {
            o -= 1;
        }
        let col: usize = self.text[start..o].chars().map(char::len_utf16).sum();
        LineCol::new(line as u32, col as u32)
    }

    /// The positions of a byte span.
    pub fn range(&self, span: Range<usize>) -> Range<LineCol> {
        self.position(span.start)..self.position(span.end)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn incremental_edits_in_utf16_units() {
        let mut t = Text::new("a = \"ä😀x\"\nb = 1\n".into());
        // the 😀 is two UTF-16 units: x is at character 7
        assert_eq!(t.offset(LineCol::new(0, 7)), "a = \"ä😀".len());
        t.apply(Some(LineCol::new(1, 4)..LineCol::new(1, 5)), "22");
        assert_eq!(t.as_str(), "a = \"ä😀x\"\nb = 22\n");
        assert_eq!(t.position(t.as_str().len()), LineCol::new(2, 0));
        // the lines as the editor analysis reads them
        assert_eq!(t.as_str().split('\n').nth(1), Some("b = 22"));
        t.apply(Some(LineCol::new(0, 0)..LineCol::new(1, 0)), "");
        assert_eq!(t.as_str(), "b = 22\n");
        assert_eq!(crate::analysis::line_span(t.as_str(), 2), 0..7);
    }

    proptest::proptest! {
        /// Random edit sequences never panic; the end of the text maps to a
        /// position and back to the end.
        #[test]
        fn random_edit_sequences_never_panic(
            start in "[a-z =\"\\n\u{e9}\u{1F600}]{0,40}",
            edits in proptest::collection::vec(
                (0u32..6, 0u32..50, 0u32..6, 0u32..50, "[a-z\\n\u{e9}\u{1F600}]{0,5}", proptest::prelude::any::<bool>()),
                0..20,
            ),
        ) {
            let mut t = Text::new(start);
            for (l0, c0, l1, c1, new, whole) in edits {
                let range = (!whole).then(|| LineCol::new(l0, c0)..LineCol::new(l1, c1));
                t.apply(range, &new);
                let n = t.as_str().len();
                let p = t.position(n);
                proptest::prop_assert_eq!(t.offset(p), n);
            }
        }
    }
}
