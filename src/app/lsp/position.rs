//! Places in a buffer, both ways: felt counts byte offsets into UTF-8 text, the protocol counts
//! lines and UTF-16 code units within a line (its default encoding, the only one every client
//! speaks). A script with a `°` or an emoji in a comment or string must still have its errors
//! underlined in the right columns, so every conversion goes through here.

use lsp_types::{Position, Range};

/// The start of each line of a text, to turn offsets into positions without rescanning it.
pub struct LineIndex {
    line_starts: Vec<usize>,
}

impl LineIndex {
    pub fn new(text: &str) -> LineIndex {
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        LineIndex { line_starts }
    }

    /// The position of a byte offset (clamped to the text, and to a character boundary).
    pub fn position(&self, text: &str, offset: usize) -> Position {
        let mut offset = offset.min(text.len());
        while !text.is_char_boundary(offset) {
            offset -= 1;
        }
        let line = match self.line_starts.binary_search(&offset) {
            Ok(i) => i,
            Err(i) => i - 1,
        };
        let start = self.line_starts[line];
        let column: usize = text[start..offset].chars().map(char::len_utf16).sum();
        Position::new(line as u32, column as u32)
    }

    pub fn range(&self, text: &str, start: usize, end: usize) -> Range {
        Range::new(self.position(text, start), self.position(text, end))
    }

    /// The byte offset of a position. A line past the end is the end of the text; a column past
    /// the end of its line is the line's end; one inside a character is that character's start.
    pub fn offset(&self, text: &str, position: Position) -> usize {
        let Some(&start) = self.line_starts.get(position.line as usize) else {
            return text.len();
        };
        let end = self
            .line_starts
            .get(position.line as usize + 1)
            .map_or(text.len(), |&next| next - 1);
        let mut units = 0usize;
        for (i, c) in text[start..end].char_indices() {
            if units >= position.character as usize {
                return start + i;
            }
            units += c.len_utf16();
            if units > position.character as usize {
                return start + i;
            }
        }
        end
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_count_utf16_units_and_offsets_come_back() {
        // `°` is 2 bytes and 1 UTF-16 unit; `𝜌` is 4 bytes and 2 units.
        let text = "a°b\n𝜌 = 1;\n";
        let index = LineIndex::new(text);
        assert_eq!(index.position(text, 3), Position::new(0, 2)); // `b`
        assert_eq!(index.position(text, 5), Position::new(1, 0));
        assert_eq!(index.position(text, 9), Position::new(1, 2)); // the space after 𝜌
        for offset in [0, 1, 3, 4, 5, 9, 10, text.len()] {
            assert_eq!(index.offset(text, index.position(text, offset)), offset);
        }
        // Inside the surrogate pair: the character's start. Past the line: its end.
        assert_eq!(index.offset(text, Position::new(1, 1)), 5);
        assert_eq!(index.offset(text, Position::new(0, 99)), 4);
        assert_eq!(index.offset(text, Position::new(9, 0)), text.len());
    }
}
