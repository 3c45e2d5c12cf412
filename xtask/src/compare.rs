//! How a regenerated block is held against the page's: simulated figures
//! exactly, host times for presence only.
//!
//! Simulated Cell time is deterministic, so every simulated figure must
//! come back to the letter. A host time differs from run to run and from
//! machine to machine: in a table, a column whose header names `host`
//! (`host ms`, `host (ms)`) is masked on both sides before the compare; a
//! block marked `host` is compared only for being there.

/// The first differences between the page's body and the regenerated
/// one, at most `most` of them, each as the line number in the body and
/// the two lines; empty when they agree.
pub fn differences(page: &str, made: &str, host: bool, most: usize) -> Vec<Difference> {
    if host {
        let empty = |s: &str| {
            s.lines()
                .all(|l| l.trim().is_empty() || l.starts_with("```"))
        };
        return match (empty(page), empty(made)) {
            (true, false) => vec![Difference::new(1, "(nothing)", "(a host-time block)")],
            _ => Vec::new(),
        };
    }
    let (a, b) = (mask(page), mask(made));
    let (a, b): (Vec<&str>, Vec<&str>) = (a.lines().collect(), b.lines().collect());
    let mut out = Vec::new();
    for i in 0..a.len().max(b.len()) {
        let (x, y) = (a.get(i).copied(), b.get(i).copied());
        if x != y {
            out.push(Difference::new(
                i + 1,
                x.unwrap_or("(no line)"),
                y.unwrap_or("(no line)"),
            ));
            if out.len() == most {
                break;
            }
        }
    }
    out
}

/// A line that differs.
#[derive(Debug, PartialEq, Eq)]
pub struct Difference {
    pub line: usize,
    pub page: String,
    pub made: String,
}

impl Difference {
    fn new(line: usize, page: &str, made: &str) -> Self {
        Difference {
            line,
            page: page.to_string(),
            made: made.to_string(),
        }
    }
}

/// `text` with every host-time cell replaced by `#`: in each table (a
/// header line and the lines under it, up to a blank line), the words of
/// a row that overlap a header cell naming `host` (the word and the words
/// a single space joins to it: `host ms`), the row's words then one space
/// apart; under a title that names host (`host ms (one thread)` over a
/// header), every word of the rows.
pub fn mask(text: &str) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let mut spans: Vec<(usize, usize)> = Vec::new();
    let mut out = String::new();
    for (i, line) in lines.iter().enumerate() {
        let next = lines.get(i + 1).copied().unwrap_or("");
        if line.trim().is_empty() {
            spans.clear();
            out.push_str(line);
        } else if let Some(found) = host_cells(line) {
            let (here, below) = (cells(line), cells(next).len());
            if here.len() == 1 && below > 2 {
                // A title naming host over a header: the whole table is
                // host time.
                spans = vec![(0, usize::MAX)];
                out.push_str(line);
            } else if here.len() <= 2 && found[0].0 == here[0].0.0 {
                // A line of its own about host time (`host time  51 ms`,
                // `host time to stream …: 0.005 s`): its numbers.
                out.push_str(&numbers_masked(line));
            } else {
                spans = found;
                out.push_str(line);
            }
        } else if spans.is_empty() {
            out.push_str(line);
        } else {
            out.push_str(&masked(line, &spans));
        }
        out.push('\n');
    }
    out
}

/// The spans of the header cells of `line` that name `host`, if any.
fn host_cells(line: &str) -> Option<Vec<(usize, usize)>> {
    let host: Vec<(usize, usize)> = (cells(line).into_iter())
        .filter(|(_, text)| text.to_lowercase().contains("host"))
        .map(|(span, _)| span)
        .collect();
    (!host.is_empty()).then_some(host)
}

/// The cells of `line`: words joined by single spaces, with their spans
/// (in characters).
fn cells(line: &str) -> Vec<((usize, usize), String)> {
    runs(line, |chars, i| chars.get(i + 1).is_none_or(|&c| c == ' '))
}

/// The runs of `line` that no space ends, with their spans (in
/// characters): a space at `i` ends a run where `ends(chars, i)`.
fn runs(line: &str, ends: impl Fn(&[char], usize) -> bool) -> Vec<((usize, usize), String)> {
    let chars: Vec<char> = line.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        if chars[i] == ' ' {
            i += 1;
            continue;
        }
        let start = i;
        while i < chars.len() && !(chars[i] == ' ' && ends(&chars, i)) {
            i += 1;
        }
        out.push(((start, i), chars[start..i].iter().collect()));
    }
    out
}

/// `line`'s words, one space apart, each that holds a digit replaced by
/// `#`.
fn numbers_masked(line: &str) -> String {
    (line.split_whitespace())
        .map(|w| match w.chars().any(|c| c.is_ascii_digit()) {
            true => "#",
            false => w,
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// `line`'s words, one space apart, each that overlaps one of `spans`
/// replaced by `#` (so a host time of another width aligns the same).
fn masked(line: &str, spans: &[(usize, usize)]) -> String {
    let hidden = |(a, b): (usize, usize)| spans.iter().any(|&(x, y)| a < y && x < b);
    (runs(line, |_, _| true).into_iter())
        .map(|(span, word)| if hidden(span) { "#".to_string() } else { word })
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    const TABLE: &str = "model   method     sim ms  host ms\n\
                         bunny   spe_bfs      54.0       35\n\
                         dragon  spe_bfs     896.8      850\n\
                         \n\
                         after the table 35\n";

    #[test]
    fn a_host_column_is_masked_and_nothing_else() {
        let m = mask(TABLE);
        assert!(m.contains("\nbunny spe_bfs 54.0 #\n"), "{m}");
        assert!(m.contains("\ndragon spe_bfs 896.8 #\n"), "{m}");
        assert!(m.contains("after the table 35"), "{m}");
        let other_host = TABLE.replace("  35\n", "  99\n").replace(" 850", "1234");
        assert!(differences(TABLE, &other_host, false, 5).is_empty());
    }

    #[test]
    fn a_simulated_figure_that_moves_is_a_difference() {
        let moved = TABLE.replace("896.8", "896.7");
        let d = differences(TABLE, &moved, false, 5);
        assert_eq!(d.len(), 1);
        assert_eq!(d[0].line, 3);
        assert!(d[0].page.contains("896.8") && d[0].made.contains("896.7"));
        let longer = format!("{TABLE}one more\n");
        assert_eq!(differences(TABLE, &longer, false, 5)[0].made, "one more");
        let prose = TABLE.replace("table 35", "table 36");
        assert_eq!(differences(TABLE, &prose, false, 5).len(), 1);
    }

    #[test]
    fn a_table_titled_host_is_masked_whole() {
        let t = "host ms (one thread)\nupdate  min ms  mean ms\nlocal    0.008    0.080\n\nsimulated\nupdate  ms\nlocal  6.24\n";
        let other = t.replace("0.080", "0.5");
        assert!(differences(t, &other, false, 5).is_empty());
        let moved = t.replace("6.24", "6.25");
        assert_eq!(differences(t, &moved, false, 5).len(), 1);
    }

    #[test]
    fn a_line_about_host_time_is_masked_and_the_table_above_is_not() {
        let t = "    16 KiB    22.25    23.18\n\nhost time to stream 64.0 MiB: 0.005 s\nhost time   51.55 ms (the emulation)\nnodes       17597\n";
        let other = t.replace("0.005", "0.007").replace("51.55", "49.1");
        assert!(differences(t, &other, false, 5).is_empty());
        assert_eq!(
            differences(t, &t.replace("23.18", "23.19"), false, 5).len(),
            1
        );
        assert_eq!(
            differences(t, &t.replace("17597", "17598"), false, 5).len(),
            1
        );
    }

    #[test]
    fn a_host_block_is_compared_for_presence_only() {
        assert!(differences(TABLE, "anything\n", true, 5).is_empty());
        assert_eq!(differences("```text\n```\n", TABLE, true, 5).len(), 1);
    }
}
