//! Section 5's knobs (double-buffered WorkA/WorkB, DMA lists, the shared
//! job queue's takes, Morton key widths, …) as each strategy declares
//! them: a [`Knob`] is a table row in the strategy's own file (name, help,
//! default, range, the values an experiment sweeps); [`Knobs`] carries the
//! values given, by name, and each strategy reads its own into a typed
//! struct of its own file. Nothing here knows which strategy takes which
//! knob: the registry does.

/// What values a knob takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A flag: off unless given (`--NAME`).
    Flag,
    /// A whole number in `min..=max`; a `default` of 0 (outside the
    /// range) is `auto`: the strategy's own choice.
    Int {
        default: usize,
        min: usize,
        max: usize,
    },
    /// One of these words; the first is the default.
    Word(&'static [&'static str]),
}

/// A strategy's knob as the command line names it (`--NAME`), declared
/// beside the code that reads it; a builder's table of these is what it
/// takes, and a knob given to a builder that does not take it is refused
/// by name (the registry does that).
#[derive(Debug, PartialEq, Eq)]
pub struct Knob {
    /// The option's name without `--`.
    pub name: &'static str,
    /// One line: what it does.
    pub help: &'static str,
    /// Its values and their range: the one range check of the knob
    /// ([`Knobs::set`]).
    pub kind: Kind,
    /// The values, other than the default, that experiments sweep (each
    /// alone, as the command line spells it; `""` turns a flag on); tests
    /// try each.
    pub sweep: &'static [&'static str],
    /// Its values other than the default build another tree; the other
    /// knobs change only what the build costs.
    pub changes_tree: bool,
}

impl Knob {
    /// A flag; experiments try it on.
    pub const fn flag(name: &'static str, help: &'static str) -> Knob {
        Knob {
            name,
            help,
            kind: Kind::Flag,
            sweep: &[""],
            changes_tree: false,
        }
    }

    /// A whole number in `min..=max`, `default` unless given.
    pub const fn int(
        name: &'static str,
        help: &'static str,
        default: usize,
        (min, max): (usize, usize),
        sweep: &'static [&'static str],
    ) -> Knob {
        Knob {
            name,
            help,
            kind: Kind::Int { default, min, max },
            sweep,
            changes_tree: false,
        }
    }

    /// A whole number in `min..=max` (`min` at least 1), or `auto` (read
    /// as 0): the strategy chooses unless given.
    pub const fn int_or_auto(
        name: &'static str,
        help: &'static str,
        (min, max): (usize, usize),
        sweep: &'static [&'static str],
    ) -> Knob {
        assert!(min >= 1, "0 reads as auto");
        Knob::int(name, help, 0, (min, max), sweep)
    }

    /// Whether it takes `auto` (and reads it as 0).
    pub(crate) fn takes_auto(&self) -> bool {
        matches!(self.kind, Kind::Int { default: 0, min, .. } if min > 0)
    }

    /// One of `words`, the first unless given.
    pub const fn word(
        name: &'static str,
        help: &'static str,
        words: &'static [&'static str],
        sweep: &'static [&'static str],
    ) -> Knob {
        Knob {
            name,
            help,
            kind: Kind::Word(words),
            sweep,
            changes_tree: false,
        }
    }

    /// Its values other than the default build another tree.
    pub const fn changing_the_tree(self) -> Knob {
        Knob {
            changes_tree: true,
            ..self
        }
    }

    pub fn is_flag(&self) -> bool {
        self.kind == Kind::Flag
    }

    /// The default as the command line spells it ("off" for a flag).
    pub fn default_text(&self) -> String {
        match self.kind {
            Kind::Flag => "off".into(),
            _ if self.takes_auto() => "auto".into(),
            Kind::Int { default, .. } => default.to_string(),
            Kind::Word(words) => words[0].into(),
        }
    }

    /// `value` as the command line gives it (empty for a flag), checked
    /// against the knob's range.
    fn parse(&self, value: &str) -> Result<Value, String> {
        let name = self.name;
        match self.kind {
            Kind::Flag if value.is_empty() => Ok(Value::On),
            Kind::Flag => Err(format!("--{name} is a flag: it takes no value ('{value}')")),
            _ if value == "auto" && self.takes_auto() => Ok(Value::Int(0)),
            Kind::Int { min, max, .. } => {
                let v: usize = (value.parse())
                    .map_err(|_| format!("--{name} takes a whole number, not '{value}'"))?;
                if !(min..=max).contains(&v) {
                    return Err(format!("--{name} {v}: {}", self.range()));
                }
                Ok(Value::Int(v))
            }
            Kind::Word(words) => (words.iter())
                .find(|w| **w == value)
                .map(|w| Value::Word(w))
                .ok_or_else(|| format!("--{name} is {}, not '{value}'", self.range())),
        }
    }

    /// The values it takes, in words ("1 to 16", "gh or xyz").
    pub fn range(&self) -> String {
        match self.kind {
            Kind::Flag => "a flag".into(),
            Kind::Int { min, max, .. } => {
                let auto = if self.takes_auto() { "auto or " } else { "" };
                match max {
                    usize::MAX => format!("{auto}at least {min}"),
                    _ => format!("{auto}{min} to {max}"),
                }
            }
            Kind::Word(words) => match words {
                [one] => (*one).into(),
                [rest @ .., last] => format!("{} or {last}", rest.join(", ")),
                [] => "nothing".into(),
            },
        }
    }

    #[cfg(test)]
    fn set_auto_is_refused(&'static self) -> bool {
        Knobs::default().set(self, "auto").is_err()
    }

    /// The option as the command line spells it with `value`: `--NAME` for
    /// a flag, `--NAME VALUE` otherwise.
    pub fn spelled(&self, value: &str) -> String {
        if value.is_empty() {
            format!("--{}", self.name)
        } else {
            format!("--{} {value}", self.name)
        }
    }
}

/// A knob's value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Value {
    On,
    Int(usize),
    Word(&'static str),
}

/// The knobs given, by name, each checked against its table row when set;
/// a knob not given reads as its table's default.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Knobs {
    given: Vec<(&'static Knob, Value, String)>,
}

impl Knobs {
    /// Sets `knob` to `value` as the command line gives it (an empty
    /// `value` for a flag), refusing a value out of its range.
    pub fn set(&mut self, knob: &'static Knob, value: &str) -> Result<(), String> {
        let v = knob.parse(value)?;
        self.given.retain(|(k, ..)| k.name != knob.name);
        self.given.push((knob, v, value.to_string()));
        Ok(())
    }

    /// These knobs and `knob` set to `value`.
    pub fn with(mut self, knob: &'static Knob, value: &str) -> Result<Self, String> {
        self.set(knob, value)?;
        Ok(self)
    }

    fn get(&self, knob: &Knob) -> Option<Value> {
        (self.given.iter())
            .find(|(k, ..)| k.name == knob.name)
            .map(|&(_, v, _)| v)
    }

    /// A flag's value.
    pub fn flag(&self, knob: &Knob) -> bool {
        debug_assert!(knob.is_flag(), "--{} is not a flag", knob.name);
        self.get(knob) == Some(Value::On)
    }

    /// A whole-number knob's value (0: `auto`).
    pub fn int(&self, knob: &Knob) -> usize {
        match (self.get(knob), knob.kind) {
            (Some(Value::Int(v)), _) => v,
            (_, Kind::Int { default, .. }) => default,
            _ => panic!("--{} is not a whole number", knob.name),
        }
    }

    /// A word knob's value.
    pub fn word(&self, knob: &Knob) -> &'static str {
        match (self.get(knob), knob.kind) {
            (Some(Value::Word(w)), _) => w,
            (_, Kind::Word(words)) => words[0],
            _ => panic!("--{} is not a word", knob.name),
        }
    }

    /// `knob`'s value as the command line spells it, its default when not
    /// given: "on"/"off" for a flag, a number or "auto", a word.
    pub fn text(&self, knob: &Knob) -> String {
        match self.get(knob) {
            Some(Value::On) => "on".into(),
            Some(Value::Int(0)) if knob.takes_auto() => "auto".into(),
            Some(Value::Int(v)) => v.to_string(),
            Some(Value::Word(w)) => w.into(),
            None => knob.default_text(),
        }
    }

    /// The knobs given, as the command line spells them, in the order set
    /// ("" when none is).
    pub fn spelled(&self) -> String {
        let v: Vec<String> = (self.given.iter())
            .map(|(k, _, text)| k.spelled(text))
            .collect();
        v.join(" ")
    }

    /// Whether a knob given builds another tree than the defaults do.
    pub fn change_the_tree(&self) -> bool {
        (self.given.iter()).any(|(k, ..)| k.changes_tree)
    }

    /// The knobs given.
    pub fn given(&self) -> impl Iterator<Item = &'static Knob> + '_ {
        self.given.iter().map(|(k, ..)| *k)
    }
}

#[cfg(test)]
mod tests {
    use super::{Knob, Knobs};

    static FLAG: Knob = Knob::flag("f", "a flag");
    static INT: Knob = Knob::int("n", "a number", 4, (1, 16), &["2"]);
    static WORD: Knob = Knob::word("w", "a word", &["gh", "xyz"], &["xyz"]);
    static AUTO: Knob = Knob::int_or_auto("a", "a number or auto", (1, 16), &["2"]);

    #[test]
    fn an_auto_knob_reads_auto_as_zero_and_refuses_zero() {
        let mut k = Knobs::default();
        assert_eq!((k.int(&AUTO), AUTO.default_text()), (0, "auto".to_string()));
        k.set(&AUTO, "3").unwrap();
        assert_eq!(k.int(&AUTO), 3);
        k.set(&AUTO, "auto").unwrap();
        assert_eq!(k.int(&AUTO), 0);
        let e = k.set(&AUTO, "0").unwrap_err();
        assert!(e.contains("--a 0: auto or 1 to 16"), "{e}");
        assert!(INT.set_auto_is_refused());
    }

    #[test]
    fn a_knob_not_given_reads_as_its_default() {
        let k = Knobs::default();
        assert!(!k.flag(&FLAG));
        assert_eq!(k.int(&INT), 4);
        assert_eq!(k.word(&WORD), "gh");
        assert_eq!(k.spelled(), "");
    }

    #[test]
    fn values_are_read_back_and_spelled_as_given() {
        let k = (Knobs::default().with(&FLAG, ""))
            .and_then(|k| k.with(&INT, "16"))
            .and_then(|k| k.with(&WORD, "xyz"))
            .unwrap();
        assert!(k.flag(&FLAG));
        assert_eq!(k.int(&INT), 16);
        assert_eq!(k.word(&WORD), "xyz");
        assert_eq!(k.spelled(), "--f --n 16 --w xyz");
        // Set again: the last value holds, spelled once.
        let k = k.with(&INT, "1").unwrap();
        assert_eq!((k.int(&INT), k.spelled().matches("--n").count()), (1, 1));
    }

    #[test]
    fn values_out_of_range_are_refused_in_the_knobs_words() {
        let mut k = Knobs::default();
        for (knob, value, says) in [
            (&INT, "0", "--n 0: 1 to 16"),
            (&INT, "17", "--n 17: 1 to 16"),
            (&INT, "x", "whole number"),
            (&WORD, "yzx", "gh or xyz, not 'yzx'"),
            (&FLAG, "1", "is a flag"),
        ] {
            let e = k.set(knob, value).unwrap_err();
            assert!(e.contains(says), "{e}");
        }
        assert_eq!(k, Knobs::default(), "a refused value sets nothing");
    }
}
