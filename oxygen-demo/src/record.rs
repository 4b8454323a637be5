//! Records of benchmark runs: every figure the docs quote comes from one.
//!
//! A record is one JSON object on one line, appended to
//! `<dir>/<bench>.jsonl`, where `<dir>` is the environment variable
//! [`RECORD_DIR_VAR`] (`OXYGEN_RECORD_DIR`). When that variable is not set
//! nothing is written, so smoke runs and CI never touch the repository; the
//! committed records live in `docs/records/` (`OXYGEN_RECORD_DIR=docs/records`).
//! A relative directory is taken from the workspace root when the binary
//! still finds the workspace it was built from, else from the working
//! directory. `docs/records/README.md` describes the format.
//!
//! ```no_run
//! use oxygen_demo::record::{Record, Row};
//! # fn run(info: &wgpu::AdapterInfo) -> Result<(), oxygen_demo::record::RecordError> {
//! Record::new("visibility_bench")
//!     .adapter(info)
//!     .value("frames", 10)
//!     .row(Row::new().value("path", "cpu").value("cpu_ms_median", 0.75).value("cpu_ms_samples", vec![0.7, 0.75, 0.8]))
//!     .write()?;
//! # Ok(())
//! # }
//! ```
//!
//! Misuse is refused when the record is written, with an error naming the
//! key: a NaN or infinite number (JSON has none; record a missing figure as
//! `None`, which is `null`), an empty or repeated key, a bench name that is
//! not a plain file name, or a record without values.

use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{SystemTime, UNIX_EPOCH};

use serde_json::{Map, Value};

/// The environment variable naming the directory records are appended to.
pub const RECORD_DIR_VAR: &str = "OXYGEN_RECORD_DIR";

/// The environment variable giving the commit a bench binary was built
/// from, when it runs away from that checkout (a release build carried to a
/// GPU machine, whose copy of the tree may hold another `.git`): when set it
/// wins over `git`, and the record's `dirty` is then unknown.
pub const COMMIT_VAR: &str = "OXYGEN_COMMIT";

/// Environment variables whose names start with one of these change what a
/// bench measures; those set are kept in the record's `command.env`
/// (except [`RECORD_DIR_VAR`] and [`COMMIT_VAR`], which only say where the
/// record goes and what it belongs to). `MESA_` and `__GL_` are the
/// drivers' knobs (their shader caches, for first-frame runs).
pub const RECORDED_ENV_PREFIXES: &[&str] = &[
    "OXYGEN_",
    "WGPU_",
    "MSAA_BENCH_",
    "VISIBILITY_",
    "CUBES_BENCH_",
    "BATCH_BENCH_",
    "GROUP_BENCH_",
    "SCHEDULE_BENCH_",
    "NODE_BENCH_",
    "ATLAS_",
    "MESA_",
    "__GL_",
];

/// Why a record was not written.
#[derive(Debug)]
pub enum RecordError {
    /// The bench name is empty or holds a character other than ASCII
    /// letters, digits, `_` and `-` (it names the file).
    InvalidBench(String),
    /// A value was given an empty key.
    EmptyKey,
    /// Two values were given the same key (the path to it, e.g. `rows[2].gpu_ms`).
    DuplicateKey(String),
    /// A number was NaN or infinite, which JSON cannot hold.
    NotFinite {
        /// The path to the value, e.g. `rows[2].gpu_ms`.
        key: String,
        /// The number.
        value: f64,
    },
    /// The record holds no values.
    NoValues,
    /// The record could not be serialised.
    Json(serde_json::Error),
    /// The record file could not be created or appended to.
    Io {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        source: std::io::Error,
    },
}

impl RecordError {
    /// Rewrites the key path of a key error (the others are returned as
    /// they are).
    fn map_key(self, f: impl FnOnce(String) -> String) -> RecordError {
        match self {
            RecordError::DuplicateKey(key) => RecordError::DuplicateKey(f(key)),
            RecordError::NotFinite { key, value } => RecordError::NotFinite { key: f(key), value },
            other => other,
        }
    }

    /// The same error with `parent` in front of its key path.
    fn under(self, parent: &str) -> RecordError {
        self.map_key(|key| match key.chars().next() {
            None => parent.to_owned(),
            Some('[') => format!("{parent}{key}"),
            Some(_) => format!("{parent}.{key}"),
        })
    }

    /// The same error with `[index]` in front of its key path.
    fn at_index(self, index: usize) -> RecordError {
        self.under(&format!("[{index}]"))
    }
}

impl fmt::Display for RecordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RecordError::InvalidBench(name) => {
                write!(f, "bench name {name:?} is not a plain file name (ASCII letters, digits, _ and -)")
            }
            RecordError::EmptyKey => write!(f, "a record value has an empty key"),
            RecordError::DuplicateKey(key) => write!(f, "record key {key:?} is given twice"),
            RecordError::NotFinite { key, value } => {
                write!(f, "record value {key:?} is {value}, which JSON cannot hold (record a missing figure as None)")
            }
            RecordError::NoValues => write!(f, "the record has no values"),
            RecordError::Json(error) => write!(f, "the record does not serialise: {error}"),
            RecordError::Io { path, source } => write!(f, "cannot append the record to {}: {source}", path.display()),
        }
    }
}

impl std::error::Error for RecordError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            RecordError::Json(error) => Some(error),
            RecordError::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

/// Something a record can hold: numbers (finite), booleans, strings,
/// `None` (`null`), lists of these and [`Row`]s.
pub trait RecordValue {
    /// The value as JSON; an error for a NaN or infinite number (with an
    /// empty key, which the record fills in).
    fn into_json(self) -> Result<Value, RecordError>;
}

fn number(value: f64) -> Result<Value, RecordError> {
    serde_json::Number::from_f64(value).map(Value::Number).ok_or(RecordError::NotFinite { key: String::new(), value })
}

impl RecordValue for f64 {
    fn into_json(self) -> Result<Value, RecordError> {
        number(self)
    }
}

impl RecordValue for f32 {
    fn into_json(self) -> Result<Value, RecordError> {
        number(f64::from(self))
    }
}

macro_rules! plain_values {
    ($($t:ty),*) => {$(
        impl RecordValue for $t {
            fn into_json(self) -> Result<Value, RecordError> {
                Ok(Value::from(self))
            }
        }
    )*};
}
plain_values!(u8, u16, u32, u64, usize, i8, i16, i32, i64, isize, bool, String, &str);

impl RecordValue for &String {
    fn into_json(self) -> Result<Value, RecordError> {
        Ok(Value::from(self.as_str()))
    }
}

impl<T: RecordValue> RecordValue for Option<T> {
    fn into_json(self) -> Result<Value, RecordError> {
        self.map_or(Ok(Value::Null), RecordValue::into_json)
    }
}

impl<T: RecordValue> RecordValue for Vec<T> {
    fn into_json(self) -> Result<Value, RecordError> {
        self.into_iter()
            .enumerate()
            .map(|(i, v)| v.into_json().map_err(|e| e.at_index(i)))
            .collect::<Result<Vec<_>, _>>()
            .map(Value::Array)
    }
}

impl<T: RecordValue + Clone> RecordValue for &[T] {
    fn into_json(self) -> Result<Value, RecordError> {
        self.to_vec().into_json()
    }
}

impl<T: RecordValue + Clone> RecordValue for &Vec<T> {
    fn into_json(self) -> Result<Value, RecordError> {
        self.as_slice().into_json()
    }
}

impl<T: RecordValue, const N: usize> RecordValue for [T; N] {
    fn into_json(self) -> Result<Value, RecordError> {
        Vec::from(self).into_json()
    }
}

/// Named values, in a record or in one of its rows; keeps the first error.
#[derive(Debug, Default)]
struct Values {
    map: Map<String, Value>,
    problem: Option<RecordError>,
}

impl Values {
    fn insert(&mut self, key: &str, value: impl RecordValue) {
        if self.problem.is_some() {
            return;
        }
        let result = if key.is_empty() {
            Err(RecordError::EmptyKey)
        } else if self.map.contains_key(key) {
            Err(RecordError::DuplicateKey(key.to_owned()))
        } else {
            value.into_json().map_err(|e| e.under(key))
        };
        match result {
            Ok(value) => {
                self.map.insert(key.to_owned(), value);
            }
            Err(error) => self.problem = Some(error),
        }
    }

    /// Appends `row` to the list under `key`.
    fn push(&mut self, key: &str, row: Row) {
        if self.problem.is_some() {
            return;
        }
        let index = self.map.get(key).and_then(Value::as_array).map_or(0, Vec::len);
        match row.into_json() {
            Ok(row) => match self.map.entry(key).or_insert_with(|| Value::Array(Vec::new())) {
                Value::Array(rows) => rows.push(row),
                _ => self.problem = Some(RecordError::DuplicateKey(key.to_owned())),
            },
            Err(error) => self.problem = Some(error.at_index(index).under(key)),
        }
    }
}

/// One row of a bench's table: a configuration's parameters and what was
/// measured for it. Rows go into the record's `values.rows` list
/// ([`Record::row`]).
#[derive(Debug, Default)]
pub struct Row {
    values: Values,
}

impl Row {
    /// An empty row.
    pub fn new() -> Row {
        Row::default()
    }

    /// Adds a value under `key`; put the unit in the key (`frame_ms_median`).
    pub fn value(mut self, key: &str, value: impl RecordValue) -> Row {
        self.values.insert(key, value);
        self
    }

    /// Adds a value under `key`, in place.
    pub fn insert(&mut self, key: &str, value: impl RecordValue) {
        self.values.insert(key, value);
    }
}

impl RecordValue for Row {
    fn into_json(self) -> Result<Value, RecordError> {
        match self.values.problem {
            Some(problem) => Err(problem),
            None => Ok(Value::Object(self.values.map)),
        }
    }
}

/// A checked record's bench, adapter and values.
type Checked = (String, Option<Value>, Map<String, Value>);

/// One run of one bench: what was measured, on what, by which command, at
/// which commit. Build it with the chained methods, then [`Record::write`].
#[derive(Debug)]
#[must_use = "a record does nothing until written"]
pub struct Record {
    bench: String,
    adapter: Option<Value>,
    values: Values,
}

impl Record {
    /// An empty record of the bench `bench` (its file is `<bench>.jsonl`).
    pub fn new(bench: &str) -> Record {
        Record { bench: bench.to_owned(), adapter: None, values: Values::default() }
    }

    /// The adapter the figures were measured on (without one, a record
    /// says `null`: a CPU-only bench).
    pub fn adapter(mut self, info: &wgpu::AdapterInfo) -> Record {
        self.set_adapter(info);
        self
    }

    /// Sets the adapter, in place.
    pub fn set_adapter(&mut self, info: &wgpu::AdapterInfo) {
        self.adapter = Some(serde_json::json!({
            "name": info.name,
            "backend": format!("{:?}", info.backend),
            "device_type": format!("{:?}", info.device_type),
            "driver": info.driver,
            "driver_info": info.driver_info,
        }));
    }

    /// Adds a value under `key`; put the unit in the key (`frame_ms_median`).
    pub fn value(mut self, key: &str, value: impl RecordValue) -> Record {
        self.values.insert(key, value);
        self
    }

    /// Adds a value under `key`, in place.
    pub fn insert(&mut self, key: &str, value: impl RecordValue) {
        self.values.insert(key, value);
    }

    /// Appends a row to `values.rows`.
    pub fn row(mut self, row: Row) -> Record {
        self.push_row(row);
        self
    }

    /// Appends a row to `values.rows`, in place.
    pub fn push_row(&mut self, row: Row) {
        self.values.push("rows", row);
    }

    /// Appends a row to the list `values.<key>` (for a bench with more
    /// than one table).
    pub fn push_row_to(&mut self, key: &str, row: Row) {
        self.values.push(key, row);
    }

    /// The values, checked: the first misuse, if any.
    fn into_checked(self) -> Result<Checked, RecordError> {
        let valid_name =
            !self.bench.is_empty() && self.bench.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
        if !valid_name {
            return Err(RecordError::InvalidBench(self.bench));
        }
        if let Some(problem) = self.values.problem {
            return Err(problem);
        }
        if self.values.map.is_empty() {
            return Err(RecordError::NoValues);
        }
        Ok((self.bench, self.adapter, self.values.map))
    }

    /// The record as one line of JSON (no newline), with its fields in the
    /// documented order; runs `git` for the commit. An error for a misused
    /// record.
    pub fn to_json_line(self) -> Result<String, RecordError> {
        let (bench, adapter, values) = self.into_checked()?;
        json_line(bench, adapter, values)
    }

    /// Appends the record to `$OXYGEN_RECORD_DIR/<bench>.jsonl` (creating
    /// the directory) and says so on stderr; returns the file. When
    /// `OXYGEN_RECORD_DIR` is not set, writes nothing and returns `None`,
    /// but still refuses a misused record, so that a run without the
    /// variable finds the misuse too.
    pub fn write(self) -> Result<Option<PathBuf>, RecordError> {
        let (bench, adapter, values) = self.into_checked()?;
        let Some(dir) = std::env::var_os(RECORD_DIR_VAR).filter(|d| !d.is_empty()) else {
            eprintln!("record: not kept ({RECORD_DIR_VAR} is not set)");
            return Ok(None);
        };
        let dir = resolve_dir(Path::new(&dir), workspace_root().as_deref());
        let path = dir.join(format!("{bench}.jsonl"));
        let mut line = json_line(bench, adapter, values)?;
        line.push('\n');
        let io = |source| RecordError::Io { path: path.clone(), source };
        std::fs::create_dir_all(&dir).map_err(io)?;
        let mut file = std::fs::OpenOptions::new().create(true).append(true).open(&path).map_err(io)?;
        // One write of the whole line: concurrent appends do not interleave.
        file.write_all(line.as_bytes()).map_err(io)?;
        eprintln!("record: appended to {}", path.display());
        Ok(Some(path))
    }
}

/// The record's line: its fields in the documented order.
fn json_line(bench: String, adapter: Option<Value>, values: Map<String, Value>) -> Result<String, RecordError> {
    let (commit, dirty) = git_state(workspace_root().as_deref());
    let fields: [(&str, Value); 8] = [
        ("bench", Value::from(bench)),
        ("commit", Value::from(commit)),
        ("dirty", dirty.map_or(Value::Null, Value::from)),
        ("date", Value::from(utc_iso8601(SystemTime::now()))),
        ("adapter", adapter.unwrap_or(Value::Null)),
        ("host", host()),
        ("command", command()),
        ("values", Value::Object(values)),
    ];
    let mut line = String::from("{");
    for (i, (key, value)) in fields.iter().enumerate() {
        if i > 0 {
            line.push(',');
        }
        line.push_str(&serde_json::to_string(key).map_err(RecordError::Json)?);
        line.push(':');
        line.push_str(&serde_json::to_string(value).map_err(RecordError::Json)?);
    }
    line.push('}');
    Ok(line)
}

/// The workspace this crate was built in, when it is still there.
fn workspace_root() -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent()?;
    root.join("Cargo.toml").is_file().then(|| root.to_path_buf())
}

/// `dir` as given when absolute, else under the workspace root (when
/// found) or the working directory.
fn resolve_dir(dir: &Path, root: Option<&Path>) -> PathBuf {
    match root {
        Some(root) if dir.is_relative() => root.join(dir),
        _ => dir.to_path_buf(),
    }
}

/// The commit (`$OXYGEN_COMMIT`, else `git rev-parse HEAD`, else
/// "unknown") and whether tracked files differ from it (`None`: unknown,
/// always so when the commit was given).
fn git_state(root: Option<&Path>) -> (String, Option<bool>) {
    let git = |args: &[&str]| {
        let mut command = Command::new("git");
        command.args(args);
        if let Some(root) = root {
            command.current_dir(root);
        }
        command
            .output()
            .ok()
            .filter(|out| out.status.success())
            .map(|out| String::from_utf8_lossy(&out.stdout).trim().to_owned())
    };
    // A commit given by the caller names the build; this directory's git
    // state says nothing about it. (On the GPU machine the tree's copy held
    // the session's first commit, and records named it instead of the
    // commit the binaries were built from.)
    if let Some(given) = std::env::var(COMMIT_VAR).ok().filter(|c| !c.is_empty()) {
        return (given, None);
    }
    let commit = git(&["rev-parse", "HEAD"]).filter(|c| !c.is_empty()).unwrap_or_else(|| "unknown".to_owned());
    let dirty = git(&["status", "--porcelain", "--untracked-files=no"]).map(|status| !status.is_empty());
    (commit, dirty)
}

fn host() -> Value {
    serde_json::json!({
        "available_parallelism": std::thread::available_parallelism().map_or(1, |n| n.get()),
        "os": std::env::consts::OS,
        "arch": std::env::consts::ARCH,
    })
}

/// `{"argv": "<program> <args>", "env": {...}}`: the program's file name
/// (without the hash cargo appends to test and bench binaries), its
/// arguments (quoted where a shell would need it), and the environment
/// variables that change what is measured.
fn command() -> Value {
    let mut args = std::env::args_os().map(|a| a.to_string_lossy().into_owned());
    let program = args.next().map(|p| program_name(&p)).unwrap_or_default();
    let line = std::iter::once(program).chain(args.map(|a| shell_quote(&a))).collect::<Vec<_>>().join(" ");
    let mut env: Vec<(String, String)> = std::env::vars_os()
        .filter_map(|(k, v)| Some((k.into_string().ok()?, v.to_string_lossy().into_owned())))
        .filter(|(k, _)| k != RECORD_DIR_VAR && k != COMMIT_VAR)
        .filter(|(k, _)| RECORDED_ENV_PREFIXES.iter().any(|p| k.starts_with(p)))
        .collect();
    env.sort();
    let env: Map<String, Value> = env.into_iter().map(|(k, v)| (k, Value::from(v))).collect();
    serde_json::json!({ "argv": line, "env": env })
}

/// The file name of `path`, without a `-<16 hex digits>` cargo suffix.
fn program_name(path: &str) -> String {
    let name = Path::new(path).file_name().map_or_else(|| path.to_owned(), |n| n.to_string_lossy().into_owned());
    match name.rsplit_once('-') {
        Some((stem, hash)) if hash.len() == 16 && hash.chars().all(|c| c.is_ascii_hexdigit()) => stem.to_owned(),
        _ => name,
    }
}

fn shell_quote(arg: &str) -> String {
    let plain = !arg.is_empty() && arg.chars().all(|c| c.is_ascii_alphanumeric() || "-_./=,:+@%".contains(c));
    if plain { arg.to_owned() } else { format!("'{}'", arg.replace('\'', r"'\''")) }
}

/// `time` as `YYYY-MM-DDThh:mm:ssZ` (UTC).
fn utc_iso8601(time: SystemTime) -> String {
    let seconds = match time.duration_since(UNIX_EPOCH) {
        Ok(after) => i64::try_from(after.as_secs()).unwrap_or(i64::MAX),
        Err(before) => -i64::try_from(before.duration().as_secs()).unwrap_or(i64::MAX),
    };
    let (days, second_of_day) = (seconds.div_euclid(86_400), seconds.rem_euclid(86_400));
    let (year, month, day) = civil_from_days(days);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        second_of_day / 3600,
        second_of_day % 3600 / 60,
        second_of_day % 60
    )
}

/// The proleptic Gregorian date of `days` after 1970-01-01 (Howard
/// Hinnant's `civil_from_days`).
fn civil_from_days(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let day_of_era = z.rem_euclid(146_097);
    let year_of_era = (day_of_era - day_of_era / 1460 + day_of_era / 36_524 - day_of_era / 146_096) / 365;
    let day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
    let shifted_month = (5 * day_of_year + 2) / 153;
    let day = (day_of_year - (153 * shifted_month + 2) / 5 + 1) as u32;
    let month = if shifted_month < 10 { shifted_month + 3 } else { shifted_month - 9 } as u32;
    let year = year_of_era + era * 400 + i64::from(month <= 2);
    (year, month, day)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn date(seconds: u64) -> String {
        utc_iso8601(UNIX_EPOCH + Duration::from_secs(seconds))
    }

    #[test]
    fn dates_are_utc_iso8601() {
        assert_eq!(date(0), "1970-01-01T00:00:00Z");
        assert_eq!(date(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(date(1_709_251_199), "2024-02-29T23:59:59Z");
        assert_eq!(date(4_107_542_400), "2100-03-01T00:00:00Z");
        assert_eq!(utc_iso8601(UNIX_EPOCH - Duration::from_secs(1)), "1969-12-31T23:59:59Z");
    }

    #[test]
    fn a_record_is_one_line_with_its_fields_in_order() {
        let _env = EnvGuard::set(&[]);
        let line = Record::new("unit_bench")
            .value("frame_ms_median", 0.75)
            .value("gpu_ms", None::<f64>)
            .row(Row::new().value("case", "a").value("ms_samples", vec![1.0, 2.5]))
            .row(Row::new().value("case", "b").value("ms_samples", [3u32, 4]))
            .to_json_line()
            .expect("a valid record");
        assert!(!line.contains('\n'));
        let value: Value = serde_json::from_str(&line).expect("JSON");
        assert_eq!(value["bench"], "unit_bench");
        assert_eq!(value["adapter"], Value::Null);
        assert_eq!(value["values"]["frame_ms_median"], 0.75);
        assert_eq!(value["values"]["rows"][1]["case"], "b");
        let order: Vec<usize> = ["bench", "commit", "dirty", "date", "adapter", "host", "command", "values"]
            .iter()
            .map(|k| line.find(&format!("\"{k}\":")).expect("every field"))
            .collect();
        assert!(order.windows(2).all(|w| w[0] < w[1]), "{line}");
    }

    #[test]
    fn misuse_is_refused_with_the_key() {
        let error = Record::new("b").value("ms", f64::NAN).to_json_line().expect_err("NaN");
        assert!(matches!(error, RecordError::NotFinite { ref key, .. } if key == "ms"), "{error}");
        let error = Record::new("b").row(Row::new()).row(Row::new().value("gpu_ms", vec![1.0, f64::INFINITY]));
        let error = error.to_json_line().expect_err("infinity");
        assert!(matches!(error, RecordError::NotFinite { ref key, .. } if key == "rows[1].gpu_ms[1]"), "{error}");
        let error = Record::new("b").value("ms", 1.0).value("ms", 2.0).to_json_line().expect_err("twice");
        assert!(matches!(error, RecordError::DuplicateKey(ref key) if key == "ms"), "{error}");
        assert!(matches!(Record::new("b").to_json_line(), Err(RecordError::NoValues)));
        assert!(matches!(Record::new("b").value("", 1).to_json_line(), Err(RecordError::EmptyKey)));
        assert!(matches!(Record::new("../b").value("x", 1).to_json_line(), Err(RecordError::InvalidBench(_))));
    }

    #[test]
    fn program_names_lose_cargo_hashes() {
        assert_eq!(program_name("/t/release/deps/prep-0123456789abcdef"), "prep");
        assert_eq!(program_name("target/debug/examples/cubes_bench"), "cubes_bench");
        assert_eq!(program_name("raster-floor"), "raster-floor");
        // All hex but not a hash's 16 digits, and 16 characters but not hex.
        assert_eq!(program_name("shader-cafe"), "shader-cafe");
        assert_eq!(program_name("a-0123456789abcdeg"), "a-0123456789abcdeg");
        assert_eq!(shell_quote("a b"), "'a b'");
        assert_eq!(shell_quote("10000,100000"), "10000,100000");
    }

    #[test]
    fn relative_directories_are_under_the_workspace() {
        let root = Path::new("/ws");
        assert_eq!(resolve_dir(Path::new("docs/records"), Some(root)), Path::new("/ws/docs/records"));
        assert_eq!(resolve_dir(Path::new("/tmp/r"), Some(root)), Path::new("/tmp/r"));
        assert_eq!(resolve_dir(Path::new("r"), None), Path::new("r"));
    }

    /// Serialises the tests that read or set environment variables (a
    /// record reads its directory, commit and `command.env` from them, and
    /// they are the whole process's).
    static ENV: std::sync::Mutex<()> = std::sync::Mutex::new(());

    /// Holds [`ENV`] with some variables set (or removed), and puts them
    /// back when dropped, a failed assertion included.
    struct EnvGuard {
        saved: Vec<(&'static str, Option<std::ffi::OsString>)>,
        _lock: std::sync::MutexGuard<'static, ()>,
    }

    impl EnvGuard {
        /// Takes [`ENV`], then sets each variable given `Some` and removes
        /// each given `None`.
        fn set(vars: &[(&'static str, Option<&str>)]) -> EnvGuard {
            let lock = ENV.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            let saved = vars.iter().map(|&(key, _)| (key, std::env::var_os(key))).collect();
            for &(key, value) in vars {
                set_env(key, value);
            }
            EnvGuard { saved, _lock: lock }
        }
    }

    impl Drop for EnvGuard {
        fn drop(&mut self) {
            for (key, value) in self.saved.drain(..) {
                set_env(key, value.as_deref().and_then(std::ffi::OsStr::to_str));
            }
        }
    }

    /// Sets `key` to `value`, or removes it for `None`.
    fn set_env(key: &str, value: Option<&str>) {
        // SAFETY: every test of this module that touches the environment
        // holds ENV, and the other tests of this crate do not read it.
        unsafe {
            match value {
                Some(value) => std::env::set_var(key, value),
                None => std::env::remove_var(key),
            }
        }
    }

    /// A fresh directory under the system's temporary one, for this
    /// process and test.
    fn temp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("oxygen-record-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("a temporary directory");
        dir
    }

    #[test]
    fn errors_say_what_went_wrong_and_why() {
        let json = serde_json::from_str::<Value>("{").expect_err("unclosed");
        let json_text = json.to_string();
        let io = std::io::Error::other("disk full");
        let cases = [
            (
                RecordError::InvalidBench("a/b".into()),
                "bench name \"a/b\" is not a plain file name (ASCII letters, digits, _ and -)",
                None,
            ),
            (RecordError::EmptyKey, "a record value has an empty key", None),
            (RecordError::DuplicateKey("rows[2].ms".into()), "record key \"rows[2].ms\" is given twice", None),
            (
                RecordError::NotFinite { key: "ms".into(), value: f64::INFINITY },
                "record value \"ms\" is inf, which JSON cannot hold (record a missing figure as None)",
                None,
            ),
            (RecordError::NoValues, "the record has no values", None),
            (RecordError::Json(json), &format!("the record does not serialise: {json_text}"), Some(json_text.clone())),
            (
                RecordError::Io { path: PathBuf::from("/r/b.jsonl"), source: io },
                "cannot append the record to /r/b.jsonl: disk full",
                Some("disk full".to_owned()),
            ),
        ];
        for (error, text, source) in cases {
            assert_eq!(error.to_string(), text);
            assert_eq!(std::error::Error::source(&error).map(ToString::to_string), source, "{error}");
        }
    }

    #[test]
    fn every_kind_of_value_becomes_json() {
        let json = |value: Result<Value, RecordError>| value.expect("a finite value");
        assert_eq!(json(1.5f32.into_json()), 1.5);
        assert!(matches!(f32::NAN.into_json(), Err(RecordError::NotFinite { .. })));
        let text = String::from("cpu");
        assert_eq!(json((&text).into_json()), "cpu");
        assert_eq!(json(Some(2u32).into_json()), 2);
        assert_eq!(json(None::<u32>.into_json()), Value::Null);
        let list = vec![1.0, 2.5];
        assert_eq!(json(list.as_slice().into_json()), serde_json::json!([1.0, 2.5]));
        assert_eq!(json((&list).into_json()), serde_json::json!([1.0, 2.5]));
        assert_eq!(json([3u8, 4].into_json()), serde_json::json!([3, 4]));
        let mut row = Row::new().value("a", 1);
        row.insert("b", true);
        assert_eq!(json(row.into_json()), serde_json::json!({"a": 1, "b": true}));
    }

    #[test]
    fn a_written_record_holds_every_field() {
        let dir = temp_dir("write");
        let mut info = wgpu::AdapterInfo::new(wgpu::DeviceType::DiscreteGpu, wgpu::Backend::Vulkan);
        info.name = "Unit GPU".into();
        info.driver = "unit driver".into();
        info.driver_info = "1.2.3".into();
        let mut record = Record::new("unit_write").value("frames", 3);
        record.set_adapter(&info);
        record.insert("label", "x");
        record.push_row_to("passes", Row::new().value("pass", "shadow"));
        record.push_row(Row::new().value("case", "a"));
        let (first, second) = {
            let dir = dir.to_str().expect("a UTF-8 temporary directory");
            let vars = [(RECORD_DIR_VAR, Some(dir)), (COMMIT_VAR, Some("0123abcd")), ("OXYGEN_UNIT_KNOB", Some("on"))];
            let _env = EnvGuard::set(&vars);
            (record.write().expect("written"), Record::new("unit_write").value("frames", 4).write().expect("written"))
        };
        let path = dir.join("unit_write.jsonl");
        assert_eq!(first.as_deref(), Some(path.as_path()));
        assert_eq!(second.as_deref(), Some(path.as_path()));
        let text = std::fs::read_to_string(&path).expect("the record file");
        std::fs::remove_dir_all(&dir).expect("the temporary directory removed");
        let lines: Vec<Value> = text.lines().map(|line| serde_json::from_str(line).expect("JSON")).collect();
        assert_eq!(lines.len(), 2, "appended: {text}");
        assert!(text.ends_with('\n'));
        let record = &lines[0];
        assert_eq!(record["bench"], "unit_write");
        assert_eq!(record["commit"], "0123abcd");
        assert_eq!(record["dirty"], Value::Null);
        let date = record["date"].as_str().expect("a date");
        assert!(date.len() == 20 && date.as_bytes()[10] == b'T' && date.ends_with('Z'), "{date}");
        let adapter = serde_json::json!({
            "name": "Unit GPU", "backend": "Vulkan", "device_type": "DiscreteGpu", "driver": "unit driver", "driver_info": "1.2.3",
        });
        assert_eq!(record["adapter"], adapter);
        let parallelism = std::thread::available_parallelism().map_or(1, |n| n.get());
        let host = serde_json::json!({ "available_parallelism": parallelism, "os": std::env::consts::OS, "arch": std::env::consts::ARCH });
        assert_eq!(record["host"], host);
        let program = program_name(&std::env::args().next().expect("a program"));
        let argv = record["command"]["argv"].as_str().expect("argv");
        assert_eq!(argv.split(' ').next(), Some(program.as_str()), "{argv}");
        let env = record["command"]["env"].as_object().expect("env");
        assert_eq!(env.get("OXYGEN_UNIT_KNOB"), Some(&Value::from("on")), "{env:?}");
        assert!(!env.contains_key(RECORD_DIR_VAR) && !env.contains_key(COMMIT_VAR), "{env:?}");
        assert!(env.keys().all(|k| RECORDED_ENV_PREFIXES.iter().any(|p| k.starts_with(p))), "{env:?}");
        let values =
            serde_json::json!({ "frames": 3, "label": "x", "passes": [{"pass": "shadow"}], "rows": [{"case": "a"}] });
        assert_eq!(record["values"], values);
        assert_eq!(lines[1]["values"], serde_json::json!({ "frames": 4 }));
    }

    #[test]
    fn without_a_directory_nothing_is_written() {
        let _env = EnvGuard::set(&[(RECORD_DIR_VAR, None)]);
        assert!(matches!(Record::new("unit_unkept").value("x", 1).write(), Ok(None)));
        assert!(matches!(Record::new("unit_unkept").write(), Err(RecordError::NoValues)));
    }

    #[test]
    fn git_state_names_the_commit_and_whether_it_is_dirty() {
        let repo = temp_dir("git");
        let git = |args: &[&str]| {
            let identity = ["-c", "user.name=unit", "-c", "user.email=unit@example.com", "-c", "commit.gpgsign=false"];
            let out = Command::new("git").args(identity).args(args).current_dir(&repo).output().expect("git runs");
            assert!(out.status.success(), "git {args:?}: {}", String::from_utf8_lossy(&out.stderr));
            String::from_utf8(out.stdout).expect("UTF-8").trim().to_owned()
        };
        git(&["init", "-q"]);
        std::fs::write(repo.join("f"), "1").expect("a file");
        git(&["add", "f"]);
        git(&["commit", "-q", "-m", "unit"]);
        let head = git(&["rev-parse", "HEAD"]);
        let state = |commit: Option<&str>| {
            let _env = EnvGuard::set(&[(COMMIT_VAR, commit)]);
            git_state(Some(&repo))
        };
        assert_eq!(state(None), (head.clone(), Some(false)));
        std::fs::write(repo.join("f"), "2").expect("a change");
        assert_eq!(state(None), (head, Some(true)));
        assert_eq!(state(Some("0123abcd")), ("0123abcd".to_owned(), None));
        std::fs::remove_dir_all(&repo).expect("the temporary repository removed");
    }

    #[test]
    fn the_workspace_root_is_this_crates_parent() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("a workspace");
        assert_eq!(workspace_root().as_deref(), Some(root));
    }
}
