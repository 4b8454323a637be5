//! Every figure in the tables of docs/performance.md, docs/accuracy.md and
//! docs/security.md comes from a record in `docs/records/*.jsonl` (issue 27),
//! and from the records its table names, not from any record at all.
//!
//! CPU only: reads the records and the Markdown, nothing else.
//!
//! * Every line of every `docs/records/*.jsonl` must be a record (an object
//!   with `bench`, `commit`, `dirty`, `date`, `adapter`, `host`, `command`
//!   and `values`, of the types the record writer gives them); a malformed
//!   line fails the test, naming file and line. A record's numbers are every
//!   JSON number in `values` and `adapter`, and every figure in their
//!   strings and in the command (its arguments and `env` values: bench
//!   arguments such as N, V and sizes are figures too). Left out: every
//!   array under a key ending in `_samples` (the per-frame samples: one of
//!   thousands lies near any figure) and the `host` object.
//! * Every table row of the three docs (rows starting with `|`, outside code
//!   fences; the separator row skipped) is read cell by cell, header
//!   included; code spans, link targets, HTML and identifiers (`H100`,
//!   `f32`, `a27cb61`, versions such as `0.19.1`) hold no figures.
//! * A table preceded by `<!-- figures: not measured — REASON -->` holds no
//!   measurements (limits restating code, names); one preceded by
//!   `<!-- figures: owed — REASON -->` holds measurements no record backs
//!   yet: it is listed, and with `OXYGEN_RECORDS_STRICT=1` it fails the
//!   test. Every other table is checked: each figure must be backed by a
//!   number of the records the table's `Record:` line names (see
//!   [`Figure::intervals`] for what "backed" means).
//!
//! The `Record:` line (the rule, see [`parse_source`] and [`select`]):
//!
//! * A checked table's first line after its last row, or the line after
//!   one blank line, starts with `Record:` (or `Records:`); the paragraph it
//!   starts (up to the next blank line) names the table's records. A
//!   checked table without one fails, naming the table.
//! * It names one or more files, `docs/records/NAME.jsonl`; only their
//!   records back the table's figures. A named file that holds no record
//!   fails.
//! * Commits: every word outside code spans of 7 to 40 lowercase hex
//!   digits, at least one a letter and one a digit (`2b48b71`). When it
//!   names any, only records whose `commit` starts with one of them count;
//!   a named commit that no record of the named files has fails.
//! * Adapters: when a word outside code spans is a word (4 characters or
//!   more) of a record's adapter name before its `(` (`NVIDIA`, `H100`,
//!   `llvmpipe`; `lavapipe` names Mesa's llvmpipe), only records on a named
//!   adapter count (CPU-only records, adapter null, always do).
//! * Commands: a code span whose program (its first word after any
//!   `VAR=value` words, path stripped) is the program of one of those
//!   records' `argv` is a command. When there are any, only records that one
//!   of them ran count: the same arguments in order (a word in capitals,
//!   `N`, stands for any one argument; `a|b` for either), and each
//!   `VAR=value` either in the record's `env` (`value` may be `a|b|c`) or,
//!   when the record's `env` has no `VAR`, among its arguments after the
//!   span's own (what `scripts/peer-bench.sh` does with `CONFIGS=…`). A
//!   command that no such record ran fails. Write each command in full: a
//!   span such as `… mdi` names no program and is no command. Other spans
//!   (`cargo bench …`, `cull_rows`) restrict nothing.
//! * Dates in a table are backed by the dates of its records.
//!
//! Being among the table's records is not all: a figure must also stand
//! where its table puts it ([`Binding`]). A column is one quantity (its
//! figures under one key of the records), a cell's list (`1.1 3.7 7.2 %`)
//! one list of a record, and a table row's figures from one line of a
//! record where the row reads one; a table of tests' records binds each row
//! to one record instead. [`decimals_raised_by_three_in_their_last_digit_are_refused`]
//! measures what that buys: every decimal of every table raised by 3 in its
//! last digit, and how many raised figures still pass.
//!
//! docs/records/README.md ("Figures in the docs") says the same for authors.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde_json::Value;

/// The docs whose tables are checked.
const DOCS: [&str; 3] = ["docs/performance.md", "docs/accuracy.md", "docs/security.md"];

/// Where the records are, relative to the workspace root.
const RECORDS_DIR: &str = "docs/records";

/// Set to `1` to fail while any table is still marked `owed`.
const STRICT_VAR: &str = "OXYGEN_RECORDS_STRICT";

/// The marker's prefix, inside an HTML comment.
const MARKER_PREFIX: &str = "figures:";

/// A reason must have at least this many words ("TODO" is not a reason).
const MIN_REASON_WORDS: usize = 3;

/// What starts the line under a checked table that names its records.
const SOURCE_PREFIXES: [&str; 2] = ["Record:", "Records:"];

/// Arrays under keys ending so back no figure: a bench's per-frame samples
/// (`gpu_ms_samples`; a count such as `reference_samples: 1024` still does).
const SAMPLES_SUFFIX: &str = "_samples";

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

// ---------------------------------------------------------------------------
// Figures: the numbers a piece of text states.
// ---------------------------------------------------------------------------

/// A unit or suffix attached to a figure, which widens what may back it.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Unit {
    /// `%`: a record may hold the fraction (0.957 for 95.7 %).
    Percent,
    /// A time unit, in seconds (`ms` is 1e-3): a record may hold the time
    /// in s, ms, µs or ns.
    Time(f64),
    /// A multiplier or a byte unit: a record may hold the figure times any
    /// of these (`k`: 1000; `MB`: 1e6 or 2^20; `MiB`: 2^20).
    Scale(&'static [f64]),
}

const KILO: &[f64] = &[1e3];
const MEGA: &[f64] = &[1e6];
const GIGA: &[f64] = &[1e9];
const KIBI: &[f64] = &[1024.0];
const MEBI: &[f64] = &[1_048_576.0];
const GIBI: &[f64] = &[1_073_741_824.0];
const TEBI: &[f64] = &[1_099_511_627_776.0];
const KB: &[f64] = &[1e3, 1024.0];
const MB: &[f64] = &[1e6, 1_048_576.0];
const GB: &[f64] = &[1e9, 1_073_741_824.0];
const TB: &[f64] = &[1e12, 1_099_511_627_776.0];

/// The unit a word names, if it is one the check knows.
fn unit_of(word: &str) -> Option<Unit> {
    Some(match word {
        "%" => Unit::Percent,
        "s" => Unit::Time(1.0),
        "ms" => Unit::Time(1e-3),
        "µs" | "μs" | "us" => Unit::Time(1e-6),
        "ns" => Unit::Time(1e-9),
        "k" | "K" => Unit::Scale(KILO),
        "M" => Unit::Scale(MEGA),
        "G" => Unit::Scale(GIGA),
        "Ki" => Unit::Scale(KIBI),
        "Mi" => Unit::Scale(MEBI),
        "Gi" => Unit::Scale(GIBI),
        "KB" | "kB" => Unit::Scale(KB),
        "MB" => Unit::Scale(MB),
        "GB" => Unit::Scale(GB),
        "TB" => Unit::Scale(TB),
        "KiB" => Unit::Scale(KIBI),
        "MiB" => Unit::Scale(MEBI),
        "GiB" => Unit::Scale(GIBI),
        "TiB" => Unit::Scale(TEBI),
        _ => return None,
    })
}

#[derive(Clone, Debug, PartialEq)]
enum Kind {
    /// A number printed as `value` with its last digit at 10^`exponent`
    /// (`0.47`: -2; `1200`: 0; `1e-4`: -4).
    Number { value: f64, exponent: i32 },
    /// `base` raised to `power` (`64²`, `2⁻⁵`, `2^40`); `base` printed with
    /// its last digit at 10^`exponent`.
    Power { base: f64, exponent: i32, power: i32 },
    /// An ISO date (`2026-11-23`): backed by a record of that day.
    Date(String),
}

/// One figure found in a piece of text.
#[derive(Clone, Debug, PartialEq)]
struct Figure {
    /// The text it was read from, unit included.
    text: String,
    kind: Kind,
    unit: Option<Unit>,
    /// Where the number (without its unit) starts and ends, in chars.
    start: usize,
    end: usize,
}

impl Figure {
    /// The value the figure states (a date has none).
    fn value(&self) -> Option<f64> {
        match self.kind {
            Kind::Number { value, .. } => Some(value),
            Kind::Power { base, power, .. } => Some(base.powi(power)),
            Kind::Date(_) => None,
        }
    }

    /// The intervals a record number's magnitude may fall in to back the
    /// figure: `[centre - tolerance, centre + tolerance]`.
    ///
    /// * A figure printed with its last digit at 10^e is backed by a number
    ///   that rounds to it there: |v − F| ≤ 0.5·10^e (integers: e = 0, so
    ///   the number must round to the integer). Signs are text ("falls by
    ///   8 %"), so magnitudes are compared.
    /// * `%`: also the fraction, v·100 rounding to F.
    /// * A time unit: the same time in s, ms, µs or ns.
    /// * `k`, `M`, `G`, `Ki`, `Mi`, byte units: also F times the unit
    ///   (`143 k` by 143 210; `5.7 MB` by bytes, decimal or binary).
    /// * A power: its value (`2⁻⁵` by 0.03125); a square or cube (`64²`,
    ///   a face size) also by its base.
    ///
    /// A tiny relative epsilon absorbs binary floating point.
    fn intervals(&self) -> Vec<(f64, f64)> {
        let mut base: Vec<(f64, f64)> = match self.kind {
            Kind::Number { value, exponent } => vec![(value.abs(), 0.5 * 10f64.powi(exponent))],
            Kind::Power { base, exponent, power } => {
                let mut v = vec![(base.abs().powi(power), 0.0)];
                if power == 2 || power == 3 {
                    v.push((base.abs(), 0.5 * 10f64.powi(exponent)));
                }
                v
            }
            Kind::Date(_) => return Vec::new(),
        };
        let mut extra = Vec::new();
        match self.unit {
            None => {}
            Some(Unit::Percent) => extra.extend(base.iter().map(|&(c, t)| (c / 100.0, t / 100.0))),
            Some(Unit::Time(seconds)) => {
                for record_unit in [1.0, 1e-3, 1e-6, 1e-9] {
                    if record_unit != seconds {
                        let factor = seconds / record_unit;
                        extra.extend(base.iter().map(|&(c, t)| (c * factor, t * factor)));
                    }
                }
            }
            Some(Unit::Scale(factors)) => {
                for &factor in factors {
                    extra.extend(base.iter().map(|&(c, t)| (c * factor, t * factor)));
                }
            }
        }
        base.extend(extra);
        base.into_iter().map(|(c, t)| (c, t + 1e-9 * c.max(1.0))).collect()
    }
}

/// Spaces the docs may put between groups of three digits.
fn is_group_space(c: char) -> bool {
    matches!(c, ' ' | '\u{2009}' | '\u{202F}' | '\u{A0}')
}

/// A char that makes digits touching it part of a word (an identifier).
fn is_word_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_' || c.is_alphabetic()
}

fn superscript_digit(c: char) -> Option<u32> {
    match c {
        '⁰' => Some(0),
        '¹' => Some(1),
        '²' => Some(2),
        '³' => Some(3),
        '⁴'..='⁹' => Some(u32::from(c) - u32::from('⁴') + 4),
        _ => None,
    }
}

/// Chars between two figures of one list (`1.1 3.7 20.4 %`, `10–12 %`,
/// `246, 252, 253 ms`, `3.5 / — / 14.1 MiB`): a unit after the last applies
/// to all of them.
fn is_list_gap(gap: &[char]) -> bool {
    gap.iter().all(|&c| c.is_whitespace() || matches!(c, '/' | '–' | '-' | '−' | ',' | '—'))
}

/// Reads `digits` at `i`; returns the digits and the index after them.
fn digits_at(chars: &[char], mut i: usize) -> (String, usize) {
    let mut s = String::new();
    while i < chars.len() && chars[i].is_ascii_digit() {
        s.push(chars[i]);
        i += 1;
    }
    (s, i)
}

/// The end of the word (letters, digits, `_`) that `i` lies in.
fn word_end(chars: &[char], mut i: usize) -> usize {
    while i < chars.len() && is_word_char(chars[i]) {
        i += 1;
    }
    i
}

/// An ISO date `YYYY-MM-DD` at `i`, not followed by a digit.
fn date_at(chars: &[char], i: usize) -> Option<String> {
    let s: String = chars.get(i..i + 10)?.iter().collect();
    let b = s.as_bytes();
    let ok = b.iter().enumerate().all(|(k, &c)| if k == 4 || k == 7 { c == b'-' } else { c.is_ascii_digit() });
    let after = chars.get(i + 10).is_some_and(|c| c.is_ascii_digit());
    (ok && !after).then_some(s)
}

/// Every figure in `text` (already cleaned of code spans, links and HTML:
/// see [`clean`]). `group`: whether `10 000` is one number (the docs' way)
/// or two (a command's arguments).
fn figures(text: &str, group: bool) -> Vec<Figure> {
    let chars: Vec<char> = text.chars().collect();
    let n = chars.len();
    let mut out: Vec<Figure> = Vec::new();
    let mut i = 0;
    while i < n {
        let c = chars[i];
        let prev = if i > 0 { Some(chars[i - 1]) } else { None };
        let starts_number = c.is_ascii_digit()
            || (c == '.'
                && chars.get(i + 1).is_some_and(char::is_ascii_digit)
                && prev.is_none_or(|p| !p.is_ascii_digit()));
        let is_sign = matches!(c, '-' | '−' | '+')
            && chars.get(i + 1).is_some_and(char::is_ascii_digit)
            && prev.is_none_or(|p| !is_word_char(p) && !matches!(p, ')' | ']' | '.'));
        if !starts_number && !is_sign {
            i += 1;
            continue;
        }
        if prev.is_some_and(is_word_char) {
            // Digits inside a word: `H100`, `f32`, `Rgba16Float`, `a27cb61`.
            i = word_end(&chars, i).max(i + 1);
            continue;
        }
        let start = i;
        let negative = is_sign && c != '+';
        let mut j = if is_sign { i + 1 } else { i };
        if let Some(date) = date_at(&chars, j) {
            out.push(Figure { text: date.clone(), kind: Kind::Date(date), unit: None, start, end: j + 10 });
            i = j + 10;
            continue;
        }
        // The integer part, with groups of three after a space.
        let (mut int, after) = digits_at(&chars, j);
        j = after;
        if group && (1..=3).contains(&int.len()) {
            while chars.get(j).is_some_and(|&c| is_group_space(c))
                && chars.get(j + 1..j + 4).is_some_and(|d| d.iter().all(char::is_ascii_digit))
                && !chars.get(j + 4).is_some_and(char::is_ascii_digit)
            {
                int.extend(&chars[j + 1..j + 4]);
                j += 4;
            }
        }
        // The fraction.
        let mut fraction = String::new();
        if chars.get(j) == Some(&'.') && chars.get(j + 1).is_some_and(char::is_ascii_digit) {
            let (f, after) = digits_at(&chars, j + 1);
            fraction = f;
            j = after;
            if chars.get(j) == Some(&'.') && chars.get(j + 1).is_some_and(char::is_ascii_digit) {
                // A version (`0.19.1`, `580.159.04`): a name, not a figure.
                while j < n && (chars[j].is_ascii_digit() || chars[j] == '.') {
                    j += 1;
                }
                i = j;
                continue;
            }
        }
        let int_value = if int.is_empty() { "0" } else { int.as_str() };
        let mantissa: f64 = format!("{int_value}.{fraction}0").parse().expect("digits");
        let mantissa = if negative { -mantissa } else { mantissa };
        let decimals = i32::try_from(fraction.len()).expect("a short fraction");
        let mut kind = Kind::Number { value: mantissa, exponent: -decimals };
        // A scientific exponent: `1e6`, `1e-4`.
        if matches!(chars.get(j), Some('e' | 'E')) {
            let mut k = j + 1;
            let exp_negative = matches!(chars.get(k), Some('-' | '−'));
            if matches!(chars.get(k), Some('-' | '−' | '+')) {
                k += 1;
            }
            let (exp, after) = digits_at(&chars, k);
            if !exp.is_empty() && !chars.get(after).is_some_and(|&c| is_word_char(c)) {
                let exp: i32 = exp.parse().expect("digits");
                let exp = if exp_negative { -exp } else { exp };
                kind = Kind::Number { value: mantissa * 10f64.powi(exp), exponent: exp - decimals };
                j = after;
            }
        }
        // A power: `64²`, `2⁻⁵`, `2^40`.
        let mut power_negative = false;
        let mut k = j;
        if matches!(chars.get(k), Some('⁻')) {
            power_negative = true;
            k += 1;
        }
        let mut power: Option<i32> = None;
        while let Some(d) = chars.get(k).and_then(|&c| superscript_digit(c)) {
            power = Some(power.unwrap_or(0) * 10 + i32::try_from(d).expect("a digit"));
            k += 1;
        }
        if power.is_none() && chars.get(j) == Some(&'^') {
            k = j + 1;
            if matches!(chars.get(k), Some('-' | '−')) {
                power_negative = true;
                k += 1;
            }
            let (p, after) = digits_at(&chars, k);
            if !p.is_empty() {
                power = Some(p.parse().expect("digits"));
                k = after;
            }
        }
        if let Some(p) = power {
            kind = Kind::Power { base: mantissa, exponent: -decimals, power: if power_negative { -p } else { p } };
            j = k;
        }
        let end = j;
        // A suffix touching the number: `10k`, `2.6×` (no unit), `0.5ms`.
        let mut unit = None;
        let mut text_end = end;
        if chars.get(j).is_some_and(|&c| c.is_alphabetic()) {
            let mut w = j;
            while w < n && chars[w].is_alphabetic() {
                w += 1;
            }
            if chars.get(w).is_some_and(|&c| c.is_ascii_digit() || c == '_') {
                // `6f40d08`, `0x1F`, `4x4_tiles`: an identifier.
                i = word_end(&chars, w);
                continue;
            }
            let word: String = chars[j..w].iter().collect();
            if word == "K"
                && matches!(kind, Kind::Number { value, exponent: 0 } if [2.0, 4.0, 5.0, 8.0].contains(&value))
            {
                // `4K`, `8K`: a display resolution's name.
                i = w;
                continue;
            }
            unit = unit_of(&word);
            text_end = w;
        } else {
            // A unit after one space: `0.47 ms`, `95.7 %`, `143 k`, `14.1 MiB`.
            let mut w = j;
            if chars.get(w).is_some_and(|&c| is_group_space(c)) {
                w += 1;
            }
            if chars.get(w) == Some(&'%') {
                unit = Some(Unit::Percent);
                text_end = w + 1;
            } else {
                let mut e = w;
                while e < n && chars[e].is_alphabetic() {
                    e += 1;
                }
                if e > w && !chars.get(e).is_some_and(|&c| is_word_char(c)) {
                    let word: String = chars[w..e].iter().collect();
                    if let Some(u) = unit_of(&word) {
                        unit = Some(u);
                        text_end = e;
                    }
                }
            }
        }
        out.push(Figure { text: chars[start..text_end].iter().collect(), kind, unit, start, end });
        i = text_end;
    }
    // A unit after the last figure of a list applies to the whole list.
    for k in (1..out.len()).rev() {
        if let Some(unit) = out[k].unit
            && out[k - 1].unit.is_none()
            && !matches!(out[k - 1].kind, Kind::Date(_))
            && is_list_gap(&chars[out[k - 1].end..out[k].start])
        {
            out[k - 1].unit = Some(unit);
        }
    }
    out
}

/// `text` without what holds names rather than figures: HTML comments and
/// tags, code spans, link targets (`](…)`, `][…]`, `<https://…>`); `\|` is
/// a `|`. Each removed piece becomes a space.
fn clean(text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let n = chars.len();
    let mut out = String::new();
    let mut i = 0;
    let starts_with = |i: usize, s: &str| s.chars().enumerate().all(|(k, c)| chars.get(i + k) == Some(&c));
    while i < n {
        let c = chars[i];
        if starts_with(i, "<!--") {
            let close = (i + 4..n).find(|&k| starts_with(k, "-->")).map_or(n, |k| k + 3);
            out.push(' ');
            i = close;
        } else if c == '<' && chars.get(i + 1).is_some_and(|&d| d.is_ascii_alphabetic() || d == '/' || d == '!') {
            let close = (i..n).find(|&k| chars[k] == '>').map_or(n, |k| k + 1);
            out.push(' ');
            i = close;
        } else if c == '`' {
            let mut run = i;
            while run < n && chars[run] == '`' {
                run += 1;
            }
            let len = run - i;
            // The next run of exactly `len` backticks closes the span.
            let mut k = run;
            let mut close = None;
            while k < n {
                if chars[k] == '`' {
                    let mut e = k;
                    while e < n && chars[e] == '`' {
                        e += 1;
                    }
                    if e - k == len {
                        close = Some(e);
                        break;
                    }
                    k = e;
                } else {
                    k += 1;
                }
            }
            match close {
                Some(e) => {
                    out.push(' ');
                    i = e;
                }
                None => {
                    out.extend(&chars[i..run]);
                    i = run;
                }
            }
        } else if c == ']' && matches!(chars.get(i + 1), Some('(' | '[')) {
            let (open, shut) = if chars[i + 1] == '(' { ('(', ')') } else { ('[', ']') };
            let mut depth = 0;
            let mut k = i + 1;
            while k < n {
                if chars[k] == open {
                    depth += 1;
                } else if chars[k] == shut {
                    depth -= 1;
                    if depth == 0 {
                        break;
                    }
                }
                k += 1;
            }
            out.push(' ');
            i = k + 1;
        } else if c == '\\' && chars.get(i + 1).is_some_and(|d| d.is_ascii_punctuation()) {
            out.push(chars[i + 1]);
            i += 2;
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

// ---------------------------------------------------------------------------
// Records.
// ---------------------------------------------------------------------------

/// One number a record holds.
#[derive(Clone, Copy, Debug)]
struct Number {
    /// Its magnitude.
    value: f64,
    /// Where in its record it is: an index into [`Records::keys`].
    key: usize,
    /// Which record holds it (their order in [`Records::of`]).
    record: usize,
    /// The list of plain values it is an element of (an id, one per JSON
    /// array in the records), or 0 (`[1.1, 3.7, 7.2]`: one list).
    list: usize,
    /// The object it is in that is an element of a list (a table row of
    /// the record, `values.rows[3]`: an id, one per such object), or 0.
    object: usize,
}

/// Where a number is: [`Number`] less its value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Place {
    key: usize,
    record: usize,
    list: usize,
    object: usize,
}

/// What some records hold: every number (sorted by magnitude), with its key
/// and record, and every date.
#[derive(Debug, Default)]
struct Records {
    numbers: Vec<Number>,
    /// Keys: a JSON path, array indices left out (`values.rows[].gpu_ms_median`,
    /// `command.argv`).
    keys: Vec<String>,
    /// Each record's date.
    dates: Vec<String>,
    count: usize,
    /// Lists and list objects numbered so far.
    lists: usize,
    objects: usize,
}

/// Which parts of a record back figures.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Pool {
    /// `values` (less its `_samples`), `adapter` and `command`: the check's.
    Figures,
    /// Every part, samples and `host` included: what the check pooled before
    /// issue 27's review, kept for [`raised_decimals`]' comparison.
    Everything,
}

impl Records {
    /// The numbers in `[centre - tolerance, centre + tolerance]`.
    fn within(&self, centre: f64, tolerance: f64) -> &[Number] {
        let first = self.numbers.partition_point(|n| n.value < centre - tolerance);
        let last = self.numbers.partition_point(|n| n.value <= centre + tolerance);
        &self.numbers[first..last.max(first)]
    }

    /// Every place (key, record, list, object) holding a number that backs
    /// `figure` (a date: the records of that day, under the key `date`).
    fn backers(&self, figure: &Figure) -> Vec<Place> {
        let mut out: Vec<Place> = match &figure.kind {
            Kind::Date(date) => {
                let key = self.keys.iter().position(|k| k == "date").unwrap_or(usize::MAX);
                let days = self.dates.iter().enumerate().filter(|(_, d)| d.starts_with(date.as_str()));
                days.map(|(record, _)| Place { key, record, list: 0, object: 0 }).collect()
            }
            _ => figure
                .intervals()
                .into_iter()
                .flat_map(|(c, t)| {
                    self.within(c, t).iter().map(|n| Place {
                        key: n.key,
                        record: n.record,
                        list: n.list,
                        object: n.object,
                    })
                })
                .collect(),
        };
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Whether `figure` is backed by these records.
    fn backs(&self, figure: &Figure) -> bool {
        !self.backers(figure).is_empty()
    }

    fn key(&mut self, path: &str) -> usize {
        match self.keys.iter().position(|k| k == path) {
            Some(key) => key,
            None => {
                self.keys.push(path.to_owned());
                self.keys.len() - 1
            }
        }
    }

    fn push(&mut self, value: f64, path: &str, (list, object): (usize, usize)) {
        let (key, record) = (self.key(path), self.count - 1);
        self.numbers.push(Number { value: value.abs(), key, record, list, object });
    }

    fn add_text(&mut self, text: &str, path: &str, at: (usize, usize)) {
        for group in [true, false] {
            for figure in figures(text, group) {
                if let Some(v) = figure.value() {
                    self.push(v, path, at);
                }
            }
        }
    }

    /// Every number in `value` (at `path`; `at`: the list it is an element
    /// of, and the list object it is in, or 0), and every figure in its
    /// strings; with [`Pool::Figures`], no array under a `_samples` key.
    fn add_json(&mut self, value: &Value, path: &str, at: (usize, usize), pool: Pool) {
        match value {
            Value::Number(n) => {
                if let Some(v) = n.as_f64() {
                    self.push(v, path, at);
                }
            }
            // A string in a list is a list of its own (`"oxygen N=10000
            // median_ms=0.89 p10_ms=0.83"`).
            Value::String(s) if at.0 != 0 => {
                self.lists += 1;
                self.add_text(s, path, (self.lists, at.1));
            }
            Value::String(s) => self.add_text(s, path, at),
            Value::Array(items) => {
                self.lists += 1;
                let list = self.lists;
                for item in items {
                    // An object's members are not the list's elements: it
                    // is a row of its own.
                    let at = if item.is_object() {
                        self.objects += 1;
                        (0, self.objects)
                    } else {
                        (list, at.1)
                    };
                    self.add_json(item, &format!("{path}[]"), at, pool);
                }
            }
            Value::Object(map) => {
                for (key, v) in map {
                    if pool == Pool::Everything || !(key.ends_with(SAMPLES_SUFFIX) && v.is_array()) {
                        self.add_json(v, &format!("{path}.{key}"), (0, at.1), pool);
                    }
                }
            }
            Value::Null | Value::Bool(_) => {}
        }
    }

    /// Adds a checked record.
    fn add(&mut self, record: &serde_json::Map<String, Value>, pool: Pool) {
        self.count += 1;
        let fields: &[&str] = match pool {
            Pool::Figures => &["values", "adapter", "command"],
            Pool::Everything => &["values", "host", "adapter", "command"],
        };
        for field in fields {
            self.add_json(&record[*field], field, (0, 0), pool);
        }
        self.key("date");
        self.dates.push(record["date"].as_str().unwrap_or_default().to_owned());
    }

    fn finish(&mut self) {
        let order = |n: &Number| (n.key, n.record, n.list, n.object);
        self.numbers.sort_by(|a, b| a.value.total_cmp(&b.value).then(order(a).cmp(&order(b))));
        self.numbers.dedup_by(|a, b| a.value == b.value && order(a) == order(b));
    }

    /// The numbers and dates of `entries`.
    fn of<'a>(entries: impl IntoIterator<Item = &'a Entry>, pool: Pool) -> Records {
        let mut records = Records::default();
        for entry in entries {
            records.add(&entry.fields, pool);
        }
        records.finish();
        records
    }
}

/// One record, as read from its file.
#[derive(Debug)]
struct Entry {
    /// `docs/records/<bench>.jsonl`, as the docs name it.
    file: String,
    /// Its line in the file (1-based).
    line: usize,
    commit: String,
    /// The adapter's `name` and `driver`; `None` for a CPU-only record.
    adapter: Option<(String, String)>,
    /// `command.argv`, or the command when it is a string.
    argv: String,
    /// `command.env`.
    env: BTreeMap<String, String>,
    fields: serde_json::Map<String, Value>,
}

impl Entry {
    fn new(file: String, line: usize, fields: serde_json::Map<String, Value>) -> Entry {
        let text = |v: Option<&Value>| v.and_then(Value::as_str).unwrap_or_default().to_owned();
        let adapter =
            fields.get("adapter").and_then(Value::as_object).map(|a| (text(a.get("name")), text(a.get("driver"))));
        let (argv, env) = match fields.get("command") {
            Some(Value::Object(command)) => {
                let env = command
                    .get("env")
                    .and_then(Value::as_object)
                    .map(|env| env.iter().map(|(k, v)| (k.clone(), text(Some(v)))).collect())
                    .unwrap_or_default();
                (text(command.get("argv")), env)
            }
            command => (text(command), BTreeMap::new()),
        };
        Entry { file, line, commit: text(fields.get("commit")), adapter, argv, env, fields }
    }

    /// The words a `Record:` line may name this record's adapter by
    /// (lowercase): those of its name before `(` with 4 characters or more,
    /// and `lavapipe` for Mesa's llvmpipe.
    fn adapter_words(&self) -> Vec<String> {
        let Some((name, driver)) = &self.adapter else { return Vec::new() };
        let mut words: Vec<String> = name
            .split('(')
            .next()
            .unwrap_or_default()
            .split(|c: char| !c.is_alphanumeric())
            .filter(|w| w.chars().count() >= 4)
            .map(str::to_lowercase)
            .collect();
        if name.to_lowercase().contains("llvmpipe") || driver.to_lowercase() == "llvmpipe" {
            words.push("lavapipe".to_owned());
        }
        words
    }

    /// Where it is, for messages.
    fn place(&self) -> String {
        format!("{}:{}", self.file, self.line)
    }
}

/// The fields of a record, in order.
const RECORD_FIELDS: [&str; 8] = ["bench", "commit", "dirty", "date", "adapter", "host", "command", "values"];

/// Why `line` is not a record (`bench`: the file's stem, which a record's
/// bench must equal).
fn check_record(line: &str, bench: &str) -> Result<serde_json::Map<String, Value>, String> {
    let value: Value = serde_json::from_str(line).map_err(|e| format!("not JSON: {e}"))?;
    let Value::Object(map) = value else {
        return Err("not a JSON object".to_owned());
    };
    let mut problems = Vec::new();
    for field in RECORD_FIELDS {
        if !map.contains_key(field) {
            problems.push(format!("no `{field}`"));
        }
    }
    for key in map.keys() {
        if !RECORD_FIELDS.contains(&key.as_str()) {
            problems.push(format!("unknown field `{key}`"));
        }
    }
    let is_string = |field: &str| map.get(field).is_none_or(Value::is_string);
    for field in ["bench", "commit", "date"] {
        if !is_string(field) {
            problems.push(format!("`{field}` is not a string"));
        }
    }
    if let Some(b) = map.get("bench").and_then(Value::as_str)
        && b != bench
    {
        problems.push(format!("`bench` is {b:?} in {bench}.jsonl"));
    }
    if map.get("date").and_then(Value::as_str).is_some_and(|d| date_at(&d.chars().collect::<Vec<_>>(), 0).is_none()) {
        problems.push("`date` does not start with YYYY-MM-DD".to_owned());
    }
    if map.get("dirty").is_some_and(|d| !d.is_boolean() && !d.is_null()) {
        problems.push("`dirty` is not a boolean or null".to_owned());
    }
    match map.get("adapter") {
        None | Some(Value::Null) => {}
        Some(Value::Object(adapter)) => {
            for field in ["name", "backend", "device_type", "driver", "driver_info"] {
                if !adapter.get(field).is_some_and(Value::is_string) {
                    problems.push(format!("`adapter.{field}` is not a string"));
                }
            }
        }
        Some(_) => problems.push("`adapter` is not an object or null".to_owned()),
    }
    if map.get("host").is_some_and(|h| !h.is_object()) {
        problems.push("`host` is not an object".to_owned());
    }
    // The command: a string, or the writer's `{"argv": "...", "env": {...}}`.
    match map.get("command") {
        None | Some(Value::String(_)) => {}
        Some(Value::Object(command)) => {
            if !command.get("argv").is_some_and(Value::is_string) {
                problems.push("`command.argv` is not a string".to_owned());
            }
            match command.get("env") {
                None => {}
                Some(Value::Object(env)) if env.values().all(Value::is_string) => {}
                Some(_) => problems.push("`command.env` is not an object of strings".to_owned()),
            }
        }
        Some(_) => problems.push("`command` is not a string or an object".to_owned()),
    }
    match map.get("values") {
        None => {}
        Some(Value::Object(values)) if values.is_empty() => problems.push("`values` is empty".to_owned()),
        Some(Value::Object(_)) => {}
        Some(_) => problems.push("`values` is not an object".to_owned()),
    }
    if problems.is_empty() { Ok(map) } else { Err(problems.join("; ")) }
}

/// Reads every `*.jsonl` in `dir` (none when `dir` does not exist); the
/// records, and a message for each malformed line.
fn read_records(dir: &Path) -> (Vec<Entry>, Vec<String>) {
    let mut records = Vec::new();
    let mut problems = Vec::new();
    let mut files: Vec<PathBuf> = match std::fs::read_dir(dir) {
        Ok(entries) => entries
            .map(|e| e.expect("a readable docs/records entry").path())
            .filter(|p| p.extension().is_some_and(|e| e == "jsonl"))
            .collect(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
        Err(e) => panic!("cannot read {}: {e}", dir.display()),
    };
    files.sort();
    for path in files {
        let shown = path.strip_prefix(root()).unwrap_or(&path).display().to_string();
        let bench = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let text = match std::fs::read_to_string(&path) {
            Ok(text) => text,
            Err(e) => {
                problems.push(format!("{shown}: unreadable: {e}"));
                continue;
            }
        };
        for (index, line) in text.lines().enumerate() {
            match check_record(line, &bench) {
                Ok(record) => records.push(Entry::new(format!("{RECORDS_DIR}/{bench}.jsonl"), index + 1, record)),
                Err(why) => problems.push(format!("{shown}:{}: malformed record: {why}", index + 1)),
            }
        }
    }
    (records, problems)
}

// ---------------------------------------------------------------------------
// A table's `Record:` line: which records back it.
// ---------------------------------------------------------------------------

/// What a table's `Record:` paragraph names.
#[derive(Debug, Default, PartialEq)]
struct Source {
    /// `docs/records/NAME.jsonl`, in the order named.
    files: Vec<String>,
    /// Commit prefixes.
    commits: Vec<String>,
    /// The words outside code spans, lowercase (adapters are named by them).
    words: Vec<String>,
    /// The code spans' contents (commands among them).
    spans: Vec<String>,
}

/// The contents of the code spans of `text` (runs of backticks closed by a
/// run of the same length).
fn code_spans(text: &str) -> Vec<String> {
    let chars: Vec<char> = text.chars().collect();
    let n = chars.len();
    let run_at = |i: usize| chars[i..].iter().take_while(|&&c| c == '`').count();
    let mut spans = Vec::new();
    let mut i = 0;
    while i < n {
        if chars[i] != '`' {
            i += 1;
            continue;
        }
        let len = run_at(i);
        let mut k = i + len;
        let mut close = None;
        while k < n {
            if chars[k] == '`' {
                let run = run_at(k);
                if run == len {
                    close = Some(k);
                    break;
                }
                k += run;
            } else {
                k += 1;
            }
        }
        match close {
            Some(k) => {
                spans.push(chars[i + len..k].iter().collect::<String>().trim().to_owned());
                i = k + len;
            }
            None => i += len,
        }
    }
    spans
}

/// Whether `word` reads as a commit hash (see the file's top comment).
fn is_commit(word: &str) -> bool {
    (7..=40).contains(&word.len())
        && word.chars().all(|c| c.is_ascii_digit() || ('a'..='f').contains(&c))
        && word.chars().any(|c| c.is_ascii_digit())
        && word.chars().any(|c| c.is_ascii_alphabetic())
}

/// What the `Record:` paragraph `text` names; `Err` when it names no file.
fn parse_source(text: &str) -> Result<Source, String> {
    let mut source = Source::default();
    let prefix = format!("{RECORDS_DIR}/");
    let mut rest = text;
    while let Some(at) = rest.find(&prefix) {
        let after = &rest[at + prefix.len()..];
        let stem_len =
            after.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '-')).unwrap_or(after.len());
        if stem_len > 0 && after[stem_len..].starts_with(".jsonl") {
            let file = format!("{prefix}{}.jsonl", &after[..stem_len]);
            if !source.files.contains(&file) {
                source.files.push(file);
            }
        }
        rest = &after[stem_len..];
    }
    if source.files.is_empty() {
        return Err(format!("it names no record file (`{RECORDS_DIR}/NAME.jsonl`)"));
    }
    let outside = clean(text);
    for word in outside.split(|c: char| !c.is_alphanumeric()).filter(|w| !w.is_empty()) {
        if is_commit(word) && !source.commits.iter().any(|c| c == word) {
            source.commits.push(word.to_owned());
        }
        source.words.push(word.to_lowercase());
    }
    source.spans = code_spans(text);
    Ok(source)
}

/// A command as a `Record:` line or a record writes it.
#[derive(Debug, PartialEq)]
struct Command {
    /// `VAR=value` words before the program.
    env: Vec<(String, String)>,
    /// The program's name, its path stripped.
    program: String,
    args: Vec<String>,
}

/// `text` split into words as a shell would: at whitespace, quotes
/// grouping (and removed).
fn shell_words(text: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut word: Option<String> = None;
    let mut quote: Option<char> = None;
    for c in text.chars() {
        match quote {
            Some(q) if c == q => quote = None,
            Some(_) => word.get_or_insert_with(String::new).push(c),
            None if c == '"' || c == '\'' => {
                quote = Some(c);
                word.get_or_insert_with(String::new);
            }
            None if c.is_whitespace() => words.extend(word.take()),
            None => word.get_or_insert_with(String::new).push(c),
        }
    }
    words.extend(word);
    words
}

/// An environment assignment `VAR=value` (`VAR` a shell name).
fn assignment(word: &str) -> Option<(String, String)> {
    let (name, value) = word.split_once('=')?;
    let mut chars = name.chars();
    let first = chars.next()?;
    ((first.is_ascii_alphabetic() || first == '_') && chars.all(|c| c.is_ascii_alphanumeric() || c == '_'))
        .then(|| (name.to_owned(), value.to_owned()))
}

/// `text` read as a command line; `None` when it has no program word.
fn parse_command(text: &str) -> Option<Command> {
    let mut words = shell_words(text).into_iter().peekable();
    let mut env = Vec::new();
    while let Some(pair) = words.peek().and_then(|w| assignment(w)) {
        env.push(pair);
        words.next();
    }
    let program = words.next()?;
    let program = program.rsplit('/').next().unwrap_or_default().to_owned();
    (!program.is_empty()).then(|| Command { env, program, args: words.collect() })
}

/// Whether a `Record:` line's argument `doc` stands for the record's `arg`.
fn argument_matches(doc: &str, arg: &str) -> bool {
    let placeholder = !doc.is_empty() && doc.chars().all(|c| c.is_ascii_uppercase());
    placeholder || doc.split('|').any(|d| d == arg)
}

/// Whether the `Record:` line's command `doc` is what `entry` ran.
fn command_matches(doc: &Command, entry: &Entry) -> bool {
    let Some(ran) = parse_command(&entry.argv) else { return false };
    if ran.program != doc.program {
        return false;
    }
    let mut args = doc.args.clone();
    for (name, value) in &doc.env {
        match entry.env.get(name) {
            Some(set) => {
                if !value.split('|').any(|v| v == set) {
                    return false;
                }
            }
            // A variable the record keeps among its arguments
            // (`peer-bench.sh CONFIGS=… ROUNDS=3`).
            None => args.extend(format!("{name}={value}").split_whitespace().map(str::to_owned)),
        }
    }
    let ran_args: Vec<String> = ran.env.iter().map(|(k, v)| format!("{k}={v}")).chain(ran.args).collect();
    args.len() == ran_args.len() && args.iter().zip(&ran_args).all(|(d, r)| argument_matches(d, r))
}

/// The records `source` names, among `entries` (the rule: the file's top
/// comment); `Err` says what it names that no record matches.
fn select<'a>(source: &Source, entries: &'a [Entry]) -> Result<Vec<&'a Entry>, String> {
    let mut chosen: Vec<&Entry> = entries.iter().filter(|e| source.files.contains(&e.file)).collect();
    for file in &source.files {
        if !chosen.iter().any(|e| &e.file == file) {
            return Err(format!("it names {file}, which holds no record"));
        }
    }
    let files = source.files.join(" and ");
    if !source.commits.is_empty() {
        for commit in &source.commits {
            if !chosen.iter().any(|e| e.commit.starts_with(commit.as_str())) {
                return Err(format!("it names commit {commit}, which no record of {files} was made at"));
            }
        }
        chosen.retain(|e| source.commits.iter().any(|c| e.commit.starts_with(c.as_str())));
    }
    let named = |e: &Entry| e.adapter_words().iter().any(|w| source.words.contains(w));
    if chosen.iter().any(|e| named(e)) {
        chosen.retain(|e| e.adapter.is_none() || named(e));
    }
    let programs: Vec<String> = chosen.iter().filter_map(|e| parse_command(&e.argv)).map(|c| c.program).collect();
    let commands: Vec<(&String, Command)> = source
        .spans
        .iter()
        .filter_map(|span| parse_command(span).map(|c| (span, c)))
        .filter(|(_, c)| programs.contains(&c.program))
        .collect();
    for (span, command) in &commands {
        if !chosen.iter().any(|e| command_matches(command, e)) {
            return Err(format!(
                "no record of {files} at its commits and adapters ran `{span}` (every command spelt out, see tests/doc_records.rs)"
            ));
        }
    }
    // A record whose program some command names must be one of them.
    chosen.retain(|e| {
        let program = parse_command(&e.argv).map(|c| c.program);
        let mut naming = commands.iter().filter(|(_, c)| Some(&c.program) == program.as_ref()).peekable();
        naming.peek().is_none() || naming.any(|(_, c)| command_matches(c, e))
    });
    if chosen.is_empty() {
        return Err(format!("no record of {files} is all it names"));
    }
    Ok(chosen)
}

// ---------------------------------------------------------------------------
// Tables.
// ---------------------------------------------------------------------------

#[derive(Clone, Debug, PartialEq)]
enum Marker {
    NotMeasured(String),
    Owed(String),
}

/// One row: its line number (1-based) and its cells, raw.
#[derive(Debug)]
struct Row {
    line: usize,
    cells: Vec<String>,
}

#[derive(Debug)]
struct Table {
    doc: String,
    /// The line of its first row (1-based).
    line: usize,
    marker: Option<Marker>,
    /// Header row first; the separator row is left out.
    rows: Vec<Row>,
    header_text: String,
    /// The `Record:` paragraph under it: its first line (1-based) and its
    /// text, lines joined by spaces.
    source: Option<(usize, String)>,
}

/// Whether `line` starts a `Record:` paragraph.
fn is_source_line(line: &str) -> bool {
    SOURCE_PREFIXES.iter().any(|p| line.trim_start().starts_with(p))
}

/// The `Record:` paragraph of the table whose rows end before line index
/// `after` (0-based): on that line, or on the next after one blank line.
fn source_after(lines: &[&str], after: usize) -> Option<(usize, String)> {
    let first = if lines.get(after).is_some_and(|l| l.trim().is_empty()) { after + 1 } else { after };
    if !lines.get(first).is_some_and(|l| is_source_line(l)) {
        return None;
    }
    let paragraph: Vec<&str> = lines[first..]
        .iter()
        .take_while(|l| !l.trim().is_empty() && !l.trim_start().starts_with('|') && !l.trim_start().starts_with("```"))
        .map(|l| l.trim())
        .collect();
    Some((first + 1, paragraph.join(" ")))
}

/// The marker on `line`, if the line is one (`Err`: it tries to be one
/// and is not right).
fn parse_marker(line: &str) -> Option<Result<Marker, String>> {
    let t = line.trim();
    let inner = t.strip_prefix("<!--")?.trim_start();
    let rest = inner.strip_prefix(MARKER_PREFIX)?;
    let Some(rest) = rest.trim_end().strip_suffix("-->") else {
        return Some(Err("a figures marker must be one line ending in `-->`".to_owned()));
    };
    let rest = rest.trim();
    let (kind, reason) = if let Some(r) = rest.strip_prefix("not measured") {
        ("not measured", r)
    } else if let Some(r) = rest.strip_prefix("owed") {
        ("owed", r)
    } else {
        return Some(Err(format!(
            "unknown figures marker {rest:?}: write `<!-- figures: not measured — REASON -->` or `<!-- figures: owed — REASON -->`"
        )));
    };
    let Some(reason) = reason.trim_start().strip_prefix(['—', '–']).map(str::trim) else {
        return Some(Err(format!("the `{kind}` marker needs ` — REASON` after its kind")));
    };
    if reason.split_whitespace().count() < MIN_REASON_WORDS {
        return Some(Err(format!("the `{kind}` marker's reason {reason:?} is too short to be one")));
    }
    Some(Ok(match kind {
        "owed" => Marker::Owed(reason.to_owned()),
        _ => Marker::NotMeasured(reason.to_owned()),
    }))
}

/// A table row's cells (GFM: split at unescaped `|`, outer pipes dropped).
fn split_row(line: &str) -> Vec<String> {
    let t = line.trim();
    let t = t.strip_prefix('|').unwrap_or(t);
    let t = if t.ends_with('|') && !t.ends_with("\\|") { &t[..t.len() - 1] } else { t };
    let mut cells = vec![String::new()];
    let mut chars = t.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '\\' && chars.peek() == Some(&'|') {
            cells.last_mut().expect("a cell").push_str("\\|");
            chars.next();
        } else if c == '|' {
            cells.push(String::new());
        } else {
            cells.last_mut().expect("a cell").push(c);
        }
    }
    cells.into_iter().map(|c| c.trim().to_owned()).collect()
}

fn is_separator_row(cells: &[String]) -> bool {
    !cells.is_empty()
        && cells.iter().all(|c| {
            let c = c.trim();
            let c = c.strip_prefix(':').unwrap_or(c);
            let c = c.strip_suffix(':').unwrap_or(c);
            !c.is_empty() && c.chars().all(|ch| ch == '-')
        })
}

/// The tables of the Markdown `text` (named `doc`), and a message for each
/// marker that is malformed or stands before no table.
fn parse_tables(doc: &str, text: &str) -> (Vec<Table>, Vec<String>) {
    let lines: Vec<&str> = text.lines().collect();
    let mut tables: Vec<Table> = Vec::new();
    let mut problems = Vec::new();
    let mut fence: Option<(char, usize)> = None;
    let mut i = 0;
    while i < lines.len() {
        let t = lines[i].trim_start();
        // Code fences hold no tables and no markers.
        let fence_char = t.chars().next().filter(|&c| c == '`' || c == '~');
        if let Some(c) = fence_char {
            let len = t.chars().take_while(|&d| d == c).count();
            if len >= 3 {
                match fence {
                    None => fence = Some((c, len)),
                    Some((open, open_len)) if open == c && len >= open_len && t.trim_end().chars().all(|d| d == c) => {
                        fence = None;
                    }
                    Some(_) => {}
                }
                i += 1;
                continue;
            }
        }
        if fence.is_some() {
            i += 1;
            continue;
        }
        if let Some(marker) = parse_marker(lines[i]) {
            let next_is_table = lines.get(i + 1).is_some_and(|l| l.trim_start().starts_with('|'));
            match marker {
                Err(why) => problems.push(format!("{doc}:{}: {why}", i + 1)),
                Ok(_) if !next_is_table => {
                    problems
                        .push(format!("{doc}:{}: a figures marker must be on the line right before a table", i + 1));
                }
                Ok(_) => {}
            }
            i += 1;
            continue;
        }
        if t.starts_with('|') {
            let marker = i.checked_sub(1).and_then(|p| parse_marker(lines[p])).and_then(Result::ok);
            let first = i;
            let mut rows = Vec::new();
            while i < lines.len() && lines[i].trim_start().starts_with('|') {
                let cells = split_row(lines[i]);
                if !is_separator_row(&cells) {
                    rows.push(Row { line: i + 1, cells });
                }
                i += 1;
            }
            tables.push(Table {
                doc: doc.to_owned(),
                line: first + 1,
                marker,
                rows,
                header_text: lines[first].trim().to_owned(),
                source: source_after(&lines, i),
            });
            continue;
        }
        i += 1;
    }
    (tables, problems)
}

/// The unit a header cell names for its column (exactly one, or none).
fn column_unit(header: &str) -> Option<Unit> {
    let cleaned = clean(header);
    let mut units: Vec<Unit> = Vec::new();
    let mut word = String::new();
    for c in cleaned.chars().chain(std::iter::once(' ')) {
        if c.is_alphanumeric() || c == '%' {
            word.push(c);
        } else {
            // Only `%` and times: a header's `k` or `MB` is too often a name.
            let unit = if ["%", "ms", "s", "µs", "us", "ns"].contains(&word.as_str()) { unit_of(&word) } else { None };
            if let Some(u) = unit
                && !units.contains(&u)
            {
                units.push(u);
            }
            word.clear();
        }
    }
    if units.len() == 1 { units.pop() } else { None }
}

/// One figure of a table, and where it stands.
#[derive(Clone, Debug)]
struct Placed {
    /// Its row: 0 is the header.
    row: usize,
    /// Its row's line (1-based).
    line: usize,
    col: usize,
    /// Its place among its cell's figures.
    pos: usize,
    cell: String,
    figure: Figure,
    /// Whether its column is one of labels (see [`is_label`]).
    label: bool,
}

/// Whether `cell` reads as a label: two words or more (of two letters or
/// more, units aside), as `grid of 10 000 cubes, oblique`.
fn is_label(cell: &str) -> bool {
    let cleaned = clean(cell);
    let words = cleaned.split(|c: char| !c.is_alphabetic()).filter(|w| w.chars().count() >= 2 && unit_of(w).is_none());
    words.count() >= 2
}

/// Every figure of `table`, header units applied to the body's cells.
fn table_figures(table: &Table) -> Vec<Placed> {
    let units: Vec<Option<Unit>> =
        table.rows.first().map(|h| h.cells.iter().map(|c| column_unit(c)).collect()).unwrap_or_default();
    // Columns of labels: every body cell a label.
    let columns = table.rows.iter().map(|r| r.cells.len()).max().unwrap_or(0);
    let labels: Vec<bool> = (0..columns)
        .map(|col| {
            let mut body = table.rows.iter().skip(1).peekable();
            body.peek().is_some() && body.all(|r| r.cells.get(col).is_some_and(|c| is_label(c)))
        })
        .collect();
    let mut out = Vec::new();
    for (r, row) in table.rows.iter().enumerate() {
        for (col, cell) in row.cells.iter().enumerate() {
            for (pos, mut figure) in figures(&clean(cell), true).into_iter().enumerate() {
                if r > 0 && figure.unit.is_none() && !matches!(figure.kind, Kind::Date(_)) {
                    figure.unit = units.get(col).copied().flatten();
                }
                let label = labels[col];
                out.push(Placed { row: r, line: row.line, col, pos, cell: cell.clone(), figure, label });
            }
        }
    }
    out
}

/// What a table's figures must share besides each being in a record.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Binding {
    /// Benches' tables, three rules on the body rows (the header's figures
    /// are each checked alone):
    ///
    /// * a column is one quantity: the figures at one place of one column's
    ///   cells (the first figure of each cell, the second, …) are all under
    ///   one key (`values.rows[].gpu_ms_median`; where several keys back as
    ///   many, the figures may be under any of them); a column of labels
    ///   (every body cell two words or more: `grid of 10 000 cubes,
    ///   oblique`) is not bound;
    /// * a cell's figures under a key of lists are of one list (`1.1 3.7
    ///   7.2 %`: one `worst_relative_rms_per_level`, not three rows' levels;
    ///   a string in a list is a list of its own);
    /// * where figures of a table row share a row of a record (an object in
    ///   a list, `values.rows[3]`), every figure of the table row that comes
    ///   from such rows shares one with another of its figures: a figure
    ///   cannot come from another line of the record than its neighbours.
    Column,
    /// The figures of one body row are all in one record: tables of tests'
    /// records, one test a row, each row its own quantities.
    Row,
}

impl Binding {
    /// Tests' records (their `values` name the test) bind rows; benches'
    /// bind columns.
    fn of(chosen: &[&Entry]) -> Binding {
        let test = |e: &&Entry| e.fields["values"].get("test").is_some_and(Value::is_string);
        if !chosen.is_empty() && chosen.iter().all(test) { Binding::Row } else { Binding::Column }
    }
}

/// What is wrong with `figures` (of the table in `doc`) against `records`
/// (`names`: each record's place, for messages): each figure must be backed
/// by a record number, and the figures must keep the rules of `binding`.
/// Empty when all is well.
fn check_figures(doc: &str, figures: &[Placed], records: &Records, names: &[String], binding: Binding) -> Vec<String> {
    let mut failures = Vec::new();
    let backers: Vec<Vec<Place>> = figures.iter().map(|p| records.backers(&p.figure)).collect();
    for (p, b) in figures.iter().zip(&backers) {
        if b.is_empty() {
            failures.push(format!(
                "{doc}:{}: figure `{}` in cell `{}` is in none of the table's records ({})",
                p.line,
                p.figure.text,
                p.cell,
                names.join(", ")
            ));
        }
    }
    // The groups: indices of backed body figures (dates apart).
    let mut groups: BTreeMap<(usize, usize), Vec<usize>> = BTreeMap::new();
    for (i, p) in figures.iter().enumerate() {
        if p.row > 0 && !backers[i].is_empty() && !matches!(p.figure.kind, Kind::Date(_)) {
            let group = match binding {
                Binding::Column if p.label => continue,
                Binding::Column => (p.col, p.pos),
                Binding::Row => (p.row, 0),
            };
            groups.entry(group).or_default().push(i);
        }
    }
    // What binds a group: a key, or a record.
    let unit = |b: &Place| if binding == Binding::Column { b.key } else { b.record };
    // Per figure, the keys its group is bound to (all that back the most).
    let mut bound: Vec<Vec<usize>> = vec![Vec::new(); figures.len()];
    for members in groups.values() {
        let has = |i: usize, u: usize| backers[i].iter().any(|b| unit(b) == u);
        let count = |u: usize| members.iter().filter(|&&i| has(i, u)).count();
        let candidates = members.iter().flat_map(|&i| backers[i].iter().map(unit));
        let Some(best) = candidates.clone().max_by_key(|&u| (count(u), std::cmp::Reverse(u))) else { continue };
        let backed = count(best);
        let mut best_keys: Vec<usize> = candidates.filter(|&u| count(u) == backed).collect();
        best_keys.sort_unstable();
        best_keys.dedup();
        for &i in members {
            if has(i, best) {
                bound[i] = best_keys.iter().copied().filter(|&u| has(i, u)).collect();
                continue;
            }
            let p = &figures[i];
            let (shared, mut own): (String, Vec<String>) = match binding {
                Binding::Column => (
                    format!(
                        "under `{}`, the key of {backed} of the {} in its column",
                        records.keys[best],
                        members.len()
                    ),
                    backers[i].iter().map(|b| format!("`{}`", records.keys[b.key])).collect(),
                ),
                Binding::Row => (
                    format!("in {}, the record of {backed} of the {} in its row", names[best], members.len()),
                    backers[i].iter().map(|b| names[b.record].clone()).collect(),
                ),
            };
            own.dedup();
            failures.push(format!(
                "{doc}:{}: figure `{}` in cell `{}` is not {shared}; only in {}",
                p.line,
                p.figure.text,
                p.cell,
                own.join(", ")
            ));
        }
    }
    if binding == Binding::Column {
        // One cell's figures under one key of lists: of one list.
        let mut cells: BTreeMap<(usize, usize, usize), Vec<usize>> = BTreeMap::new();
        for (i, keys) in bound.iter().enumerate() {
            for &key in keys {
                if backers[i].iter().any(|b| b.key == key && b.list != 0) {
                    cells.entry((figures[i].row, figures[i].col, key)).or_default().push(i);
                }
            }
        }
        let cells: BTreeMap<_, _> = cells.into_iter().filter(|(_, m)| m.len() > 1).collect();
        let mut apart: Vec<(usize, usize)> = Vec::new();
        for ((_, _, key), members) in &cells {
            let has = |i: usize, list: usize| backers[i].iter().any(|b| b.key == *key && b.list == list);
            let count = |list: usize| members.iter().filter(|&&i| has(i, list)).count();
            let lists = members.iter().flat_map(|&i| backers[i].iter().filter(|b| b.key == *key).map(|b| b.list));
            let Some(best) = lists.max_by_key(|&l| (count(l), std::cmp::Reverse(l))) else { continue };
            apart.extend(members.iter().filter(|&&i| !has(i, best)).map(|&i| (i, *key)));
        }
        // Apart under every key of lists it is bound to, in its cell.
        for (i, p) in figures.iter().enumerate() {
            let keys: Vec<usize> =
                bound[i].iter().copied().filter(|&k| cells.contains_key(&(p.row, p.col, k))).collect();
            if !keys.is_empty() && keys.iter().all(|&k| apart.contains(&(i, k))) {
                failures.push(format!(
                    "{doc}:{}: figure `{}` in cell `{}` is not in the list (`{}`) that holds the cell's other figures",
                    p.line, p.figure.text, p.cell, records.keys[keys[0]]
                ));
            }
        }
        // Rows: where figures of a table row share a row of a record's list
        // (`values.rows[3]`), each of them shares one with another.
        let objects = |i: usize| -> Vec<usize> {
            let keys = &bound[i];
            backers[i].iter().filter(|b| keys.contains(&b.key) && b.object != 0).map(|b| b.object).collect()
        };
        let mut rows: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
        for (i, p) in figures.iter().enumerate() {
            if !objects(i).is_empty() {
                rows.entry(p.row).or_default().push(i);
            }
        }
        for members in rows.values() {
            let shares = |i: usize| {
                let mine = objects(i);
                members.iter().any(|&j| j != i && objects(j).iter().any(|o| mine.contains(o)))
            };
            if !members.iter().any(|&i| shares(i)) {
                continue; // each figure from a row of its own (one figure a record row)
            }
            for &i in members.iter().filter(|&&i| !shares(i)) {
                let p = &figures[i];
                failures.push(format!(
                    "{doc}:{}: figure `{}` in cell `{}` is only in rows of its records (`{}`) that hold no other \
                     figure of its table row",
                    p.line,
                    p.figure.text,
                    p.cell,
                    bound[i].iter().map(|&k| records.keys[k].as_str()).collect::<Vec<_>>().join("`, `")
                ));
            }
        }
    }
    failures
}

/// The records that back `table`: those its `Record:` line names.
fn table_records<'a>(table: &Table, entries: &'a [Entry]) -> Result<Vec<&'a Entry>, String> {
    let Some((line, text)) = &table.source else {
        return Err(format!(
            "{}:{}: table `{}` has no `Record:` line under it (on the line after its last row, or after one blank \
             line: `Record: {RECORDS_DIR}/NAME.jsonl, `command`, commit, adapter`; see tests/doc_records.rs)",
            table.doc, table.line, table.header_text
        ));
    };
    parse_source(text).and_then(|source| select(&source, entries)).map_err(|why| {
        format!(
            "{}:{line}: the `Record:` line of table `{}` (line {}): {why}",
            table.doc, table.header_text, table.line
        )
    })
}

/// What checking the docs found.
#[derive(Debug, Default)]
struct Report {
    /// Per doc: (tables checked, owed, not measured, figures checked).
    counts: Vec<(String, [usize; 4])>,
    /// (doc, line, header, reason, every figure already backed).
    owed: Vec<(String, usize, String, String, bool)>,
    /// Per checked table: (doc, line, the records backing it, how).
    sources: Vec<(String, usize, Vec<String>, Binding)>,
    failures: Vec<String>,
}

/// Checks the tables of `docs` (name, text), each against the records
/// among `entries` that its `Record:` line names.
fn check_docs(docs: &[(String, String)], entries: &[Entry], strict: bool) -> Report {
    let mut report = Report::default();
    for (doc, text) in docs {
        let (tables, problems) = parse_tables(doc, text);
        report.failures.extend(problems);
        let mut counts = [0; 4];
        for table in &tables {
            match &table.marker {
                Some(Marker::NotMeasured(_)) => counts[2] += 1,
                Some(Marker::Owed(reason)) => {
                    counts[1] += 1;
                    // Its records if it names them yet, else all of them.
                    let records = match table_records(table, entries) {
                        Ok(chosen) => Records::of(chosen, Pool::Figures),
                        Err(_) => Records::of(entries, Pool::Figures),
                    };
                    let figures = table_figures(table);
                    let all_backed = !figures.is_empty() && figures.iter().all(|p| records.backs(&p.figure));
                    report.owed.push((doc.clone(), table.line, table.header_text.clone(), reason.clone(), all_backed));
                }
                None => {
                    counts[0] += 1;
                    counts[3] += table_figures(table).len();
                    let chosen = match table_records(table, entries) {
                        Ok(chosen) => chosen,
                        Err(why) => {
                            report.failures.push(why);
                            continue;
                        }
                    };
                    let names: Vec<String> = chosen.iter().map(|e| e.place()).collect();
                    let binding = Binding::of(&chosen);
                    let records = Records::of(chosen, Pool::Figures);
                    report.failures.extend(check_figures(doc, &table_figures(table), &records, &names, binding));
                    report.sources.push((doc.clone(), table.line, names, binding));
                }
            }
        }
        report.counts.push((doc.clone(), counts));
    }
    if strict {
        for (doc, line, header, reason, _) in &report.owed {
            report.failures.push(format!("{doc}:{line}: table still owed ({STRICT_VAR}=1): {header} — {reason}"));
        }
    }
    report
}

fn read_docs() -> Vec<(String, String)> {
    DOCS.iter()
        .map(|doc| {
            let text = std::fs::read_to_string(root().join(doc)).unwrap_or_else(|e| panic!("cannot read {doc}: {e}"));
            ((*doc).to_owned(), text)
        })
        .collect()
}

#[test]
fn every_figure_in_the_docs_tables_is_in_a_record() {
    let (entries, record_problems) = read_records(&root().join(RECORDS_DIR));
    let strict = std::env::var(STRICT_VAR).is_ok_and(|v| v == "1");
    let mut report = check_docs(&read_docs(), &entries, strict);
    report.failures.splice(0..0, record_problems);

    let mut summary = format!("{} records in {RECORDS_DIR}\n", entries.len());
    for (doc, [checked, owed, not_measured, figures]) in &report.counts {
        writeln!(
            summary,
            "{doc}: {checked} tables checked ({figures} figures), {owed} owed, {not_measured} not measured"
        )
        .expect("a string");
    }
    writeln!(summary, "Each checked table against the records its `Record:` line names:").expect("a string");
    for (doc, line, names, binding) in &report.sources {
        writeln!(summary, "  {doc}:{line} ({binding:?}): {}", names.join(", ")).expect("a string");
    }
    if !report.owed.is_empty() {
        writeln!(summary, "Tables whose figures no record backs yet (owed):").expect("a string");
        for (doc, line, header, reason, all_backed) in &report.owed {
            writeln!(summary, "  {doc}:{line}: {header}\n      owed: {reason}").expect("a string");
            if *all_backed {
                writeln!(summary, "      (every figure is now in a record: remove the marker)").expect("a string");
            }
        }
    }
    println!("{summary}");
    assert!(
        report.failures.is_empty(),
        "{} problems:\n{}\n(tables without a figures marker must have every figure in a record; see docs/records/README.md)",
        report.failures.len(),
        report.failures.join("\n")
    );
}

// ---------------------------------------------------------------------------
// The parser's own tests.
// ---------------------------------------------------------------------------

fn numbers(text: &str) -> Vec<f64> {
    figures(&clean(text), true).iter().filter_map(Figure::value).collect()
}

fn records_of(numbers: &[f64]) -> Records {
    let mut records = Records { count: 1, ..Records::default() };
    numbers.iter().for_each(|&v| records.push(v, "values", (0, 0)));
    records.finish();
    records
}

fn backed(cell: &str, numbers: &[f64]) -> bool {
    let records = records_of(numbers);
    let found = figures(&clean(cell), true);
    assert!(!found.is_empty(), "no figure in {cell:?}");
    found.iter().all(|f| records.backs(f))
}

#[test]
fn thousands_separators_ranges_and_products_are_read_as_the_docs_write_them() {
    assert_eq!(numbers("1 209"), [1209.0]);
    assert_eq!(numbers("10 000 boxes"), [10000.0]);
    assert_eq!(numbers("1 000 000"), [1e6]);
    assert_eq!(numbers("10\u{2009}000 and 2\u{202F}500"), [10000.0, 2500.0]);
    assert_eq!(numbers("1 903 k"), [1903.0]);
    assert_eq!(numbers("640 × 360"), [640.0, 360.0]);
    assert_eq!(numbers("0.3–0.5"), [0.3, 0.5]);
    assert_eq!(numbers("1.38–1.50 frame"), [1.38, 1.5]);
    assert_eq!(numbers("2.6×"), [2.6]);
    assert_eq!(numbers("1.1 3.7 7.2 11.2 20.4 %"), [1.1, 3.7, 7.2, 11.2, 20.4]);
    assert_eq!(numbers("0.5 / 1"), [0.5, 1.0]);
    assert_eq!(numbers("12 34"), [12.0, 34.0], "a group needs three digits");
    assert_eq!(numbers("2946 / 2729"), [2946.0, 2729.0]);
    assert_eq!(numbers("1e6, 1e-4 and 3e7"), [1e6, 1e-4, 3e7]);
    assert_eq!(numbers("64² × 16"), [4096.0, 16.0]);
    assert_eq!(numbers("within 2⁻⁵"), [2f64.powi(-5)]);
    assert_eq!(numbers("threads: −3, x = -0.5"), [-3.0, -0.5]);
    assert_eq!(numbers("V−1"), [1.0]);
    // Names hold no figures.
    assert_eq!(numbers("H100, f32, Rg11b10Ufloat, a27cb61, 6f40d08, 0x1F"), Vec::<f64>::new());
    assert_eq!(numbers("Bevy 0.19.1, driver 580.159.04"), Vec::<f64>::new());
    assert_eq!(numbers("view targets (4K)"), Vec::<f64>::new());
    assert_eq!(numbers("2-core CPU, every 8th frame, 10k boxes"), [2.0, 8.0, 10.0]);
    // Without grouping (a command's arguments) every group is its own number.
    let plain: Vec<f64> =
        figures("bench 1920 2500 40 10000,100000 1 000", false).iter().filter_map(Figure::value).collect();
    assert_eq!(plain, [1920.0, 2500.0, 40.0, 10000.0, 100000.0, 1.0, 0.0]);
}

#[test]
fn units_percentages_and_dates() {
    let fs = figures("95.7 %, 0.47 ms, 5.7 MB, 14.1 MiB, 143 k, 0.4–2 s, 10–12 %", true);
    let units: Vec<Option<Unit>> = fs.iter().map(|f| f.unit).collect();
    assert_eq!(
        units,
        [
            Some(Unit::Percent),
            Some(Unit::Time(1e-3)),
            Some(Unit::Scale(MB)),
            Some(Unit::Scale(MEBI)),
            Some(Unit::Scale(KILO)),
            Some(Unit::Time(1.0)),
            Some(Unit::Time(1.0)),
            Some(Unit::Percent),
            Some(Unit::Percent),
        ]
    );
    // A percentage by the figure or by its fraction.
    assert!(backed("95.7 %", &[0.957]));
    assert!(backed("95.7 %", &[95.7]));
    assert!(backed("96.0 %", &[0.95961]));
    assert!(!backed("95.7 %", &[0.95]));
    assert!(backed("1.1 3.7 %", &[0.011, 0.037]));
    assert!(!backed("95.7", &[0.957]), "no % sign: no fraction");
    // Times in any unit, counts and bytes scaled.
    assert!(backed("0.47 ms", &[0.000_47]));
    assert!(backed("0.47 ms", &[470.0]));
    assert!(backed("143 k", &[143_210.0]));
    assert!(!backed("143 k", &[143_600.0]));
    assert!(backed("5.7 MB", &[5_700_000.0]));
    assert!(backed("14.1 MiB", &[14.1 * 1_048_576.0]));
    // Squares by their side or their area; other powers by their value.
    assert!(backed("64²", &[64.0]) && backed("64²", &[4096.0]));
    assert!(backed("2⁻⁵", &[0.03125]) && !backed("2⁻⁵", &[2.0]));
    assert!(backed("1e-4", &[0.000_12]) && !backed("1e-4", &[0.000_16]));
    // A date by a record of that day.
    let mut records = records_of(&[]);
    records.dates.push("2026-11-23T10:12:00Z".to_owned());
    let date = figures("measured 2026-11-23", true);
    assert!(matches!(date[..], [Figure { kind: Kind::Date(_), .. }]));
    assert!(records.backs(&date[0]));
    assert!(!records.backs(&figures("2026-11-24", true)[0]));
}

#[test]
fn code_spans_link_targets_and_html_hold_no_figures() {
    assert_eq!(numbers("`Msaa::X4` at 3.2 ms, `--shard 0/6`"), [3.2]);
    assert_eq!(numbers("``a ` 5`` and 7"), [7.0]);
    assert_eq!(numbers("[the 2 runs](docs/x2.md#run-3) and [ref 4][note5]"), [2.0, 4.0]);
    assert_eq!(numbers("<https://example.com/9> <br/> <!-- 12 --> 1 < 2"), [1.0, 2.0]);
    assert_eq!(split_row("| a \\| b | `c` | 3 |"), ["a \\| b", "`c`", "3"]);
}

#[test]
fn a_figure_is_backed_when_a_record_number_rounds_to_it() {
    assert!(backed("0.47", &[0.4749]) && backed("0.47", &[0.465]) && !backed("0.47", &[0.4751]));
    assert!(backed("6195", &[6195.0]) && backed("6195", &[6195.4]) && !backed("6195", &[6196.0]));
    assert!(backed("1.00", &[0.996]) && !backed("1.00", &[0.994]));
    assert!(backed("0.32", &[0.325]), "a tie rounds either way");
    assert!(backed("10 000", &[10_000.0]) && !backed("10 000", &[10.0]));
    assert!(backed("1.7×", &[1.68]));
    assert!(backed("−0.3", &[0.3]) && backed("0.3", &[-0.3]), "signs are text");
}

const SAMPLE: &str = "# Sample

```text
| 9 | not a table: inside a fence |
```

<!-- figures: not measured — the configured limits, restated from ImportLimits -->
| limit | default |
|---|---:|
| nodes | 200 000 |

<!-- figures: owed — H100 run of sample_bench; no record was kept -->
| N | ms |
|---:|---:|
| 10 | 1.5 |

| N | GPU ms | share |
|---:|---:|---:|
| 10 000 | 0.47 | 95.7 % |
| 100 000 | 4.12 | 99.0 % |

Record: docs/records/sample_bench.jsonl, `sample_bench 10`, abc1234, lavapipe (llvmpipe, Vulkan).
";

/// A well-formed record of `bench` at `commit` on `adapter` (`None`: the
/// CPU), run as `argv` with `env`, whose `values` hold `numbers`.
fn entry(bench: &str, commit: &str, adapter: Option<&str>, command: (&str, &[(&str, &str)]), numbers: &[f64]) -> Entry {
    let adapter = adapter.map_or(Value::Null, |name| {
        serde_json::json!({"name": name, "backend": "Vulkan", "device_type": "Cpu", "driver": "x", "driver_info": "y"})
    });
    let env: serde_json::Map<String, Value> =
        command.1.iter().map(|(k, v)| ((*k).to_owned(), Value::String((*v).to_owned()))).collect();
    let line = serde_json::json!({
        "bench": bench, "commit": commit, "dirty": false, "date": "2026-11-25T10:00:00Z", "adapter": adapter,
        "host": {"available_parallelism": 16}, "command": {"argv": command.0, "env": env},
        "values": {"numbers": numbers},
    });
    let fields = check_record(&line.to_string(), bench).expect("a well-formed record");
    Entry::new(format!("{RECORDS_DIR}/{bench}.jsonl"), 1, fields)
}

const LAVAPIPE: Option<&str> = Some("llvmpipe (LLVM 15.0.6, 256 bits)");
const H100: Option<&str> = Some("NVIDIA H100 80GB HBM3");

/// The figures of SAMPLE's checked table.
const SAMPLE_FIGURES: [f64; 6] = [10_000.0, 0.000_47, 0.957, 100_000.0, 4.12, 0.99];

fn sample_check(entries: &[Entry], strict: bool) -> Report {
    check_docs(&[("sample.md".to_owned(), SAMPLE.to_owned())], entries, strict)
}

fn sample_entry(numbers: &[f64]) -> Entry {
    entry("sample_bench", "abc1234def", LAVAPIPE, ("sample_bench 10", &[]), numbers)
}

#[test]
fn an_unbacked_figure_fails_with_its_doc_line_and_cell() {
    let report = sample_check(&[sample_entry(&SAMPLE_FIGURES)], false);
    assert_eq!(report.failures, Vec::<String>::new());
    assert_eq!(report.counts, [("sample.md".to_owned(), [1, 1, 1, 6])]);
    assert_eq!(report.owed.len(), 1);
    assert_eq!(report.owed[0].1, 13);
    assert_eq!(report.owed[0].2, "| N | ms |");
    assert_eq!(report.owed[0].3, "H100 run of sample_bench; no record was kept");

    // 4.12 made up: the one failure names it.
    let report = sample_check(&[sample_entry(&[10_000.0, 0.000_47, 0.957, 100_000.0, 4.13, 0.99])], false);
    assert_eq!(
        report.failures,
        [
            "sample.md:20: figure `4.12` in cell `4.12` is in none of the table's records (docs/records/sample_bench.jsonl:1)"
        ]
    );

    // Strict: the owed table fails too.
    let report = sample_check(&[sample_entry(&SAMPLE_FIGURES)], true);
    assert_eq!(report.failures.len(), 1, "{:?}", report.failures);
    assert!(report.failures[0].starts_with("sample.md:13: table still owed"), "{:?}", report.failures);

    // Without its marker the owed table is checked, and fails (no
    // `Record:` line).
    let unmarked = SAMPLE.replace("<!-- figures: owed — H100 run of sample_bench; no record was kept -->\n", "");
    let report = check_docs(&[("sample.md".to_owned(), unmarked)], &[sample_entry(&SAMPLE_FIGURES)], false);
    assert_eq!(report.failures.len(), 1, "{:?}", report.failures);
    assert!(report.failures[0].starts_with("sample.md:12: table `| N | ms |` has no `Record:` line"));
}

#[test]
fn a_table_is_checked_against_the_records_its_record_line_names_and_no_others() {
    let without = [10_000.0, 0.000_47, 0.957, 100_000.0, 0.99];
    let failing = ["sample.md:20: figure `4.12` in cell `4.12` is in none of the table's records"];
    let fails_on_4_12 = |entries: &[Entry], text: &str| {
        let report = check_docs(&[("sample.md".to_owned(), text.to_owned())], entries, false);
        match &report.failures[..] {
            [] => false,
            [one] if one.starts_with(failing[0]) => true,
            other => panic!("{other:?}"),
        }
    };
    // 4.12 only in another file, at another commit, on another adapter or
    // from another command: not this table's.
    for other in [
        entry("other_bench", "abc1234def", LAVAPIPE, ("other_bench", &[]), &[4.12]),
        entry("sample_bench", "fed9876abc", LAVAPIPE, ("sample_bench 10", &[]), &[4.12]),
        entry("sample_bench", "abc1234def", H100, ("sample_bench 10", &[]), &[4.12]),
        entry("sample_bench", "abc1234def", LAVAPIPE, ("sample_bench 20", &[]), &[4.12]),
    ] {
        let entries = [sample_entry(&without), other];
        assert!(fails_on_4_12(&entries, SAMPLE), "{:?}", entries[1]);
    }
    // Named, they back it.
    let both_files = SAMPLE.replace("sample_bench.jsonl,", "sample_bench.jsonl and docs/records/other_bench.jsonl,");
    let entries = [sample_entry(&without), entry("other_bench", "abc1234def", LAVAPIPE, ("other_bench", &[]), &[4.12])];
    assert!(!fails_on_4_12(&entries, &both_files));
    let entries =
        [sample_entry(&without), entry("sample_bench", "abc1234def", LAVAPIPE, ("sample_bench 20", &[]), &[4.12])];
    assert!(!fails_on_4_12(
        &entries,
        &SAMPLE.replace("`sample_bench 10`,", "`sample_bench 10` and `sample_bench 20`,")
    ));
    assert!(!fails_on_4_12(&entries, &SAMPLE.replace("`sample_bench 10`,", "`sample_bench N`,")));
    assert!(!fails_on_4_12(&entries, &SAMPLE.replace("`sample_bench 10`,", "`sample_bench 10|20`,")));
    assert!(!fails_on_4_12(&entries, &SAMPLE.replace("`sample_bench 10`,", "`cargo run --example sample_bench`,")));
    let entries =
        [sample_entry(&without), entry("sample_bench", "abc1234def", H100, ("sample_bench 10", &[]), &[4.12])];
    assert!(!fails_on_4_12(&entries, &SAMPLE.replace("lavapipe (llvmpipe, Vulkan)", "lavapipe and the NVIDIA H100")));
    assert!(!fails_on_4_12(&entries, &SAMPLE.replace("lavapipe (llvmpipe, Vulkan)", "both adapters")));
}

#[test]
fn a_checked_table_without_a_parseable_record_line_fails_naming_it() {
    let entries = [sample_entry(&SAMPLE_FIGURES)];
    let fails_with = |text: String, start: &str, has: &str| {
        let report = check_docs(&[("sample.md".to_owned(), text)], &entries, false);
        assert_eq!(report.failures.len(), 1, "{:?}", report.failures);
        let failure = &report.failures[0];
        assert!(failure.starts_with(start) && failure.contains(has), "{failure}");
    };
    let record_line =
        "Record: docs/records/sample_bench.jsonl, `sample_bench 10`, abc1234, lavapipe (llvmpipe, Vulkan).";
    let no_line = "sample.md:17: table `| N | GPU ms | share |` has no `Record:` line";
    fails_with(SAMPLE.replace(record_line, ""), no_line, "");
    fails_with(SAMPLE.replace(record_line, &format!("The same run.\n\n{record_line}")), no_line, "");
    fails_with(SAMPLE.replace(record_line, &format!("\n{record_line}")), no_line, "");
    let bad = "sample.md:22: the `Record:` line of table `| N | GPU ms | share |` (line 17): ";
    fails_with(
        SAMPLE.replace("docs/records/sample_bench.jsonl", "the sample bench's record"),
        bad,
        "names no record file",
    );
    fails_with(
        SAMPLE.replace("sample_bench.jsonl", "sampel_bench.jsonl"),
        bad,
        "sampel_bench.jsonl, which holds no record",
    );
    fails_with(SAMPLE.replace("abc1234", "abc1235"), bad, "names commit abc1235");
    fails_with(SAMPLE.replace("`sample_bench 10`", "`sample_bench 30`"), bad, "ran `sample_bench 30`");
    // Right under the table, or after one blank line; a paragraph may run
    // on over several lines.
    let report = check_docs(
        &[("sample.md".to_owned(), SAMPLE.replace("\n\nRecord:", "\nRecord:").replace(", abc1234,", ",\nabc1234,"))],
        &entries,
        false,
    );
    assert_eq!(report.failures, Vec::<String>::new());
}

#[test]
fn record_lines_name_files_commits_adapters_and_commands() {
    let text = "Record: docs/records/msaa_bench.jsonl, `msaa_bench 1920 2500 40` and `MSAA_BENCH_GRAPH=unlit \
                msaa_bench 3840 0 40` (2b48b71, NVIDIA H100, Vulkan); `msaa_bench 640 0 20` (f78d6bb, lavapipe), \
                also docs/records/raster_floor.jsonl; `gpu_ms_median` of 40 frames, deadbeef and 1000000 no commits.";
    let source = parse_source(text).expect("a source");
    assert_eq!(source.files, ["docs/records/msaa_bench.jsonl", "docs/records/raster_floor.jsonl"]);
    assert_eq!(source.commits, ["2b48b71", "f78d6bb"]);
    assert!(source.words.iter().any(|w| w == "nvidia") && source.words.iter().any(|w| w == "lavapipe"));
    assert!(!source.words.iter().any(|w| w == "msaa_bench" || w == "3840"), "spans are not words");
    assert_eq!(
        source.spans,
        [
            "msaa_bench 1920 2500 40",
            "MSAA_BENCH_GRAPH=unlit msaa_bench 3840 0 40",
            "msaa_bench 640 0 20",
            "gpu_ms_median"
        ]
    );
    assert!(parse_source("Record: the same (`cull_rows`).").is_err());

    let peer = "OXYGEN_CPU_PATH=1 CONFIGS=\"10000x1 10000x6\" ROUNDS=3 scripts/peer-bench.sh";
    let command = parse_command(peer).expect("a command");
    assert_eq!(command.program, "peer-bench.sh");
    assert_eq!(command.env[1], ("CONFIGS".to_owned(), "10000x1 10000x6".to_owned()));
    assert!(command.args.is_empty());
    let ran = |argv: &str, env: &[(&str, &str)]| entry("peer_bench", "cf4c5cb", H100, (argv, env), &[1.0]);
    let matches = |doc: &str, entry: &Entry| command_matches(&parse_command(doc).expect("a command"), entry);
    let record = ran("peer-bench.sh CONFIGS=10000x1 10000x6 ROUNDS=3", &[("OXYGEN_CPU_PATH", "1")]);
    assert!(matches(peer, &record));
    assert!(!matches(&peer.replace("ROUNDS=3", "ROUNDS=2"), &record));
    assert!(!matches(&peer.replace("OXYGEN_CPU_PATH=1", "OXYGEN_CPU_PATH=0"), &record));
    let cubes = ran("cubes_bench 10000 1 20", &[("OXYGEN_PREPASS", "on")]);
    assert!(matches("OXYGEN_PREPASS=auto|on|off cubes_bench N 1 20", &cubes));
    assert!(matches("cubes_bench 10000 1 20", &cubes), "a variable not named is not constrained");
    assert!(!matches("OXYGEN_PREPASS=auto|off cubes_bench N 1 20", &cubes));
    assert!(!matches("cubes_bench 10000 1", &cubes) && !matches("cubes_bench 10000 1 20 8", &cubes));
    assert!(!matches("OXYGEN_VIEWPORT=640x360 cubes_bench 10000 1 20", &cubes));
    assert_eq!(parse_command("OXYGEN_X=1"), None);
}

#[test]
fn frame_samples_and_the_host_back_no_figure() {
    let mut record = sample_entry(&[2.5]);
    let values = record.fields["values"].as_object_mut().expect("values");
    values.insert("frame_ms_samples".to_owned(), serde_json::json!([1.23, 4.56]));
    values.insert("rows".to_owned(), serde_json::json!([{"gpu_ms_samples": [7.89], "gpu_ms_median": 3.25}]));
    values.insert("reference_samples".to_owned(), serde_json::json!(1024));
    let records = Records::of([&record], Pool::Figures);
    let backs = |text: &str| records.backs(&figures(text, true)[0]);
    assert!(backs("2.5") && backs("3.25") && backs("2026-11-25"));
    assert!(backs("1024"), "a count named `_samples` is no sample array");
    assert!(!backs("1.23") && !backs("4.56") && !backs("7.89"), "samples");
    assert!(!backs("16"), "the host's available_parallelism");
    let everything = Records::of([&record], Pool::Everything);
    assert!(everything.backs(&figures("7.89", true)[0]) && everything.backs(&figures("16", true)[0]));
}

/// The failures of `table` (rows of a Markdown table) against records of
/// `values` (`bench_tests` records when they name a test).
fn bound_failures(table: &str, values: &[Value]) -> Vec<String> {
    let entries: Vec<Entry> = values
        .iter()
        .map(|v| {
            let mut e = entry("b", "abc1234def", LAVAPIPE, ("b", &[]), &[]);
            e.fields.insert("values".to_owned(), v.clone());
            e
        })
        .collect();
    let text = format!("{table}\nRecord: docs/records/b.jsonl, abc1234, lavapipe.\n");
    check_docs(&[("t.md".to_owned(), text)], &entries, false).failures
}

#[test]
fn figures_stand_where_their_table_puts_them() {
    let bench = serde_json::json!({"rows": [
        {"n": 10, "ms": 1.5, "p90_ms": 1.9, "levels": [0.011, 0.037]},
        {"n": 20, "ms": 1.8, "p90_ms": 2.1, "levels": [0.014, 0.039]},
    ]});
    let table = |first: &str, second: &str| {
        format!("| N | ms | p90 ms | levels |\n|---|---|---|---|\n| 10 | {first} |\n| 20 | {second} |\n")
    };
    let fine = bound_failures(&table("1.5 | 1.9 | 1.1 3.7 %", "1.8 | 2.1 | 1.4 3.9 %"), std::slice::from_ref(&bench));
    assert_eq!(fine, Vec::<String>::new());
    // A column is one quantity: 2.1 is the second row's p90, not its ms.
    let failures =
        bound_failures(&table("1.5 | 1.9 | 1.1 3.7 %", "2.1 | 2.1 | 1.4 3.9 %"), std::slice::from_ref(&bench));
    assert!(failures.iter().any(|f| f.contains("the key of 1 of the 2 in its column")), "{failures:?}");
    // A cell's list is one list: 3.9 % is the second row's.
    let failures =
        bound_failures(&table("1.5 | 1.9 | 1.1 3.9 %", "1.8 | 2.1 | 1.4 3.9 %"), std::slice::from_ref(&bench));
    assert!(failures.iter().all(|f| f.contains("figure `3.9 %`")), "{failures:?}");
    assert!(failures.iter().any(|f| f.contains("not in the list")), "{failures:?}");
    // A row is one line of the record: 1.8 ms is the second row's.
    let failures = bound_failures(&table("1.8 | 1.9 | 1.1 3.7 %", "1.8 | 2.1 | 1.4 3.9 %"), &[bench]);
    assert_eq!(failures.len(), 1, "{failures:?}");
    assert!(failures[0].starts_with("t.md:3: figure `1.8` in cell `1.8` is only in rows"), "{failures:?}");

    // Tests' records: a row is one test's.
    let tests = [
        serde_json::json!({"test": "a", "traced": 0.981, "albedo": 0.972}),
        serde_json::json!({"test": "b", "rmse": 0.0395}),
    ];
    let table = |cells: &str| format!("| test | measured |\n|---|---|\n| a | {cells} |\n");
    assert_eq!(bound_failures(&table("0.981 against 0.972"), &tests), Vec::<String>::new());
    let failures = bound_failures(&table("0.981 against 0.0395"), &tests);
    assert_eq!(failures.len(), 1, "{failures:?}");
    assert!(failures[0].contains("`0.0395`") && failures[0].contains("the record of 1 of the 2 in its row"));
}

/// `figure` with the last digit of its decimal raised by 3 (`0.47` →
/// `0.50`); `None` for a figure printed without decimals.
fn raised_by_three(figure: &Figure) -> Option<Figure> {
    let Kind::Number { value, exponent } = figure.kind else { return None };
    if exponent >= 0 || !figure.text.contains('.') {
        return None;
    }
    let raised = value.abs() + 3.0 * 10f64.powi(exponent);
    Some(Figure { kind: Kind::Number { value: raised.copysign(value), exponent }, ..figure.clone() })
}

/// What [`raised_decimals`] found.
#[derive(Debug, Default)]
struct Raised {
    /// Decimal figures raised.
    decimals: usize,
    /// Still backed by every record pooled with their samples and hosts (the
    /// check before issue 27's review).
    pooled: usize,
    /// Still passing the check of their tables: (doc, line, figure).
    named: Vec<(String, usize, String)>,
}

/// The review of issue 27, as a test: every decimal figure of every checked
/// table raised by 3 in its last digit (as if a copy of the docs had been
/// edited so), and checked again.
fn raised_decimals(docs: &[(String, String)], entries: &[Entry]) -> Raised {
    let everything = Records::of(entries, Pool::Everything);
    let mut raised = Raised::default();
    for (doc, text) in docs {
        let (tables, _) = parse_tables(doc, text);
        for table in tables.iter().filter(|t| t.marker.is_none()) {
            let Ok(chosen) = table_records(table, entries) else { continue };
            let names: Vec<String> = chosen.iter().map(|e| e.place()).collect();
            let binding = Binding::of(&chosen);
            let records = Records::of(chosen, Pool::Figures);
            let figures = table_figures(table);
            if !check_figures(doc, &figures, &records, &names, binding).is_empty() {
                continue; // failing as it stands: the main test says why
            }
            for (i, placed) in figures.iter().enumerate() {
                let Some(up) = raised_by_three(&placed.figure) else { continue };
                raised.decimals += 1;
                raised.pooled += usize::from(everything.backs(&up));
                let mut edited = figures.clone();
                edited[i].figure = up;
                if check_figures(doc, &edited, &records, &names, binding).is_empty() {
                    raised.named.push((doc.clone(), placed.line, placed.figure.text.clone()));
                }
            }
        }
    }
    raised
}

/// At most this share of the raised decimals may still pass (32 of 658
/// when written, against 512 by the check before the review): a raised
/// figure that lands on a value of its own record row still does (a
/// median raised to the slowest of its rounds, `0.86 (0.80–0.89)`), as
/// does one that lands on the same quantity of another row where each
/// figure of a row comes from a record row of its own (the MSAA breakdown,
/// the atlas), or on another figure of the same test's record.
const RAISED_MAY_PASS: f64 = 0.06;

#[test]
fn decimals_raised_by_three_in_their_last_digit_are_refused() {
    let (entries, _) = read_records(&root().join(RECORDS_DIR));
    let raised = raised_decimals(&read_docs(), &entries);
    let (decimals, named) = (raised.decimals, raised.named.len());
    println!(
        "{decimals} decimal figures raised by 3 in their last digit: {} still backed by all records pooled \
         (samples and hosts included), {named} by the records their tables name",
        raised.pooled
    );
    for (doc, line, figure) in &raised.named {
        println!("  {doc}:{line}: `{figure}` raised by 3 still passes");
    }
    assert!(decimals > 0, "the docs' tables hold no decimal figure");
    assert!(
        named as f64 <= RAISED_MAY_PASS * decimals as f64,
        "{named} of {decimals} raised decimals still pass: the check cannot tell a figure from its neighbours"
    );
    assert_eq!(raised_by_three(&figures("0.47", true)[0]).map(|f| f.value()), Some(Some(0.5)));
    let down = raised_by_three(&figures("−9.98", true)[0]).and_then(|f| f.value());
    assert_eq!(down.map(|v| (v * 100.0).round()), Some(-1001.0), "magnitudes are raised");
    assert_eq!(raised_by_three(&figures("470", true)[0]), None);
}

#[test]
fn markers_must_be_well_formed_and_right_before_a_table() {
    assert_eq!(
        parse_marker("<!-- figures: owed — H100 run of x; no record -->"),
        Some(Ok(Marker::Owed("H100 run of x; no record".to_owned())))
    );
    assert_eq!(
        parse_marker("<!-- figures: not measured – names of the knobs -->"),
        Some(Ok(Marker::NotMeasured("names of the knobs".to_owned())))
    );
    assert_eq!(parse_marker("<!-- other comment -->"), None);
    assert!(matches!(parse_marker("<!-- figures: owed -->"), Some(Err(_))));
    assert!(matches!(parse_marker("<!-- figures: owed — TODO -->"), Some(Err(_))));
    assert!(matches!(parse_marker("<!-- figures: guessed — a b c -->"), Some(Err(_))));
    assert!(matches!(parse_marker("<!-- figures: owed — a b c"), Some(Err(_))));
    let text = "<!-- figures: owed — H100 run; no record kept -->\n\n| a |\n|---|\n| 1 |\n";
    let (tables, problems) = parse_tables("d.md", text);
    assert_eq!(problems, ["d.md:1: a figures marker must be on the line right before a table"]);
    assert_eq!(tables.len(), 1);
    assert_eq!(tables[0].marker, None);
}

#[test]
fn malformed_records_are_refused() {
    let good = r#"{"bench":"b","commit":"abc","dirty":false,"date":"2026-11-23T00:00:00Z","adapter":null,"host":{"available_parallelism":2},"command":{"argv":"b 10000","env":{"OXYGEN_X":"1"}},"values":{"rows":[{"ms":0.5,"ms_samples":[0.25]}]}}"#;
    let record = check_record(good, "b").expect("a record");
    let entry = Entry::new("docs/records/b.jsonl".to_owned(), 1, record);
    assert_eq!((entry.argv.as_str(), entry.env.get("OXYGEN_X").map(String::as_str)), ("b 10000", Some("1")));
    let records = Records::of([&entry], Pool::Figures);
    let numbers: Vec<(f64, &str)> = records.numbers.iter().map(|n| (n.value, records.keys[n.key].as_str())).collect();
    assert_eq!(
        numbers,
        [(0.5, "values.rows[].ms"), (1.0, "command.env.OXYGEN_X"), (10000.0, "command.argv")],
        "no samples, no host"
    );
    assert!(check_record(good, "other").is_err(), "bench must name its file");
    assert!(check_record(&good.replace(r#""dirty":false"#, r#""dirty":"no""#), "b").is_err());
    assert!(check_record(&good.replace(r#""adapter":null"#, r#""adapter":{"name":"x"}"#), "b").is_err());
    assert!(check_record(&good.replace(r#","values":{"rows":[{"ms":0.5,"ms_samples":[0.25]}]}"#, ""), "b").is_err());
    assert!(check_record(&good.replace(r#""host""#, r#""hots""#), "b").is_err());
    assert!(check_record(&good.replace("2026-11-23T", "yesterday "), "b").is_err());
    assert!(check_record("[1, 2]", "b").is_err());
    assert!(check_record("", "b").is_err());
    let command_string = good.replace(r#"{"argv":"b 10000","env":{"OXYGEN_X":"1"}}"#, r#""b 10000""#);
    let record = check_record(&command_string, "b").expect("a record");
    assert_eq!(Entry::new(String::new(), 1, record).argv, "b 10000");

    let dir = std::env::temp_dir().join(format!("oxygen-doc-records-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary directory");
    std::fs::write(dir.join("b.jsonl"), format!("{good}\n{{\"bench\": 1}}\n")).expect("written");
    std::fs::write(dir.join("notes.md"), "not a record").expect("written");
    let (records, problems) = read_records(&dir);
    std::fs::remove_dir_all(&dir).expect("removed");
    assert_eq!(records.len(), 1);
    assert_eq!((records[0].file.as_str(), records[0].line), ("docs/records/b.jsonl", 1));
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(problems[0].contains("b.jsonl:2: malformed record"), "{problems:?}");
}

#[test]
fn the_real_docs_fail_without_a_marker_their_records_do_not_cover() {
    // With no records at all, an owed table whose marker is removed fails.
    let docs = read_docs();
    let before = check_docs(&docs, &[], false);
    let mut marked = None;
    'docs: for (d, (doc, text)) in docs.iter().enumerate() {
        let (tables, _) = parse_tables(doc, text);
        for table in tables {
            if table.marker.is_some() && !table_figures(&table).is_empty() {
                marked = Some((d, table.line));
                break 'docs;
            }
        }
    }
    let Some((d, line)) = marked else {
        return; // every table is checked: nothing to remove
    };
    let mut docs = docs;
    let mut lines: Vec<&str> = docs[d].1.lines().collect();
    lines.remove(line - 2);
    docs[d].1 = lines.join("\n");
    let after = check_docs(&docs, &[], false);
    assert!(after.failures.len() > before.failures.len(), "{:?}", after.failures);
    let doc = &docs[d].0;
    assert!(after.failures.iter().any(|f| f.starts_with(&format!("{doc}:"))), "{:?}", after.failures);
}
