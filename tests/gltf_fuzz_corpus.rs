//! A deterministic fuzz corpus for the glTF importer (issue 10: untrusted
//! files end in a clear error, with no crash, no hang, no read outside the
//! scene's folder, and bounded memory).
//!
//! Every shipped scene (`assets/*/*.glb`, and each `.gltf` both with its
//! buffers and images turned into `data:` URIs and as it is, from a copy of
//! its folder) is mutated [`CORPUS_SIZE`] times from one fixed seed with a
//! small hand-written PRNG: truncation, byte flips in the JSON and in the
//! binary data, GLB headers made inconsistent, JSON values swapped for edge
//! values, keys deleted, accessors bent out of shape, node graphs with cycles,
//! shared children and deep chains, hostile URIs and lying images.
//!
//! Each mutant is imported on its own thread (named after the case, so that
//! even a stack overflow names it) inside `catch_unwind`, and must come back
//! `Ok` or `Err` within [`TIME_BUDGET`] with its peak live heap, measured by
//! the counting allocator below, under [`MEMORY_BUDGET`]. A panic hook counts
//! panics instead of printing them; any panic fails the test.
//!
//! The corpus imports with [`ImportLimits::default`] scaled down by
//! [`corpus_limits`]: 128 MiB of bytes, 2^19 vertices, 3·2^19 indices. The
//! memory assertion then checks that the importer's budget covers what it
//! really allocates (with 2× headroom for transient copies), whatever a
//! mutant asks for.
//!
//! Reproduce one mutant: `OXYGEN_FUZZ_CASE=N cargo test --test
//! gltf_fuzz_corpus -- --nocapture` prints its mutation and outcome and writes
//! its bytes to `target/tmp/gltf_fuzz_corpus/case-N.<ext>`. Other knobs:
//! `OXYGEN_FUZZ_CASES` (corpus size), `OXYGEN_FUZZ_SEED` (another seed),
//! `OXYGEN_FUZZ_VERBOSE` (one line per import).

mod support;

use std::alloc::{GlobalAlloc, Layout, System};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use oxygen::core::Scene;
use oxygen::import::{GltfError, ImportLimits, ImportOptions, import_gltf_slice, import_gltf_with};
use oxygen_demo::record::Row;
use serde_json::{Value, json};
use support::encode::{base64_encode, data_uri, png_chunk};

/// Mutants in the corpus (at least 2000, as the issue asks).
const CORPUS_SIZE: usize = 2400;
/// The fixed seed; `OXYGEN_FUZZ_SEED` overrides it for exploration.
const CORPUS_SEED: u64 = 0x0179_6E10_9F5A_D00D;
/// Wall-clock time one import may take (debug build).
const TIME_BUDGET: Duration = Duration::from_secs(2);
/// Peak live heap one import may reach, bytes.
const MEMORY_BUDGET: usize = 256 << 20;

/// The corpus' import limits: the defaults, with the byte total and the
/// vertex and index counts scaled down so that the largest import a mutant
/// can legally ask for (a few hundred bytes of JSON may declare millions of
/// zero-filled vertices) fits [`TIME_BUDGET`] in a debug build, and so that
/// [`MEMORY_BUDGET`] is twice the byte budget: the memory check then tests
/// that the importer charges what it really allocates.
fn corpus_limits() -> ImportLimits {
    ImportLimits { max_total_bytes: 128 << 20, max_vertices: 1 << 19, max_indices: 3 << 19, ..ImportLimits::default() }
}

// ---------------------------------------------------------------------------
// Peak-memory accounting.

/// The system allocator, counting live bytes and their high-water mark.
struct CountingAllocator;

static LIVE_BYTES: AtomicUsize = AtomicUsize::new(0);
static PEAK_BYTES: AtomicUsize = AtomicUsize::new(0);

fn grew(bytes: usize) {
    let live = LIVE_BYTES.fetch_add(bytes, Ordering::Relaxed) + bytes;
    PEAK_BYTES.fetch_max(live, Ordering::Relaxed);
}

// SAFETY: every call is forwarded to `System` unchanged; only counters change.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded with the caller's guarantees.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded with the caller's guarantees.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded with the caller's guarantees.
        unsafe { System.dealloc(ptr, layout) };
        LIVE_BYTES.fetch_sub(layout.size(), Ordering::Relaxed);
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: forwarded with the caller's guarantees.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            // While moving, both blocks are live.
            grew(new_size);
            LIVE_BYTES.fetch_sub(layout.size(), Ordering::Relaxed);
        }
        p
    }
}

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

/// Starts a measurement: the peak is reset to what is live now.
fn start_measuring() -> usize {
    let live = LIVE_BYTES.load(Ordering::Relaxed);
    PEAK_BYTES.store(live, Ordering::Relaxed);
    live
}

/// Peak bytes above `baseline` since [`start_measuring`].
fn peak_since(baseline: usize) -> usize {
    PEAK_BYTES.load(Ordering::Relaxed).saturating_sub(baseline)
}

// ---------------------------------------------------------------------------
// A small deterministic PRNG (SplitMix64).

struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Self {
        Rng(seed)
    }
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in `0..n` (`n > 0`).
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    /// True with probability `1 / n`.
    fn one_in(&mut self, n: usize) -> bool {
        self.below(n) == 0
    }
    fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

/// The PRNG of mutant `index`: each mutant can be made on its own.
fn case_rng(seed: u64, index: usize) -> Rng {
    let mut mix = Rng::new(seed ^ (index as u64).wrapping_mul(0xD1B5_4A32_D192_ED03));
    Rng::new(mix.next_u64())
}

// ---------------------------------------------------------------------------
// Seeds: the shipped scenes.

fn assets() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets")
}

fn work_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("gltf_fuzz_corpus")
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SeedForm {
    /// A `.glb` file.
    Glb,
    /// A `.gltf` whose buffers and images were turned into `data:` URIs.
    Embedded,
    /// A `.gltf` as shipped, importable only from (a copy of) its folder.
    External,
}

struct Seed {
    name: String,
    form: SeedForm,
    /// The file as imported.
    bytes: Vec<u8>,
    /// Its JSON.
    json: Value,
    /// A GLB's binary chunk.
    bin: Option<Vec<u8>>,
    /// A folder holding a copy of the asset's files (`scene/`) beside an
    /// `outside/` folder no URI may reach, with traps (a FIFO, links out).
    folder: PathBuf,
}

/// The JSON and binary chunks of a well-formed GLB.
fn split_glb(bytes: &[u8]) -> (Vec<u8>, Option<Vec<u8>>) {
    let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    let json_len = word(12);
    let json = bytes[20..20 + json_len].to_vec();
    let bin_at = 20 + json_len;
    let bin = (bin_at + 8 <= bytes.len()).then(|| bytes[bin_at + 8..bin_at + 8 + word(bin_at)].to_vec());
    (json, bin)
}

/// A GLB with consistent lengths.
fn make_glb(json: &[u8], bin: Option<&[u8]>) -> Vec<u8> {
    let mut json = json.to_vec();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let bin = bin.map(|b| {
        let mut b = b.to_vec();
        while !b.len().is_multiple_of(4) {
            b.push(0);
        }
        b
    });
    let total = 12 + 8 + json.len() + bin.as_ref().map_or(0, |b| 8 + b.len());
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(&json);
    if let Some(bin) = bin {
        out.extend((bin.len() as u32).to_le_bytes());
        out.extend(b"BIN\0");
        out.extend(&bin);
    }
    out
}

fn base64_decode(text: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        _ => 63,
    };
    let mut out = Vec::new();
    let (mut acc, mut bits) = (0u32, 0);
    for c in text.trim_end_matches('=').bytes() {
        acc = (acc << 6) | u32::from(value(c));
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    out
}

/// Copies the asset folder to `<work>/<name>/scene`, with an `outside/`
/// sibling holding copies of the same files and a `secret.bin`/`secret.png`,
/// and traps inside `scene/`: a FIFO, links out of the folder and to
/// `/dev/zero`, a link loop and a subfolder.
fn prepare_folder(name: &str, asset_folder: &Path, secret_bin: &[u8]) -> PathBuf {
    let folder = work_dir().join(name);
    let _ = std::fs::remove_dir_all(&folder);
    let (scene, outside) = (folder.join("scene"), folder.join("outside"));
    std::fs::create_dir_all(scene.join("subdir")).unwrap();
    std::fs::create_dir_all(&outside).unwrap();
    for entry in std::fs::read_dir(asset_folder).unwrap() {
        let path = entry.unwrap().path();
        let file_name = path.file_name().unwrap();
        if matches!(path.extension().and_then(|e| e.to_str()), Some("bin" | "png" | "jpg")) {
            std::fs::copy(&path, scene.join(file_name)).unwrap();
            std::fs::copy(&path, outside.join(file_name)).unwrap();
        }
    }
    std::fs::write(outside.join("secret.bin"), secret_bin).unwrap();
    std::fs::copy(assets().join("TwoSidedPlane/TwoSidedPlane_Normal.png"), outside.join("secret.png")).unwrap();
    let status = std::process::Command::new("mkfifo").arg(scene.join("fifo")).status();
    assert!(status.is_ok_and(|s| s.success()), "mkfifo failed");
    std::os::unix::fs::symlink("../outside/secret.bin", scene.join("link-out.bin")).unwrap();
    std::os::unix::fs::symlink("../outside/secret.png", scene.join("link-out.png")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", scene.join("link-zero")).unwrap();
    std::os::unix::fs::symlink("link-loop", scene.join("link-loop")).unwrap();
    folder
}

/// Replaces every external buffer and image URI with a `data:` URI.
fn embed(json: &mut Value, folder: &Path) {
    for (list, mime) in [("buffers", "application/octet-stream"), ("images", "image/png")] {
        for item in json.get_mut(list).and_then(Value::as_array_mut).into_iter().flatten() {
            if let Some(uri) = item.get("uri").and_then(Value::as_str) {
                let bytes = std::fs::read(folder.join(uri)).unwrap();
                item["uri"] = Value::String(data_uri(mime, &bytes));
            }
        }
    }
}

fn load_seeds() -> Vec<Seed> {
    let mut seeds = Vec::new();
    let mut folders: Vec<PathBuf> = std::fs::read_dir(assets()).unwrap().map(|e| e.unwrap().path()).collect();
    folders.sort();
    for folder in folders.iter().filter(|f| f.is_dir()) {
        let mut files: Vec<PathBuf> = std::fs::read_dir(folder).unwrap().map(|e| e.unwrap().path()).collect();
        files.sort();
        for file in files {
            let stem = file.file_stem().unwrap().to_string_lossy().into_owned();
            match file.extension().and_then(|e| e.to_str()) {
                Some("glb") => {
                    let bytes = std::fs::read(&file).unwrap();
                    let (json, bin) = split_glb(&bytes);
                    let folder = prepare_folder(&stem, folder, bin.as_deref().unwrap_or(b"secret"));
                    let json = serde_json::from_slice(&json).unwrap();
                    seeds.push(Seed { name: stem, form: SeedForm::Glb, bytes, json, bin, folder });
                }
                Some("gltf") => {
                    let bytes = std::fs::read(&file).unwrap();
                    let json: Value = serde_json::from_slice(&bytes).unwrap();
                    let first_buffer =
                        json["buffers"][0]["uri"].as_str().map(|u| std::fs::read(folder.join(u)).unwrap());
                    let secret = first_buffer.unwrap_or_default();
                    let external_folder = prepare_folder(&format!("{stem}-external"), folder, &secret);
                    let mut embedded = json.clone();
                    embed(&mut embedded, folder);
                    let embedded_folder = prepare_folder(&format!("{stem}-embedded"), folder, &secret);
                    seeds.push(Seed {
                        name: format!("{stem} (data: URIs)"),
                        form: SeedForm::Embedded,
                        bytes: serde_json::to_vec(&embedded).unwrap(),
                        json: embedded,
                        bin: None,
                        folder: embedded_folder,
                    });
                    seeds.push(Seed {
                        name: format!("{stem} (external files)"),
                        form: SeedForm::External,
                        bytes,
                        json,
                        bin: None,
                        folder: external_folder,
                    });
                }
                _ => {}
            }
        }
    }
    assert!(seeds.len() >= 12, "expected every shipped scene, found {}", seeds.len());
    seeds
}

// ---------------------------------------------------------------------------
// Mutations.

/// How a mutant was made, for the summary and for reproducing it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    Unmutated,
    Truncate,
    FlipJsonBytes,
    FlipBinBytes,
    GlbHeader,
    JsonValue,
    RawToken,
    DeleteKey,
    Accessor,
    Graph,
    Uri,
    Image,
}

/// One mutant: its bytes and how to import it.
struct Mutant {
    index: usize,
    seed: usize,
    kind: Kind,
    /// What was done, in words.
    what: String,
    bytes: Vec<u8>,
    /// Import from the seed's folder copy (else from memory only).
    from_folder: bool,
    /// Import from memory too.
    from_memory: bool,
    /// An outcome the mutant must have.
    expect: Expect,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Expect {
    /// `Ok` or `Err`.
    Anything,
    /// Must import.
    Ok,
    /// Must be refused (a URI that names nothing readable inside the folder).
    Err,
    /// Must be refused with [`GltfError::Uri`].
    UriErr,
}

/// A JSON path.
#[derive(Clone, Debug)]
enum Step {
    Key(String),
    At(usize),
}

fn collect_paths(value: &Value, path: &mut Vec<Step>, out: &mut Vec<Vec<Step>>) {
    out.push(path.clone());
    match value {
        Value::Object(map) => {
            for (k, v) in map {
                path.push(Step::Key(k.clone()));
                collect_paths(v, path, out);
                path.pop();
            }
        }
        Value::Array(items) => {
            for (i, v) in items.iter().enumerate() {
                path.push(Step::At(i));
                collect_paths(v, path, out);
                path.pop();
            }
        }
        _ => {}
    }
}

fn at_path<'a>(value: &'a mut Value, path: &[Step]) -> Option<&'a mut Value> {
    let mut at = value;
    for step in path {
        at = match step {
            Step::Key(k) => at.get_mut(k.as_str())?,
            Step::At(i) => at.get_mut(*i)?,
        };
    }
    Some(at)
}

fn show_path(path: &[Step]) -> String {
    let mut s = String::new();
    for step in path {
        match step {
            Step::Key(k) => write!(s, ".{k}").unwrap(),
            Step::At(i) => write!(s, "[{i}]").unwrap(),
        }
    }
    if s.is_empty() { "$".into() } else { s }
}

/// Keys whose values steer the importer; edits prefer them.
const STEERING_KEYS: &str = "accessors attributes buffer bufferView bufferViews buffers byteLength byteOffset \
    byteStride camera children componentType count extensionsRequired images index indices material materials \
    matrix mesh meshes mode nodes normalized POSITION NORMAL TEXCOORD_0 rotation sampler scale scene scenes source \
    sparse texCoord textures translation type uri values alphaMode alphaCutoff light lights KHR_lights_punctual \
    perspective yfov znear zfar wrapS magFilter max min version";

/// Values a file may hold that code tends not to expect (plus a 10 000-byte
/// string): huge and negative counts, every component type, floats past
/// `f32`, `-0.0`, NaN-like strings, empty and wrongly-typed containers.
const EDGE_VALUES: &str = r#"[0, 1, -1, 2, 3, 4, 6, 7, 255, 65536, 2147483647, 2147483648, 4294967295, 4294967296,
    16777216, 4194303, 3000000, 1000000000000000000, 1e18, 18446744073709551615, -9223372036854775808, 1e39, -1e39,
    -0.0, 0.5, 1e-45, 1e308, 5120, 5121, 5122, 5123, 5124, 5125, 5126, 5127, 34963, 9728, 10497,
    "", "NaN", "Infinity", "-0", "1e39", "SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT4", "MASK", "BLEND", "bogus",
    "\u0000", "é😀", [], [0], [-1], [0, 0], [1e39, 1e39, 1e39], [null], {}, null, true, false]"#;

/// An edge value, of the same JSON type as `old` two times in three.
fn edge_value(rng: &mut Rng, old: Option<&Value>) -> (Value, String) {
    let mut values: Vec<Value> = serde_json::from_str(EDGE_VALUES).unwrap();
    values.push(Value::String("x".repeat(10_000)));
    let same_type = |v: &Value| {
        matches!(
            (old, v),
            (Some(Value::Number(_)), Value::Number(_))
                | (Some(Value::String(_)), Value::String(_))
                | (Some(Value::Array(_)), Value::Array(_))
                | (Some(Value::Object(_)), Value::Object(_))
                | (Some(Value::Bool(_)), Value::Bool(_))
        )
    };
    let typed: Vec<&Value> = values.iter().filter(|v| same_type(v)).collect();
    let v = if !typed.is_empty() && rng.below(3) < 2 { (*rng.pick(&typed)).clone() } else { rng.pick(&values).clone() };
    let shown = match &v {
        Value::String(s) if s.len() > 40 => format!("\"x\" * {}", s.len()),
        v => v.to_string(),
    };
    (v, shown)
}

/// Tokens that are not JSON values but may sit where one is expected.
const RAW_TOKENS: &[&str] = &[
    "NaN",
    "Infinity",
    "-Infinity",
    "1e400",
    "-1e400",
    "99999999999999999999999",
    "-99999999999999999999999",
    "0x10",
    "01",
    "1.",
    "\"\\ud800\"",
    "[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[",
    "{\"a\":{\"a\":{\"a\":{\"a\":{}}}}}",
];

/// A random path, preferring values under steering keys.
fn random_path(rng: &mut Rng, json: &Value) -> Vec<Step> {
    let mut paths = Vec::new();
    collect_paths(json, &mut Vec::new(), &mut paths);
    if rng.below(10) < 7 {
        let steering: Vec<&Vec<Step>> = paths
            .iter()
            .filter(|p| {
                p.iter()
                    .rev()
                    .find_map(|s| if let Step::Key(k) = s { Some(k) } else { None })
                    .is_some_and(|k| STEERING_KEYS.split_whitespace().any(|s| s == k))
            })
            .collect();
        if !steering.is_empty() {
            return (*rng.pick(&steering)).clone();
        }
    }
    rng.pick(&paths).clone()
}

fn array_mut<'a>(json: &'a mut Value, key: &str) -> &'a mut Vec<Value> {
    if !json.get(key).is_some_and(Value::is_array) {
        json[key] = json!([]);
    }
    json[key].as_array_mut().unwrap()
}

fn len_of(json: &Value, key: &str) -> usize {
    json.get(key).and_then(Value::as_array).map_or(0, Vec::len)
}

/// The scene the importer will pick: its root list.
fn scene_roots(json: &mut Value) -> &mut Vec<Value> {
    let scene = json.get("scene").and_then(Value::as_u64).unwrap_or(0) as usize;
    let scenes = array_mut(json, "scenes");
    if scenes.len() <= scene {
        scenes.resize(scene + 1, json!({}));
    }
    array_mut(&mut scenes[scene], "nodes")
}

/// Appends nodes and returns the index of the first.
fn add_nodes(json: &mut Value, nodes: impl IntoIterator<Item = Value>) -> usize {
    let list = array_mut(json, "nodes");
    let first = list.len();
    list.extend(nodes);
    first
}

fn graph_edit(rng: &mut Rng, json: &mut Value) -> String {
    let count = len_of(json, "nodes");
    let any = |rng: &mut Rng| rng.below(count.max(1));
    let push_child = |json: &mut Value, parent: usize, child: Value| {
        if let Some(node) = json["nodes"].get_mut(parent) {
            array_mut(node, "children").push(child);
        }
    };
    match rng.below(11) {
        0 if count > 0 => {
            let n = any(rng);
            push_child(json, n, json!(n));
            format!("node {n} is its own child")
        }
        1 => {
            let a = add_nodes(json, [json!({}), json!({})]);
            json["nodes"][a]["children"] = json!([a + 1]);
            json["nodes"][a + 1]["children"] = json!([a]);
            if rng.one_in(2) {
                scene_roots(json).push(json!(a));
            }
            format!("two-node cycle {a} <-> {}", a + 1)
        }
        2 if count > 0 => {
            // A cycle through existing nodes: a descendant parents an ancestor.
            let (a, b) = (any(rng), any(rng));
            push_child(json, a, json!(b));
            push_child(json, b, json!(a));
            format!("nodes {a} and {b} parent each other")
        }
        3 if count > 0 => {
            let child = add_nodes(json, [json!({"mesh": 0})]);
            let (a, b) = (any(rng), any(rng));
            push_child(json, a, json!(child));
            push_child(json, b, json!(child));
            format!("node {child} shared by {a} and {b}")
        }
        4 => {
            let depth = *rng.pick(&[100usize, 511, 512, 513, 10_000, 100_000]);
            let first = count;
            let chain = (0..depth)
                .map(|i| if i + 1 < depth { json!({"children": [first + i + 1]}) } else { json!({"mesh": 0}) });
            add_nodes(json, chain);
            scene_roots(json).push(json!(first));
            format!("a chain {depth} deep")
        }
        5 => {
            // 40 levels of two nodes, each parenting both below: 2^40 paths.
            let levels = 40;
            let first = count;
            let nodes = (0..levels * 2).map(|i| {
                let level = i / 2;
                if level + 1 < levels {
                    json!({"children": [first + 2 * (level + 1), first + 2 * (level + 1) + 1]})
                } else {
                    json!({})
                }
            });
            add_nodes(json, nodes);
            scene_roots(json).extend([json!(first), json!(first + 1)]);
            "40 levels of 2 nodes parenting both below (2^40 paths)".into()
        }
        6 if count > 0 => {
            let n = any(rng);
            let bad = rng
                .pick(&[json!(count), json!(count + 1000), json!(-1), json!(u32::MAX), json!(u64::MAX), json!(1e39)])
                .clone();
            push_child(json, n, bad.clone());
            format!("node {n} gets child {bad}")
        }
        7 if count > 0 => {
            // A child listed as a scene root too, or a root listed twice.
            let n = any(rng);
            scene_roots(json).push(json!(n));
            format!("node {n} added to the scene roots")
        }
        8 => {
            let bad = rng.pick(&[json!(count), json!(-1), json!(u64::MAX), json!(null)]).clone();
            scene_roots(json).push(bad.clone());
            format!("scene root {bad}")
        }
        9 => {
            let width = *rng.pick(&[1000usize, 50_000]);
            let parent = add_nodes(json, [json!({"children": (count + 1..count + 1 + width).collect::<Vec<_>>()})]);
            add_nodes(json, (0..width).map(|_| json!({"mesh": 0})));
            scene_roots(json).push(json!(parent));
            format!("a node with {width} children")
        }
        _ => {
            let scene = rng.pick(&[json!(1), json!(-1), json!(u64::MAX), json!(null), json!("0")]).clone();
            json["scene"] = scene.clone();
            format!("default scene {scene}")
        }
    }
}

/// Element counts from the plausible to the absurd.
fn huge_count(rng: &mut Rng) -> Value {
    json!(*rng.pick(&[
        0u64,
        1,
        2,
        3,
        1 << 20,
        4_194_304,
        16_777_216,
        16_777_217,
        1 << 32,
        1_000_000_000_000_000_000,
        u64::MAX
    ]))
}

fn accessor_edit(rng: &mut Rng, json: &mut Value) -> String {
    let accessors = len_of(json, "accessors");
    if accessors == 0 {
        return "no accessors".into();
    }
    let a = rng.below(accessors);
    match rng.below(14) {
        12 | 13 => {
            // Mesh 0 becomes one primitive of zero-filled accessors (legal:
            // an accessor without a bufferView holds zeros), as many as the
            // file likes: nothing in the file's size bounds them.
            let vertices = *rng.pick(&[3u64, 524_286, 524_289, 1_048_575, 3_000_000, 16_777_215, 30_000_000, 1 << 32]);
            let indexed = rng.one_in(2);
            let indices = *rng.pick(&[3u64, 1_572_861, 1_572_864, 1_572_867, 3_145_728, 50_331_648, 1 << 32]);
            let first = len_of(json, "accessors");
            let list = array_mut(json, "accessors");
            list.push(json!({"componentType": 5126, "type": "VEC3", "count": vertices}));
            list.push(json!({"componentType": 5125, "type": "SCALAR", "count": indices}));
            let mut primitive = json!({"attributes": {"POSITION": first}});
            if indexed {
                primitive["indices"] = json!(first + 1);
            }
            if len_of(json, "meshes") == 0 {
                array_mut(json, "meshes").push(json!({}));
                add_nodes(json, [json!({"mesh": 0})]);
                let node = len_of(json, "nodes") - 1;
                scene_roots(json).push(json!(node));
            }
            json["meshes"][0]["primitives"] = json!([primitive]);
            if indexed {
                format!("mesh 0 is {vertices} zero vertices and {indices} zero indices")
            } else {
                format!("mesh 0 is {vertices} zero vertices")
            }
        }
        0 => {
            json["accessors"][a].as_object_mut().unwrap().remove("bufferView");
            format!("accessor {a} loses its bufferView")
        }
        1 => {
            let count = if rng.one_in(2) { huge_count(rng) } else { edge_value(rng, None).0 };
            json["accessors"][a].as_object_mut().unwrap().remove("bufferView");
            json["accessors"][a]["count"] = count.clone();
            format!("accessor {a} loses its bufferView and counts {count}")
        }
        2 => {
            let count = huge_count(rng);
            json["accessors"][a]["count"] = count.clone();
            format!("accessor {a} counts {count}")
        }
        3 => {
            let c = *rng.pick(&[5120, 5121, 5122, 5123, 5124, 5125, 5126, 0, -1, 5127]);
            json["accessors"][a]["componentType"] = json!(c);
            format!("accessor {a} componentType {c}")
        }
        4 => {
            let t = *rng.pick(&["SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4", "vec3", ""]);
            json["accessors"][a]["type"] = json!(t);
            format!("accessor {a} type {t}")
        }
        5 => {
            json["accessors"][a]["normalized"] = json!(true);
            format!("accessor {a} normalized")
        }
        6 => {
            let o = *rng.pick(&[1u64, 2, 3, 4, 12, 1 << 31, u32::MAX as u64, u64::MAX]);
            json["accessors"][a]["byteOffset"] = json!(o);
            format!("accessor {a} byteOffset {o}")
        }
        7 => {
            let views = len_of(json, "bufferViews").max(1);
            let v = rng.below(views);
            let s = *rng.pick(&[0u64, 1, 3, 4, 6, 252, 256, u32::MAX as u64]);
            if let Some(view) = json["bufferViews"].get_mut(v) {
                view["byteStride"] = json!(s);
            }
            format!("bufferView {v} byteStride {s}")
        }
        8 => {
            let views = len_of(json, "bufferViews").max(1);
            let (iv, vv) = (rng.below(views), rng.below(views));
            let count = rng.pick(&[json!(1), json!(2), json!(3), json!(1000), json!(u64::MAX)]).clone();
            let ic = *rng.pick(&[5121, 5123, 5125, 5126]);
            let drop_view = rng.one_in(2);
            let accessor = &mut json["accessors"][a];
            accessor["sparse"] = json!({"count": count, "indices": {"bufferView": iv, "componentType": ic}, "values": {"bufferView": vv}});
            if drop_view {
                accessor.as_object_mut().unwrap().remove("bufferView");
            }
            format!(
                "accessor {a} gets sparse count {count} (indices view {iv} of {ic}, values view {vv}){}",
                if drop_view { ", no bufferView" } else { "" }
            )
        }
        9 => {
            // A primitive's indices point at its POSITION accessor, or
            // TEXCOORD_0 at an accessor of another type.
            let meshes = len_of(json, "meshes");
            if meshes == 0 {
                return "no meshes".into();
            }
            let m = rng.below(meshes);
            let Some(primitive) = json["meshes"][m]["primitives"].get_mut(0) else { return "no primitive".into() };
            if rng.one_in(2) {
                let position = primitive["attributes"]["POSITION"].clone();
                primitive["indices"] = position;
                format!("mesh {m} primitive 0: indices = its POSITION accessor")
            } else {
                primitive["attributes"]["TEXCOORD_0"] = json!(a);
                format!("mesh {m} primitive 0: TEXCOORD_0 = accessor {a}")
            }
        }
        10 => {
            let views = len_of(json, "bufferViews").max(1);
            let v = rng.below(views);
            let key = *rng.pick(&["byteLength", "byteOffset", "buffer"]);
            let value = rng
                .pick(&[json!(0), json!(1), json!(3), json!(1 << 30), json!(u32::MAX), json!(u64::MAX), json!(-1)])
                .clone();
            if let Some(view) = json["bufferViews"].get_mut(v) {
                view[key] = value.clone();
            }
            format!("bufferView {v} {key} {value}")
        }
        _ => {
            let buffers = len_of(json, "buffers").max(1);
            let b = rng.below(buffers);
            let value =
                rng.pick(&[json!(0), json!(1), json!(1 << 30), json!(u32::MAX), json!(u64::MAX), json!(-1)]).clone();
            if let Some(buffer) = json["buffers"].get_mut(b) {
                buffer["byteLength"] = value.clone();
            }
            format!("buffer {b} byteLength {value}")
        }
    }
}

/// URIs a file must never get the importer to follow (or to panic on).
/// The flag says whether the URI is a well-formed `data:` URI (which may be
/// refused for its content rather than as a URI).
const HOSTILE_URIS: &[(&str, bool)] = &[
    ("../outside/secret.bin", false),
    ("../outside/secret.png", false),
    ("../../../../../../../../../../etc/passwd", false),
    ("sub/../../outside/secret.bin", false),
    ("subdir/../../outside/secret.png", false),
    ("%2e%2e/outside/secret.bin", false),
    ("%2E%2E%2Foutside%2Fsecret.png", false),
    ("..%2foutside%2fsecret.bin", false),
    ("..\\outside\\secret.bin", false),
    ("%5c..%5coutside", false),
    ("/etc/hostname", false),
    ("/etc/passwd", false),
    ("file:///etc/passwd", false),
    ("FILE:/etc/passwd", false),
    ("/dev/zero", false),
    ("/dev/urandom", false),
    ("/proc/self/mem", false),
    ("/proc/self/environ", false),
    ("link-out.bin", false),
    ("link-out.png", false),
    ("link-zero", false),
    ("link-loop", false),
    ("fifo", false),
    ("subdir", false),
    ("subdir/", false),
    (".", false),
    ("", false),
    ("C:/Windows/win.ini", false),
    ("C:\\Windows\\win.ini", false),
    ("\\\\server\\share\\x.bin", false),
    ("//server/share/x.bin", false),
    ("http://127.0.0.1/x.bin", false),
    ("a%00.bin", false),
    ("%", false),
    ("%zz", false),
    ("%ff%fe", false),
    ("textü.bin", false),
    ("dataé.bin", false),
    ("data\u{1F600}", false),
    ("ü", false),
    ("data:", false),
    ("data:,", false),
    ("data:application/octet-stream,AAAA", false),
    ("data:application/octet-stream;base64,!!!!", false),
    ("data:;base64,A", false),
    ("data:application/octet-stream;base64,AAAA====", false),
    ("data:application/octet-stream;base64, AAAA", false),
    ("data:application/octet-stream;base64,AAAA", true),
    ("DaTa:image/png;base64,iVBORw0KGgo=", true),
];

/// Makes image `image` used: a new texture on every material, and every
/// primitive given a material.
fn use_image(json: &mut Value, image: usize) {
    let texture = len_of(json, "textures");
    array_mut(json, "textures").push(json!({"source": image}));
    if len_of(json, "materials") == 0 {
        array_mut(json, "materials").push(json!({}));
    }
    for material in array_mut(json, "materials") {
        if !material.is_object() {
            *material = json!({});
        }
        material["pbrMetallicRoughness"] = json!({"baseColorTexture": {"index": texture}});
    }
    for mesh in array_mut(json, "meshes") {
        for primitive in mesh.get_mut("primitives").and_then(Value::as_array_mut).into_iter().flatten() {
            primitive["material"] = json!(0);
        }
    }
}

fn uri_edit(rng: &mut Rng, json: &mut Value) -> (String, Expect) {
    let long_climb = "../".repeat(3000) + "etc/passwd";
    let long_name = "a/".repeat(5000) + "x.bin";
    let (uri, data_ok) = match rng.below(20) {
        0 => (long_climb.as_str(), false),
        1 => (long_name.as_str(), false),
        _ => *rng.pick(HOSTILE_URIS),
    };
    let to_image = rng.one_in(2);
    if to_image {
        let images = len_of(json, "images");
        let image = if images == 0 || rng.one_in(3) {
            array_mut(json, "images").push(json!({}));
            images
        } else {
            rng.below(images)
        };
        let entry = &mut json["images"][image];
        if let Some(object) = entry.as_object_mut() {
            object.remove("bufferView");
            object.remove("mimeType");
        }
        entry["uri"] = json!(uri);
        use_image(json, image);
        let shown = if uri.len() > 40 { format!("{}… ({} bytes)", &uri[..20], uri.len()) } else { uri.to_owned() };
        (format!("image {image} uri {shown:?}"), if data_ok { Expect::Err } else { Expect::UriErr })
    } else {
        let buffers = len_of(json, "buffers");
        if buffers == 0 {
            array_mut(json, "buffers").push(json!({"byteLength": 4}));
        }
        let b = rng.below(buffers.max(1));
        json["buffers"][b]["uri"] = json!(uri);
        let shown = if uri.len() > 40 { format!("{}… ({} bytes)", &uri[..20], uri.len()) } else { uri.to_owned() };
        (format!("buffer {b} uri {shown:?}"), if data_ok { Expect::Err } else { Expect::UriErr })
    }
}

/// A real PNG whose IHDR now claims `width` × `height` (CRC fixed).
fn png_claiming(png: &[u8], width: u32, height: u32) -> Vec<u8> {
    let mut out = png[..8].to_vec();
    let mut at = 8;
    while at + 12 <= png.len() {
        let len = u32::from_be_bytes(png[at..at + 4].try_into().unwrap()) as usize;
        let kind: [u8; 4] = png[at + 4..at + 8].try_into().unwrap();
        let Some(data) = png.get(at + 8..at + 8 + len) else { break };
        if &kind == b"IHDR" {
            let mut ihdr = data.to_vec();
            ihdr[0..4].copy_from_slice(&width.to_be_bytes());
            ihdr[4..8].copy_from_slice(&height.to_be_bytes());
            png_chunk(&mut out, &kind, &ihdr);
        } else {
            png_chunk(&mut out, &kind, data);
        }
        at += 12 + len;
    }
    out
}

/// A PNG with a header claiming `width` × `height` (RGBA8 or RGBA16) and
/// no texel data.
fn png_header_only(width: u32, height: u32, depth: u8) -> Vec<u8> {
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend(width.to_be_bytes());
    ihdr.extend(height.to_be_bytes());
    ihdr.extend([depth, 6, 0, 0, 0]);
    png_chunk(&mut out, b"IHDR", &ihdr);
    // An empty zlib stream: a decoder reads the header, then runs out of data.
    png_chunk(&mut out, b"IDAT", &[0x78, 0x01, 0x01, 0x00, 0x00, 0xFF, 0xFF, 0x00, 0x00, 0x00, 0x01]);
    png_chunk(&mut out, b"IEND", &[]);
    out
}

/// A JPEG whose SOF now claims `width` × `height`.
fn jpeg_claiming(jpeg: &[u8], width: u16, height: u16) -> Vec<u8> {
    let mut out = jpeg.to_vec();
    let mut at = 2;
    while at + 9 < out.len() {
        if out[at] == 0xFF && matches!(out[at + 1], 0xC0..=0xC2) {
            out[at + 5..at + 7].copy_from_slice(&height.to_be_bytes());
            out[at + 7..at + 9].copy_from_slice(&width.to_be_bytes());
            break;
        }
        at += 1;
    }
    out
}

struct Pictures {
    png: Vec<u8>,
    jpeg: Vec<u8>,
}

fn load_pictures() -> Pictures {
    let png = std::fs::read(assets().join("TwoSidedPlane/TwoSidedPlane_Normal.png")).unwrap();
    // The first JPEG in AlphaBlendModeTest.
    let glb = std::fs::read(assets().join("AlphaBlendModeTest/AlphaBlendModeTest.glb")).unwrap();
    let (json, bin) = split_glb(&glb);
    let json: Value = serde_json::from_slice(&json).unwrap();
    let bin = bin.unwrap();
    let image = json["images"].as_array().unwrap().iter().find(|i| i["mimeType"] == "image/jpeg").unwrap();
    let view = &json["bufferViews"][image["bufferView"].as_u64().unwrap() as usize];
    let start = view["byteOffset"].as_u64().unwrap_or(0) as usize;
    let jpeg = bin[start..start + view["byteLength"].as_u64().unwrap() as usize].to_vec();
    Pictures { png, jpeg }
}

fn image_edit(rng: &mut Rng, json: &mut Value, pictures: &Pictures) -> String {
    let (bytes, what): (Vec<u8>, String) = match rng.below(12) {
        0 => (png_claiming(&pictures.png, 100_000, 100_000), "PNG claiming 100000x100000".into()),
        1 => (png_claiming(&pictures.png, 8192, 8192), "PNG claiming 8192x8192".into()),
        2 => (png_claiming(&pictures.png, 8193, 1), "PNG claiming 8193x1".into()),
        3 => (png_claiming(&pictures.png, 0, 0), "PNG claiming 0x0".into()),
        4 => (png_header_only(8192, 8192, 16), "header-only 16-bit PNG claiming 8192x8192".into()),
        5 => (png_header_only(4096, 4096, 8), "header-only PNG claiming 4096x4096".into()),
        6 => (jpeg_claiming(&pictures.jpeg, 65535, 65535), "JPEG claiming 65535x65535".into()),
        7 => (jpeg_claiming(&pictures.jpeg, 8192, 8192), "JPEG claiming 8192x8192".into()),
        8 => {
            let cut = rng.below(pictures.png.len());
            (pictures.png[..cut].to_vec(), format!("PNG cut at {cut}"))
        }
        9 => {
            let mut jpeg = pictures.jpeg.clone();
            for _ in 0..1 + rng.below(8) {
                let i = rng.below(jpeg.len());
                jpeg[i] ^= 1 << rng.below(8);
            }
            (jpeg, "JPEG with flipped bits".into())
        }
        10 => (b"GIF89a\x01\x00\x01\x00\x00\x00\x00;".to_vec(), "a GIF".into()),
        _ => ((0..64).map(|_| rng.next_u64() as u8).collect(), "64 random bytes".into()),
    };
    let images = len_of(json, "images");
    let image = if images == 0 { 0 } else { rng.below(images) };
    if images == 0 {
        array_mut(json, "images").push(json!({}));
    }
    json["images"][image] = json!({"uri": data_uri("image/png", &bytes)});
    use_image(json, image);
    format!("image {image} is a {what}")
}

fn flip_bytes(rng: &mut Rng, bytes: &mut [u8], range: std::ops::Range<usize>) -> usize {
    if range.is_empty() {
        return 0;
    }
    let flips = if rng.one_in(8) { 64 } else { 1 + rng.below(8) };
    for _ in 0..flips {
        let i = range.start + rng.below(range.len());
        bytes[i] = match rng.below(4) {
            0 => bytes[i] ^ (1 << rng.below(8)),
            1 => rng.next_u64() as u8,
            2 => *rng.pick(&[0u8, 0xFF, b'"', b'{', b'}', b'[', b']', b',', b':', b'\\', b'9', b'-']),
            _ => bytes[i].wrapping_add(1),
        };
    }
    flips
}

/// The byte range of a GLB's JSON and binary chunk contents.
fn glb_ranges(bytes: &[u8]) -> (std::ops::Range<usize>, std::ops::Range<usize>) {
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json = 20..20 + json_len;
    let bin = if json.end + 8 <= bytes.len() { json.end + 8..bytes.len() } else { bytes.len()..bytes.len() };
    (json, bin)
}

/// Serializes a mutated JSON document in the seed's form. A GLB's lengths are
/// recomputed, except (one time in four) where the old header and JSON chunk
/// length are kept, which makes them disagree with the content.
fn serialize(rng: &mut Rng, seed: &Seed, json_text: Vec<u8>, what: &mut String) -> Vec<u8> {
    if seed.form != SeedForm::Glb {
        return json_text;
    }
    let mut glb = make_glb(&json_text, seed.bin.as_deref());
    if rng.one_in(4) {
        glb[8..16].copy_from_slice(&seed.bytes[8..16]);
        what.push_str(" (GLB lengths left stale)");
    }
    glb
}

fn make_mutant(seeds: &[Seed], pictures: &Pictures, corpus_seed: u64, index: usize) -> Mutant {
    let mut rng = case_rng(corpus_seed, index);
    // The first mutants are the seeds themselves, which must import.
    if index < seeds.len() {
        let seed = &seeds[index];
        return Mutant {
            index,
            seed: index,
            kind: Kind::Unmutated,
            what: "unmutated".into(),
            bytes: seed.bytes.clone(),
            from_folder: true,
            from_memory: seed.form != SeedForm::External,
            expect: Expect::Ok,
        };
    }
    // AlphaBlendModeTest (3 MB of pictures) is picked half as often.
    let seed_index = loop {
        let i = rng.below(seeds.len());
        if seeds[i].bytes.len() < 1 << 20 || rng.one_in(2) {
            break i;
        }
    };
    let seed = &seeds[seed_index];
    let glb = seed.form == SeedForm::Glb;
    let kind = *rng.pick(&[
        Kind::Truncate,
        Kind::Truncate,
        Kind::FlipJsonBytes,
        Kind::FlipJsonBytes,
        Kind::FlipBinBytes,
        Kind::FlipBinBytes,
        Kind::GlbHeader,
        Kind::JsonValue,
        Kind::JsonValue,
        Kind::JsonValue,
        Kind::JsonValue,
        Kind::RawToken,
        Kind::DeleteKey,
        Kind::DeleteKey,
        Kind::Accessor,
        Kind::Accessor,
        Kind::Accessor,
        Kind::Graph,
        Kind::Graph,
        Kind::Uri,
        Kind::Uri,
        Kind::Image,
    ]);
    let kind = match kind {
        Kind::GlbHeader if !glb => Kind::FlipJsonBytes,
        Kind::FlipBinBytes if seed.form == SeedForm::External => Kind::FlipJsonBytes,
        k => k,
    };
    let mut expect = Expect::Anything;
    let mut json = seed.json.clone();
    let mut what = String::new();
    let bytes = match kind {
        Kind::Unmutated => unreachable!(),
        Kind::Truncate => {
            let len = seed.bytes.len();
            let cut = match rng.below(4) {
                0 if glb => rng.below(28.min(len)),
                1 if glb => {
                    let (json_range, _) = glb_ranges(&seed.bytes);
                    (json_range.end + rng.below(12)).min(len - 1)
                }
                _ => rng.below(len),
            };
            what = format!("cut to {cut} of {len} bytes");
            seed.bytes[..cut].to_vec()
        }
        Kind::FlipJsonBytes => {
            let mut bytes = seed.bytes.clone();
            let range = if glb { glb_ranges(&bytes).0 } else { 0..bytes.len() };
            let flips = flip_bytes(&mut rng, &mut bytes, range);
            what = format!("{flips} JSON bytes changed");
            bytes
        }
        Kind::FlipBinBytes if glb => {
            let mut bytes = seed.bytes.clone();
            let range = glb_ranges(&bytes).1;
            let flips = flip_bytes(&mut rng, &mut bytes, range);
            what = format!("{flips} binary-chunk bytes changed");
            bytes
        }
        Kind::FlipBinBytes => {
            // Flip bytes inside a decoded data: URI and encode it again.
            let mut uris: Vec<Vec<Step>> = Vec::new();
            for list in ["buffers", "images"] {
                for i in 0..len_of(&json, list) {
                    uris.push(vec![Step::Key(list.into()), Step::At(i), Step::Key("uri".into())]);
                }
            }
            let path = rng.pick(&uris).clone();
            let uri = at_path(&mut json, &path).unwrap();
            let text = uri.as_str().unwrap().to_owned();
            let (header, payload) = text.split_once(',').unwrap();
            let mut data = base64_decode(payload);
            let range = 0..data.len();
            let flips = flip_bytes(&mut rng, &mut data, range);
            *uri = json!(format!("{header},{}", base64_encode(&data)));
            what = format!("{flips} bytes changed in {}", show_path(&path));
            serde_json::to_vec(&json).unwrap()
        }
        Kind::GlbHeader => {
            let mut bytes = seed.bytes.clone();
            let (json_range, bin_range) = glb_ranges(&bytes);
            let field = *rng.pick(&[0usize, 4, 8, 12, 16, json_range.end, json_range.end + 4]);
            let field =
                if field + 4 > bytes.len() || (field >= json_range.end && bin_range.is_empty()) { 8 } else { field };
            let value = *rng.pick(&[0u32, 1, 3, 11, 12, 20, u32::MAX, u32::MAX - 7, 0x7FFF_FFFF]);
            let value = if rng.one_in(2) {
                u32::from_le_bytes(bytes[field..field + 4].try_into().unwrap())
                    .wrapping_add(rng.below(9) as u32)
                    .wrapping_sub(4)
            } else {
                value
            };
            bytes[field..field + 4].copy_from_slice(&value.to_le_bytes());
            what = format!("GLB word at {field} set to {value}");
            bytes
        }
        Kind::JsonValue | Kind::DeleteKey | Kind::Accessor => {
            let edits = 1 + rng.below(3);
            for _ in 0..edits {
                let done = match kind {
                    Kind::JsonValue => {
                        let path = random_path(&mut rng, &json);
                        let slot = at_path(&mut json, &path).unwrap();
                        let (value, shown) = edge_value(&mut rng, Some(slot));
                        *slot = value;
                        format!("{} = {shown}", show_path(&path))
                    }
                    Kind::DeleteKey => {
                        let path = random_path(&mut rng, &json);
                        let parent = &path[..path.len().saturating_sub(1)];
                        match (path.last(), at_path(&mut json, parent)) {
                            (Some(Step::Key(k)), Some(Value::Object(map))) => {
                                map.remove(k);
                                format!("{} deleted", show_path(&path))
                            }
                            (Some(Step::At(i)), Some(Value::Array(items))) => {
                                items.remove(*i);
                                format!("{} removed", show_path(&path))
                            }
                            _ => "nothing deleted".into(),
                        }
                    }
                    _ => accessor_edit(&mut rng, &mut json),
                };
                if !what.is_empty() {
                    what.push_str("; ");
                }
                what.push_str(&done);
            }
            let text = serde_json::to_vec(&json).unwrap();
            serialize(&mut rng, seed, text, &mut what)
        }
        Kind::RawToken => {
            let path = random_path(&mut rng, &json);
            let token = *rng.pick(RAW_TOKENS);
            *at_path(&mut json, &path).unwrap() = json!("@@RAW@@");
            let text = serde_json::to_string(&json).unwrap().replacen("\"@@RAW@@\"", token, 1);
            what = format!("{} = {token}", show_path(&path));
            serialize(&mut rng, seed, text.into_bytes(), &mut what)
        }
        Kind::Graph => {
            what = graph_edit(&mut rng, &mut json);
            let text = serde_json::to_vec(&json).unwrap();
            serialize(&mut rng, seed, text, &mut what)
        }
        Kind::Uri => {
            let (done, must) = uri_edit(&mut rng, &mut json);
            what = done;
            expect = must;
            let text = serde_json::to_vec(&json).unwrap();
            let bytes = make_glb_if(seed, text);
            return Mutant {
                index,
                seed: seed_index,
                kind,
                what,
                bytes,
                from_folder: true,
                from_memory: seed.form != SeedForm::External,
                expect,
            };
        }
        Kind::Image => {
            what = image_edit(&mut rng, &mut json, pictures);
            let text = serde_json::to_vec(&json).unwrap();
            serialize(&mut rng, seed, text, &mut what)
        }
    };
    let external = seed.form == SeedForm::External;
    Mutant {
        index,
        seed: seed_index,
        kind,
        what,
        bytes,
        // One mutant in eight (and every external seed's) also from a folder.
        from_folder: external || rng.one_in(8),
        from_memory: !external,
        expect,
    }
}

/// A GLB seed's JSON packed again with consistent lengths.
fn make_glb_if(seed: &Seed, json_text: Vec<u8>) -> Vec<u8> {
    if seed.form == SeedForm::Glb { make_glb(&json_text, seed.bin.as_deref()) } else { json_text }
}

// ---------------------------------------------------------------------------
// Running a mutant.

/// Panics seen by the hook, with the thread (case) they happened on.
static PANICS: Mutex<Vec<String>> = Mutex::new(Vec::new());

fn install_counting_panic_hook() {
    std::panic::set_hook(Box::new(|info| {
        let thread = std::thread::current().name().unwrap_or("?").to_owned();
        PANICS.lock().unwrap_or_else(|e| e.into_inner()).push(format!("{thread}: {info}"));
    }));
}

fn variant(e: &GltfError) -> &'static str {
    match e {
        GltfError::Load { .. } => "Load",
        GltfError::Parse { .. } => "Parse",
        GltfError::Limit { .. } => "Limit",
        GltfError::Uri { .. } => "Uri",
        GltfError::Graph { .. } => "Graph",
        GltfError::Mesh { .. } => "Mesh",
        GltfError::UnsupportedExtension { .. } => "UnsupportedExtension",
        GltfError::NoSuchScene { .. } => "NoSuchScene",
        GltfError::Invalid { .. } => "Invalid",
    }
}

/// What one import did.
struct Outcome {
    /// `Ok`, an error variant's name, or "panic".
    result: &'static str,
    message: String,
    elapsed: Duration,
    peak_bytes: usize,
}

fn corpus_options() -> ImportOptions {
    ImportOptions { limits: corpus_limits(), ..ImportOptions::default() }
}

/// Imports `bytes` (from memory, or written into `folder`) on a thread named
/// after the case; `None` if it did not come back in time.
fn run_import(label: &str, bytes: Vec<u8>, folder: Option<PathBuf>) -> Option<Outcome> {
    let (send, receive) = std::sync::mpsc::channel();
    let path =
        folder.as_ref().map(|f| f.join(format!("mutant.{}", if bytes.starts_with(b"glTF") { "glb" } else { "gltf" })));
    if let Some(path) = &path {
        std::fs::write(path, &bytes).unwrap();
    }
    let worker = std::thread::Builder::new().name(label.to_owned()).spawn(move || {
        let options = corpus_options();
        let baseline = start_measuring();
        let started = Instant::now();
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let mut scene = Scene::new();
            let result = match &path {
                Some(path) => import_gltf_with(&mut scene, path, &options),
                None => import_gltf_slice(&mut scene, &bytes, "mutant", &options),
            };
            result.map(|import| (import.renderables, import.bytes_decoded))
        }));
        let elapsed = started.elapsed();
        let peak_bytes = peak_since(baseline);
        let (result, message) = match result {
            Ok(Ok((renderables, bytes))) => ("Ok", format!("{renderables} renderables, {bytes} bytes decoded")),
            Ok(Err(e)) => (variant(&e), e.to_string()),
            Err(panic) => (
                "panic",
                panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| (*s).to_owned()))
                    .unwrap_or_default(),
            ),
        };
        let _ = send.send(Outcome { result, message, elapsed, peak_bytes });
    });
    let worker = worker.expect("spawn an import thread");
    match receive.recv_timeout(TIME_BUDGET * 10) {
        Ok(outcome) => {
            worker.join().unwrap();
            Some(outcome)
        }
        Err(_) => None,
    }
}

#[derive(Default)]
struct Summary {
    imports: usize,
    by_result: BTreeMap<&'static str, usize>,
    by_kind: BTreeMap<String, BTreeMap<&'static str, usize>>,
    slowest: (Duration, String),
    heaviest: (usize, String),
    failures: Vec<String>,
}

fn run_mutant(seeds: &[Seed], mutant: &Mutant, summary: &mut Summary, verbose: bool) {
    let seed = &seeds[mutant.seed];
    let describe = || format!("case {} ({:?} of {}: {})", mutant.index, mutant.kind, seed.name, mutant.what);
    let mut routes: Vec<(&str, Option<PathBuf>)> = Vec::new();
    if mutant.from_memory {
        routes.push(("memory", None));
    }
    if mutant.from_folder {
        routes.push(("folder", Some(seed.folder.join("scene"))));
    }
    for (route, folder) in routes {
        let label = format!("case {} {:?} {route}", mutant.index, mutant.kind);
        let Some(outcome) = run_import(&label, mutant.bytes.clone(), folder) else {
            summary.failures.push(format!("{} from {route}: no answer in {:?} (hang)", describe(), TIME_BUDGET * 10));
            return;
        };
        summary.imports += 1;
        *summary.by_result.entry(outcome.result).or_default() += 1;
        *summary.by_kind.entry(format!("{:?}", mutant.kind)).or_default().entry(outcome.result).or_default() += 1;
        if outcome.elapsed > summary.slowest.0 {
            summary.slowest = (outcome.elapsed, format!("{} from {route}", describe()));
        }
        if outcome.peak_bytes > summary.heaviest.0 {
            summary.heaviest = (outcome.peak_bytes, format!("{} from {route}", describe()));
        }
        if verbose {
            println!(
                "{} from {route}: {} in {:?}, peak {} KiB: {}",
                describe(),
                outcome.result,
                outcome.elapsed,
                outcome.peak_bytes >> 10,
                outcome.message
            );
        }
        let mut fail = |why: String| summary.failures.push(format!("{} from {route}: {why}", describe()));
        if outcome.result == "panic" {
            fail(format!("panicked: {}", outcome.message));
        }
        if outcome.elapsed > TIME_BUDGET {
            fail(format!("took {:?} (budget {TIME_BUDGET:?})", outcome.elapsed));
        }
        if outcome.peak_bytes > MEMORY_BUDGET {
            fail(format!("peak heap {} MiB (budget {} MiB)", outcome.peak_bytes >> 20, MEMORY_BUDGET >> 20));
        }
        let expected = match mutant.expect {
            Expect::Anything => true,
            Expect::Ok => outcome.result == "Ok",
            Expect::Err => outcome.result != "Ok",
            Expect::UriErr => outcome.result == "Uri",
        };
        if !expected {
            fail(format!("expected {:?}, got {}: {}", mutant.expect, outcome.result, outcome.message));
        }
    }
}

fn env_number(name: &str) -> Option<u64> {
    let text = std::env::var(name).ok()?;
    let text = text.trim();
    Some(match text.strip_prefix("0x") {
        Some(hex) => u64::from_str_radix(hex, 16).unwrap_or_else(|_| panic!("{name}={text} is not a number")),
        None => text.parse().unwrap_or_else(|_| panic!("{name}={text} is not a number")),
    })
}

#[test]
fn every_mutant_of_the_shipped_scenes_ends_in_ok_or_a_clear_error_within_time_and_memory_budgets() {
    let started = Instant::now();
    let seeds = load_seeds();
    let pictures = load_pictures();
    let corpus_seed = env_number("OXYGEN_FUZZ_SEED").unwrap_or(CORPUS_SEED);
    let size = env_number("OXYGEN_FUZZ_CASES").map_or(CORPUS_SIZE, |n| n as usize);
    let only = env_number("OXYGEN_FUZZ_CASE").map(|n| n as usize);
    let verbose = only.is_some() || std::env::var_os("OXYGEN_FUZZ_VERBOSE").is_some();
    install_counting_panic_hook();
    let mut summary = Summary::default();
    let cases: Vec<usize> = match only {
        Some(case) => vec![case],
        None => (0..size).collect(),
    };
    for &index in &cases {
        let mutant = make_mutant(&seeds, &pictures, corpus_seed, index);
        if only.is_some() {
            let path = work_dir()
                .join(format!("case-{index}.{}", if mutant.bytes.starts_with(b"glTF") { "glb" } else { "gltf" }));
            std::fs::write(&path, &mutant.bytes).unwrap();
            println!(
                "case {index}: {:?} of {}: {} ({} bytes, written to {})",
                mutant.kind,
                seeds[mutant.seed].name,
                mutant.what,
                mutant.bytes.len(),
                path.display()
            );
        }
        run_mutant(&seeds, &mutant, &mut summary, verbose);
    }
    let _ = std::panic::take_hook();
    let panics = std::mem::take(&mut *PANICS.lock().unwrap());

    let mut report = String::new();
    writeln!(
        report,
        "glTF fuzz corpus: seed {corpus_seed:#x}, {} mutants of {} seeds, {} imports in {:.1?}",
        cases.len(),
        seeds.len(),
        summary.imports,
        started.elapsed()
    )
    .unwrap();
    writeln!(report, "  outcomes: {:?}", summary.by_result).unwrap();
    for (kind, results) in &summary.by_kind {
        writeln!(report, "  {kind:>14}: {results:?}").unwrap();
    }
    writeln!(report, "  slowest: {:.1?} for {}", summary.slowest.0, summary.slowest.1).unwrap();
    writeln!(report, "  peak heap: {:.1} MiB for {}", summary.heaviest.0 as f64 / (1 << 20) as f64, summary.heaviest.1)
        .unwrap();
    println!("{report}");
    for p in &panics {
        println!("panic hook: {p}");
    }
    for f in &summary.failures {
        println!("FAILED {f}");
    }
    assert!(panics.is_empty(), "{} panics (reproduce with OXYGEN_FUZZ_CASE=N):\n{}", panics.len(), panics.join("\n"));
    assert!(
        summary.failures.is_empty(),
        "{} failures (reproduce with OXYGEN_FUZZ_CASE=N):\n{}",
        summary.failures.len(),
        summary.failures.join("\n")
    );
    // The run's figures (docs/security.md quotes them), when recording.
    let elapsed = started.elapsed();
    support::record::write_cpu(|record| {
        let outcomes =
            summary.by_result.iter().fold(Row::new(), |row, (result, count)| row.value(result, *count as u64));
        record
            .value("corpus_seed", corpus_seed)
            .value("mutants", cases.len() as u64)
            .value("seeds", seeds.len() as u64)
            .value("imports", summary.imports as u64)
            .value("seconds", elapsed.as_secs_f64())
            .value("slowest_import_seconds", summary.slowest.0.as_secs_f64())
            .value("peak_heap_mib", summary.heaviest.0 as f64 / (1 << 20) as f64)
            .value("panics", panics.len() as u64)
            .value("failures", summary.failures.len() as u64)
            .value("outcomes", outcomes)
    });
}
