//! The generated blocks of a Markdown page: a marker that names the
//! command which made it, the command's output, and a closing marker.
//!
//! ````text
//! <!-- figures: table1 --scenes bunny | quick | svg: a.svg -->
//! ```text
//! …the command's standard output…
//! ```
//! <!-- /figures -->
//! ````
//!
//! After `figures:` come the command (a binary of the front end and its
//! arguments, or `bench NAME ARGS`: a bench's printed table) and, each after a `|`, the block's options: `quick` (in the
//! quick check), `host` (every figure of it is host time: compared only
//! for presence), `svg: FILE…` (plots the run writes into its `--out`
//! directory, copied to that path from the page: `docs/<name>.svg` from the
//! README; `host-svg: FILE…` for plots of host
//! time, compared only for being there), `from: TEXT` (the output from its
//! first line that starts with TEXT: a long run's summary).

use std::fmt;

/// One generated block of a page.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Block {
    /// The line of its opening marker (1-based), for messages.
    pub line: usize,
    /// The binary that makes it.
    pub bin: String,
    /// Its arguments, as the marker gives them.
    pub args: Vec<String>,
    /// In the quick check.
    pub quick: bool,
    /// Its figures are host times.
    pub host: bool,
    /// The plots it copies beside the page.
    pub svgs: Vec<String>,
    /// Those of them that plot host time.
    pub host_svgs: Vec<String>,
    /// The output from the first line that starts with this.
    pub from: Option<String>,
    /// The lines between its markers, as the page has them.
    pub body: String,
}

impl Block {
    /// The command as the marker names it.
    pub fn command(&self) -> String {
        std::iter::once(self.bin.as_str())
            .chain(self.args.iter().map(String::as_str))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// A page's text, cut at its markers.
#[derive(Debug)]
pub struct Page {
    /// The text before each block, and after the last (one more than
    /// `blocks`), each with its marker lines.
    pub between: Vec<String>,
    pub blocks: Vec<Block>,
}

/// A marker that does not parse, or a block that does not close.
#[derive(Debug, PartialEq, Eq)]
pub struct MarkerError {
    pub line: usize,
    pub what: String,
}

impl fmt::Display for MarkerError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.what)
    }
}

const OPEN: &str = "<!-- figures";
const CLOSE: &str = "<!-- /figures -->";

/// Cuts `text` at its markers.
pub fn parse(text: &str) -> Result<Page, MarkerError> {
    let mut page = Page {
        between: vec![String::new()],
        blocks: Vec::new(),
    };
    let mut open: Option<Block> = None;
    for (i, line) in text.split_inclusive('\n').enumerate() {
        let trimmed = line.trim();
        match open.as_mut() {
            None if trimmed.starts_with(OPEN) => {
                let mut block = marker(trimmed, i + 1)?;
                block.line = i + 1;
                page.between.last_mut().expect("one").push_str(line);
                open = Some(block);
            }
            None if trimmed == CLOSE => return Err(error(i + 1, "a closing marker with no block")),
            None => page.between.last_mut().expect("one").push_str(line),
            Some(_) if trimmed == CLOSE => {
                page.blocks.push(open.take().expect("open"));
                page.between.push(line.to_string());
            }
            Some(_) if trimmed.starts_with(OPEN) => {
                return Err(error(i + 1, "a block opened inside another"));
            }
            Some(block) => block.body.push_str(line),
        }
    }
    match open {
        Some(b) => Err(error(b.line, "this block has no closing <!-- /figures -->")),
        None => Ok(page),
    }
}

impl Page {
    /// The page with each block's body replaced by `body(block)`.
    pub fn with_bodies(&self, mut body: impl FnMut(&Block) -> String) -> String {
        let mut out = String::new();
        for (before, block) in self.between.iter().zip(&self.blocks) {
            out.push_str(before);
            out.push_str(&body(block));
        }
        out.push_str(self.between.last().expect("one"));
        out
    }
}

fn error(line: usize, what: &str) -> MarkerError {
    MarkerError {
        line,
        what: what.to_string(),
    }
}

/// The block an opening marker names (its body empty).
fn marker(text: &str, line: usize) -> Result<Block, MarkerError> {
    let inner = (text
        .strip_prefix("<!--")
        .and_then(|t| t.strip_suffix("-->")))
    .ok_or_else(|| error(line, "a marker is one line: <!-- figures: COMMAND -->"))?;
    let rest = (inner.trim().strip_prefix("figures:"))
        .ok_or_else(|| error(line, "a marker starts `<!-- figures: `"))?;
    let mut parts = rest.split('|');
    let mut words = parts
        .next()
        .unwrap_or("")
        .split_whitespace()
        .map(String::from);
    let bin = words
        .next()
        .ok_or_else(|| error(line, "the marker names no command"))?;
    let mut block = Block {
        line,
        bin,
        args: words.collect(),
        quick: false,
        host: false,
        svgs: Vec::new(),
        host_svgs: Vec::new(),
        from: None,
        body: String::new(),
    };
    for option in parts.map(str::trim) {
        match option.split_once(':') {
            None if option == "quick" => block.quick = true,
            None if option == "host" => block.host = true,
            Some(("svg", files)) => block
                .svgs
                .extend(files.split_whitespace().map(String::from)),
            Some(("host-svg", files)) => {
                let files: Vec<String> = files.split_whitespace().map(String::from).collect();
                block.svgs.extend(files.iter().cloned());
                block.host_svgs.extend(files);
            }
            Some(("from", text)) => block.from = Some(text.trim().to_string()),
            _ => {
                let what = format!(
                    "unknown option `{option}` (quick, host, svg: FILE…, host-svg: FILE…, from: TEXT)"
                );
                return Err(error(line, &what));
            }
        }
    }
    Ok(block)
}

impl Block {
    /// The body the block holds for its command's output: the part it
    /// shows, fenced as text; `None` when `from:` names no line of it.
    pub fn body_of(&self, output: &str) -> Option<String> {
        let shown = match &self.from {
            None => output,
            Some(from) => {
                let at = (output.lines())
                    .scan(0, |offset, line| {
                        let here = *offset;
                        *offset += line.len() + 1;
                        Some((here, line))
                    })
                    .find(|(_, line)| line.starts_with(from.as_str()))?
                    .0;
                &output[at..]
            }
        };
        Some(fenced(shown))
    }
}

/// A command's output as a block's body: a fenced text block.
pub fn fenced(output: &str) -> String {
    format!("```text\n{}\n```\n", output.trim_end())
}

#[cfg(test)]
mod tests {
    use super::*;

    const PAGE: &str = "# A page\n\nBefore.\n\n\
        <!-- figures: table1 --scenes bunny | quick | svg: a.svg b.svg -->\n\
        ```text\nold\n```\n\
        <!-- /figures -->\n\nAfter.\n";

    #[test]
    fn a_page_cuts_at_its_markers_and_puts_itself_back_together() {
        let page = parse(PAGE).unwrap();
        assert_eq!(page.blocks.len(), 1);
        let b = &page.blocks[0];
        assert_eq!(b.command(), "table1 --scenes bunny");
        assert!(b.quick && !b.host);
        assert_eq!(b.svgs, ["a.svg", "b.svg"]);
        assert!(b.host_svgs.is_empty());
        let split = PAGE.replace("| svg: a.svg b.svg", "| svg: a.svg | host-svg: b.svg");
        let b2 = &parse(&split).unwrap().blocks[0];
        assert_eq!(
            (b2.svgs.clone(), b2.host_svgs.clone()),
            (
                vec!["a.svg".to_string(), "b.svg".to_string()],
                vec!["b.svg".to_string()]
            )
        );
        assert_eq!(b.line, 5);
        assert_eq!(b.body, "```text\nold\n```\n");
        assert_eq!(page.with_bodies(|b| b.body.clone()), PAGE);
        let new = page.with_bodies(|_| fenced("new\n\n"));
        assert_eq!(new, PAGE.replace("old", "new"));
    }

    #[test]
    fn from_shows_the_output_from_its_line() {
        let page = PAGE.replace("| quick", "| quick | from: summary");
        let b = &parse(&page).unwrap().blocks[0];
        let out = "rows\nmore rows\nsummary: two\nlast\n";
        assert_eq!(
            b.body_of(out).unwrap(),
            "```text\nsummary: two\nlast\n```\n"
        );
        assert_eq!(b.body_of("no such line\n"), None);
    }

    #[test]
    fn a_bad_marker_is_refused_with_its_line() {
        let unknown = PAGE.replace("| quick", "| quik");
        let e = parse(&unknown).unwrap_err();
        assert_eq!(e.line, 5);
        assert!(e.what.contains("quik"), "{e}");
        let unclosed = PAGE.replace("<!-- /figures -->\n", "");
        assert!(parse(&unclosed).unwrap_err().what.contains("no closing"));
        let stray = "text\n<!-- /figures -->\n";
        assert_eq!(parse(stray).unwrap_err().line, 2);
        let empty = "<!-- figures: -->\n<!-- /figures -->\n";
        assert!(parse(empty).unwrap_err().what.contains("no command"));
    }
}
