//! Text inputs (ray files, OBJ scenes) read with every line bounded: a
//! file without a newline (`/dev/zero`, a binary file, a runaway
//! generator) is refused at its first over-long line or NUL byte, named
//! by its line, instead of being read until memory runs out.

use std::io::{BufRead, Read};

/// The longest line a text input may have, in bytes: an OBJ line or a
/// ray is well under 200; a megabyte is no text a person wrote.
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// Why a text input could not be read as text.
#[derive(Debug)]
pub enum TextError {
    Io(std::io::Error),
    /// Line `line` (1-based) is longer than [`MAX_LINE_BYTES`].
    LongLine {
        line: usize,
    },
    /// Line `line` holds a NUL byte; `head` is the input's first bytes
    /// (up to 64), for telling UTF-16 or UTF-32 from binary data.
    Nul {
        line: usize,
        head: Vec<u8>,
    },
}

impl std::fmt::Display for TextError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TextError::Io(e) => write!(f, "{e}"),
            TextError::LongLine { .. } => write!(
                f,
                "a line longer than {} MiB without a newline: not a text file",
                MAX_LINE_BYTES >> 20
            ),
            TextError::Nul { line, head } => write!(f, "{}", not_text(head, *line)),
        }
    }
}

/// What a file that holds a NUL byte is, in words: UTF-32 or UTF-16 text
/// (by a byte-order mark, or NULs beside every character of an ASCII
/// start), NUL bytes only, or not text at all.
pub fn not_text(head: &[u8], line: usize) -> String {
    let units = |w: usize, first: usize| {
        let h = &head[..head.len() / w * w];
        h.len() >= 2 * w
            && h.chunks(w)
                .all(|c| c.iter().enumerate().all(|(k, &b)| (k == first) != (b == 0)))
    };
    let utf32 = head.starts_with(b"\xff\xfe\0\0")
        || head.starts_with(b"\0\0\xfe\xff")
        || units(4, 0)
        || units(4, 3);
    let utf16 = head.starts_with(b"\xff\xfe")
        || head.starts_with(b"\xfe\xff")
        || units(2, 0)
        || units(2, 1);
    if !head.is_empty() && head.iter().all(|&b| b == 0) {
        "it is not text: it starts with NUL bytes only".into()
    } else if utf32 {
        "it is UTF-32 text, which is not supported: save it as UTF-8 or ASCII".into()
    } else if utf16 {
        "it is UTF-16 text, which is not supported: save it as UTF-8 or ASCII".into()
    } else {
        format!("it is not text (a NUL byte on line {line})")
    }
}

/// Reads the lines of `input` one at a time, each without its `\n`, each
/// at most [`MAX_LINE_BYTES`] and free of NUL bytes.
pub struct Lines<R> {
    input: R,
    line: usize,
    head: Vec<u8>,
    done: bool,
    /// The last line ended at the end of the input, without a `\n`.
    unterminated: bool,
}

impl<R: BufRead> Lines<R> {
    pub fn new(input: R) -> Self {
        Lines {
            input,
            line: 0,
            head: Vec::new(),
            done: false,
            unterminated: false,
        }
    }

    /// The next line and its number (1-based), `None` at the end.
    pub fn next_line(&mut self) -> Result<Option<(usize, Vec<u8>)>, TextError> {
        if self.done {
            return Ok(None);
        }
        self.line += 1;
        let mut line = Vec::new();
        loop {
            let buf = match self.input.fill_buf() {
                Ok(b) => b,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(TextError::Io(e)),
            };
            if self.head.len() < 64 {
                let take = buf.len().min(64 - self.head.len());
                self.head.extend_from_slice(&buf[..take]);
            }
            if buf.is_empty() {
                self.done = true;
                self.unterminated = !line.is_empty();
                return Ok((!line.is_empty()).then_some((self.line, line)));
            }
            let end = buf.iter().position(|&b| b == b'\n');
            let part = &buf[..end.unwrap_or(buf.len())];
            if part.contains(&0) {
                return Err(TextError::Nul {
                    line: self.line,
                    head: self.head.clone(),
                });
            }
            if line.len() + part.len() > MAX_LINE_BYTES {
                return Err(TextError::LongLine { line: self.line });
            }
            line.extend_from_slice(part);
            let used = part.len() + end.map_or(0, |_| 1);
            self.input.consume(used);
            if end.is_some() {
                return Ok(Some((self.line, line)));
            }
        }
    }
}

/// Reads all of `input` as text whose every line is bounded: the bytes
/// as they are (a last line without a newline stays so).
pub fn read_text(input: impl Read) -> Result<Vec<u8>, TextError> {
    let mut lines = Lines::new(std::io::BufReader::with_capacity(1 << 16, input));
    let mut out = Vec::new();
    while let Some((_, line)) = lines.next_line()? {
        out.extend_from_slice(&line);
        out.push(b'\n');
    }
    if lines.unterminated {
        out.pop();
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_endless_line_is_refused_by_its_number() {
        let input = b"ok\n"
            .iter()
            .copied()
            .chain(std::iter::repeat_n(b'x', MAX_LINE_BYTES + 1));
        let bytes: Vec<u8> = input.collect();
        let e = read_text(&bytes[..]).unwrap_err();
        assert!(matches!(e, TextError::LongLine { line: 2 }), "{e}");
        // Endless input ends at the bound, not when memory runs out.
        let e = read_text(std::io::repeat(b'y')).unwrap_err();
        assert!(matches!(e, TextError::LongLine { line: 1 }), "{e}");
        let e = read_text(std::io::repeat(0)).unwrap_err();
        assert_eq!(
            e.to_string(),
            "it is not text: it starts with NUL bytes only"
        );
    }

    #[test]
    fn encodings_are_told_apart() {
        let utf16: Vec<u8> = "v 1 2 3\n".bytes().flat_map(|b| [b, 0]).collect();
        let utf32: Vec<u8> = "v 1 2 3\n".bytes().flat_map(|b| [b, 0, 0, 0]).collect();
        let utf32be: Vec<u8> = "v 1 2 3\n".bytes().flat_map(|b| [0, 0, 0, b]).collect();
        assert!(not_text(&utf16, 1).contains("UTF-16"));
        assert!(not_text(&utf32, 1).contains("UTF-32"));
        assert!(not_text(&utf32be, 1).contains("UTF-32"));
        assert!(not_text(b"\xff\xfe\0\0v\0\0\0", 1).contains("UTF-32"));
        assert!(not_text(b"v 1 2\0 3", 1).contains("a NUL byte on line 1"));
    }

    #[test]
    fn lines_keep_their_numbers_and_a_last_line_without_newline() {
        assert_eq!(read_text(&b"a\n\nb"[..]).unwrap(), b"a\n\nb");
        assert_eq!(read_text(&b"a\n\nb\n"[..]).unwrap(), b"a\n\nb\n");
        let mut l = Lines::new(&b"a\r\nb"[..]);
        assert_eq!(l.next_line().unwrap(), Some((1, b"a\r".to_vec())));
        assert_eq!(l.next_line().unwrap(), Some((2, b"b".to_vec())));
        assert_eq!(l.next_line().unwrap(), None);
    }
}
