//! Colour in rendered text, or none: the ANSI styles the reports and the
//! CLI's own lines use (bold, red errors, green / red / yellow diff lines).
//! Whether to colour is the caller's to decide (a terminal, `NO_COLOR`);
//! a [`Style`] only paints.

use driveset_schema::error::Colour;

/// Colour on or off.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Style {
    colour: Colour,
}

const RED: &str = "\x1b[1;31m";
const BOLD: &str = "\x1b[1m";
const GREEN: &str = "\x1b[32m";
const YELLOW: &str = "\x1b[33m";
const DIM_RED: &str = "\x1b[31m";
const RESET: &str = "\x1b[0m";

impl Style {
    /// No colour.
    pub const PLAIN: Style = Style {
        colour: Colour::Plain,
    };

    /// ANSI colours, for a terminal.
    pub const COLOUR: Style = Style {
        colour: Colour::Styled,
    };

    /// The style of `colour`.
    pub fn of(colour: Colour) -> Style {
        Style { colour }
    }

    /// Whether it colours, as the schema crate's renderers take it.
    pub fn colour(self) -> Colour {
        self.colour
    }

    fn paint(self, code: &str, text: &str) -> String {
        match self.colour {
            Colour::Styled => format!("{code}{text}{RESET}"),
            Colour::Plain => text.to_string(),
        }
    }

    /// Bold red.
    pub fn error(self, text: &str) -> String {
        self.paint(RED, text)
    }
    /// Bold.
    pub fn bold(self, text: &str) -> String {
        self.paint(BOLD, text)
    }
    /// Green (added lines).
    pub fn added(self, text: &str) -> String {
        self.paint(GREEN, text)
    }
    /// Red (removed lines).
    pub fn removed(self, text: &str) -> String {
        self.paint(DIM_RED, text)
    }
    /// Yellow (changed lines).
    pub fn changed(self, text: &str) -> String {
        self.paint(YELLOW, text)
    }
}

/// `n thing` / `n things`.
pub fn plural(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paints_only_in_colour() {
        assert_eq!(Style::PLAIN.error("x"), "x");
        assert_eq!(Style::COLOUR.error("x"), "\x1b[1;31mx\x1b[0m");
        assert_eq!(Style::COLOUR.added("x"), "\x1b[32mx\x1b[0m");
        assert_eq!(Style::of(Colour::Plain), Style::PLAIN);
    }

    #[test]
    fn plurals() {
        assert_eq!(plural(1, "file", "files"), "1 file");
        assert_eq!(plural(0, "file", "files"), "0 files");
    }
}
