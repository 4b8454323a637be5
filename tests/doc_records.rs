//! Every figure in the tables of docs/performance.md, docs/accuracy.md and
//! docs/security.md comes from a record in `docs/records/*.jsonl` (issue 27).
//!
//! CPU only: reads the records and the Markdown, nothing else.
//!
//! * Every line of every `docs/records/*.jsonl` must be a record (an object
//!   with `bench`, `commit`, `dirty`, `date`, `adapter`, `host`, `command`
//!   and `values`, of the types the record writer gives them); a malformed
//!   line fails the test, naming file and line. A record's numbers are every
//!   JSON number in `values`, `host` and `adapter`, and every figure in their
//!   strings and in the command line (bench arguments are figures too).
//! * Every table row of the three docs (rows starting with `|`, outside code
//!   fences; the separator row skipped) is read cell by cell, header
//!   included; code spans, link targets, HTML and identifiers (`H100`,
//!   `f32`, `a27cb61`, versions such as `0.19.1`) hold no figures.
//! * A table preceded by `<!-- figures: not measured — REASON -->` holds no
//!   measurements (limits restating code, names); one preceded by
//!   `<!-- figures: owed — REASON -->` holds measurements no record backs
//!   yet: it is listed, and with `OXYGEN_RECORDS_STRICT=1` it fails the
//!   test. Every other table is checked: each figure must be backed by a
//!   record number (see [`Figure::intervals`] for what "backed" means).
//!
//! docs/records/README.md ("Figures in the docs") says the same for authors.

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

/// What the records hold: every number's magnitude (sorted) and every date.
#[derive(Debug, Default)]
struct Records {
    numbers: Vec<f64>,
    dates: Vec<String>,
    count: usize,
}

impl Records {
    /// Whether some number lies in `[centre - tolerance, centre + tolerance]`.
    fn holds(&self, centre: f64, tolerance: f64) -> bool {
        let first = self.numbers.partition_point(|&v| v < centre - tolerance);
        self.numbers.get(first).is_some_and(|&v| v <= centre + tolerance)
    }

    /// Whether `figure` is backed by these records.
    fn backs(&self, figure: &Figure) -> bool {
        match &figure.kind {
            Kind::Date(date) => self.dates.iter().any(|d| d.starts_with(date.as_str())),
            _ => figure.intervals().into_iter().any(|(c, t)| self.holds(c, t)),
        }
    }

    fn add_text(&mut self, text: &str) {
        for group in [true, false] {
            for figure in figures(text, group) {
                if let Some(v) = figure.value() {
                    self.numbers.push(v.abs());
                }
            }
        }
    }

    /// Every number in `value`, and every figure in its strings.
    fn add_json(&mut self, value: &Value) {
        match value {
            Value::Number(n) => {
                if let Some(v) = n.as_f64() {
                    self.numbers.push(v.abs());
                }
            }
            Value::String(s) => self.add_text(s),
            Value::Array(items) => items.iter().for_each(|v| self.add_json(v)),
            Value::Object(map) => map.values().for_each(|v| self.add_json(v)),
            Value::Null | Value::Bool(_) => {}
        }
    }

    /// Adds a checked record.
    fn add(&mut self, record: &serde_json::Map<String, Value>) {
        self.count += 1;
        for field in ["values", "host", "adapter", "command"] {
            self.add_json(&record[field]);
        }
        if let Some(date) = record["date"].as_str() {
            self.dates.push(date.to_owned());
        }
    }

    fn finish(&mut self) {
        self.numbers.sort_by(f64::total_cmp);
        self.numbers.dedup();
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
fn read_records(dir: &Path) -> (Records, Vec<String>) {
    let mut records = Records::default();
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
                Ok(record) => records.add(&record),
                Err(why) => problems.push(format!("{shown}:{}: malformed record: {why}", index + 1)),
            }
        }
    }
    records.finish();
    (records, problems)
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

/// One figure of a table that is not backed.
#[derive(Debug)]
struct Unbacked {
    doc: String,
    line: usize,
    cell: String,
    figure: String,
}

/// Every figure of `table` (with its row's line and cell), header units
/// applied to the body's cells.
fn table_figures(table: &Table) -> Vec<(usize, String, Figure)> {
    let units: Vec<Option<Unit>> =
        table.rows.first().map(|h| h.cells.iter().map(|c| column_unit(c)).collect()).unwrap_or_default();
    let mut out = Vec::new();
    for (r, row) in table.rows.iter().enumerate() {
        for (col, cell) in row.cells.iter().enumerate() {
            for mut figure in figures(&clean(cell), true) {
                if r > 0 && figure.unit.is_none() && !matches!(figure.kind, Kind::Date(_)) {
                    figure.unit = units.get(col).copied().flatten();
                }
                out.push((row.line, cell.clone(), figure));
            }
        }
    }
    out
}

fn unbacked(table: &Table, records: &Records) -> Vec<Unbacked> {
    table_figures(table)
        .into_iter()
        .filter(|(_, _, f)| !records.backs(f))
        .map(|(line, cell, f)| Unbacked { doc: table.doc.clone(), line, cell, figure: f.text })
        .collect()
}

/// What checking the docs found.
#[derive(Debug, Default)]
struct Report {
    /// Per doc: (tables checked, owed, not measured, figures checked).
    counts: Vec<(String, [usize; 4])>,
    /// (doc, line, header, reason, every figure already backed).
    owed: Vec<(String, usize, String, String, bool)>,
    failures: Vec<String>,
}

/// Checks the tables of `docs` (name, text) against `records`.
fn check_docs(docs: &[(String, String)], records: &Records, strict: bool) -> Report {
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
                    let all_backed = !table_figures(table).is_empty() && unbacked(table, records).is_empty();
                    report.owed.push((doc.clone(), table.line, table.header_text.clone(), reason.clone(), all_backed));
                }
                None => {
                    counts[0] += 1;
                    counts[3] += table_figures(table).len();
                    for u in unbacked(table, records) {
                        report.failures.push(format!(
                            "{}:{}: figure `{}` in cell `{}` is in no record",
                            u.doc, u.line, u.figure, u.cell
                        ));
                    }
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
    let (records, record_problems) = read_records(&root().join(RECORDS_DIR));
    let strict = std::env::var(STRICT_VAR).is_ok_and(|v| v == "1");
    let mut report = check_docs(&read_docs(), &records, strict);
    report.failures.splice(0..0, record_problems);

    let mut summary =
        format!("{} records in {RECORDS_DIR} ({} distinct numbers)\n", records.count, records.numbers.len());
    for (doc, [checked, owed, not_measured, figures]) in &report.counts {
        writeln!(
            summary,
            "{doc}: {checked} tables checked ({figures} figures), {owed} owed, {not_measured} not measured"
        )
        .expect("a string");
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
    let mut records = Records { numbers: numbers.iter().map(|v| v.abs()).collect(), ..Records::default() };
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
";

fn sample_check(numbers: &[f64], strict: bool) -> Report {
    check_docs(&[("sample.md".to_owned(), SAMPLE.to_owned())], &records_of(numbers), strict)
}

#[test]
fn an_unbacked_figure_fails_with_its_doc_line_and_cell() {
    let all = [10_000.0, 0.000_47, 0.957, 100_000.0, 4.12, 0.99];
    let report = sample_check(&all, false);
    assert_eq!(report.failures, Vec::<String>::new());
    assert_eq!(report.counts, [("sample.md".to_owned(), [1, 1, 1, 6])]);
    assert_eq!(report.owed.len(), 1);
    assert_eq!(report.owed[0].1, 13);
    assert_eq!(report.owed[0].2, "| N | ms |");
    assert_eq!(report.owed[0].3, "H100 run of sample_bench; no record was kept");

    // 4.12 made up: the one failure names it.
    let report = sample_check(&[10_000.0, 0.000_47, 0.957, 100_000.0, 4.13, 0.99], false);
    assert_eq!(report.failures, ["sample.md:20: figure `4.12` in cell `4.12` is in no record"]);

    // Strict: the owed table fails too.
    let report = sample_check(&all, true);
    assert_eq!(report.failures.len(), 1, "{:?}", report.failures);
    assert!(report.failures[0].starts_with("sample.md:13: table still owed"), "{:?}", report.failures);

    // Without its marker the owed table is checked, and fails.
    let unmarked = SAMPLE.replace("<!-- figures: owed — H100 run of sample_bench; no record was kept -->\n", "");
    let report = check_docs(&[("sample.md".to_owned(), unmarked)], &records_of(&all), false);
    assert_eq!(report.failures.len(), 2, "{:?}", report.failures);
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
    let good = r#"{"bench":"b","commit":"abc","dirty":false,"date":"2026-11-23T00:00:00Z","adapter":null,"host":{"available_parallelism":2},"command":{"argv":"b 10000","env":{"OXYGEN_X":"1"}},"values":{"rows":[{"ms":0.5}]}}"#;
    let record = check_record(good, "b").expect("a record");
    let mut records = Records::default();
    records.add(&record);
    records.finish();
    assert_eq!(records.numbers, [0.5, 1.0, 2.0, 10000.0]);
    assert!(check_record(good, "other").is_err(), "bench must name its file");
    assert!(check_record(&good.replace(r#""dirty":false"#, r#""dirty":"no""#), "b").is_err());
    assert!(check_record(&good.replace(r#""adapter":null"#, r#""adapter":{"name":"x"}"#), "b").is_err());
    assert!(check_record(&good.replace(r#","values":{"rows":[{"ms":0.5}]}"#, ""), "b").is_err());
    assert!(check_record(&good.replace(r#""host""#, r#""hots""#), "b").is_err());
    assert!(check_record(&good.replace("2026-11-23T", "yesterday "), "b").is_err());
    assert!(check_record("[1, 2]", "b").is_err());
    assert!(check_record("", "b").is_err());
    let command_string = good.replace(r#"{"argv":"b 10000","env":{"OXYGEN_X":"1"}}"#, r#""b 10000""#);
    assert!(check_record(&command_string, "b").is_ok());

    let dir = std::env::temp_dir().join(format!("oxygen-doc-records-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary directory");
    std::fs::write(dir.join("b.jsonl"), format!("{good}\n{{\"bench\": 1}}\n")).expect("written");
    std::fs::write(dir.join("notes.md"), "not a record").expect("written");
    let (records, problems) = read_records(&dir);
    std::fs::remove_dir_all(&dir).expect("removed");
    assert_eq!(records.count, 1);
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(problems[0].contains("b.jsonl:2: malformed record"), "{problems:?}");
}

#[test]
fn the_real_docs_fail_without_a_marker_their_records_do_not_cover() {
    // With no records at all, an owed table whose marker is removed fails.
    let docs = read_docs();
    let empty = records_of(&[]);
    let before = check_docs(&docs, &empty, false);
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
    let after = check_docs(&docs, &empty, false);
    assert!(after.failures.len() > before.failures.len(), "{:?}", after.failures);
    let doc = &docs[d].0;
    assert!(after.failures.iter().any(|f| f.starts_with(&format!("{doc}:"))), "{:?}", after.failures);
}
