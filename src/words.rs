//! Numbers in words for the library's messages and descriptions, and
//! messages wrapped for a terminal.

/// `n` and `noun`, plural unless `n` is 1: "1 SPE", "6 SPEs", "1 triangle".
pub fn count(n: impl Into<u64>, noun: &str) -> String {
    match n.into() {
        1 => format!("1 {noun}"),
        n => format!("{n} {noun}s"),
    }
}

/// An error or note for the terminal: each line of `text` wrapped at 80
/// columns, the lines it continues onto indented by two spaces (a word
/// longer than a line, such as a path, stands alone).
pub fn wrapped(text: &str) -> String {
    let mut out: Vec<String> = Vec::new();
    for line in text.lines() {
        let mut cur = String::new();
        for word in line.split(' ').filter(|w| !w.is_empty()) {
            if !cur.trim().is_empty() && cur.chars().count() + 1 + word.chars().count() > 80 {
                out.push(std::mem::replace(&mut cur, "  ".into()));
            }
            if !cur.trim().is_empty() {
                cur.push(' ');
            }
            cur.push_str(word);
        }
        out.push(cur);
    }
    out.join("\n")
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_message_wraps_at_80_with_its_further_lines_indented() {
        let text = format!("error: {}", "word ".repeat(40));
        let w = super::wrapped(&text);
        assert!(w.lines().count() > 1, "{w}");
        assert!(w.lines().all(|l| l.chars().count() <= 80), "{w}");
        assert!(w.lines().skip(1).all(|l| l.starts_with("  word")), "{w}");
        assert_eq!(w.replace("\n  ", " "), text.trim_end());
    }
}
