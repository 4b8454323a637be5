//! glTF files written by someone else (issue 10): every hostile construct
//! ends in an error that names the part at fault, never in a crash, a hang,
//! a read outside the scene's folder or an unbounded allocation.
//!
//! Each test builds the smallest file that shows one behaviour: a one-
//! triangle document ([`triangle`]) edited in a line or two, imported from
//! memory ([`import_memory`]) or from a scratch folder ([`Folder`]).

mod support;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use oxygen::core::Scene;
use oxygen::import::{
    GltfError, GltfImport, GraphError, ImportLimits, ImportOptions, LimitExceeded, UriError, import_gltf_slice,
    import_gltf_with,
};
use serde_json::{Value, json};
use support::encode::{data_uri, png_chunk};

/// "At once" for work that is refused before it starts: doing it instead
/// (decoding 10^10 texels, walking 2^40 paths, building 16 Mi vertices in a
/// debug build) takes far longer. Generous, for a loaded machine.
const QUICKLY: Duration = Duration::from_secs(2);

/// The wait after which an import is taken to be blocked (on a FIFO, a
/// device): such a wait never ends.
const NEVER_BLOCKS: Duration = Duration::from_secs(10);

// ---------------------------------------------------------------------------
// The one-triangle document and ways to import it.

/// Positions (3 × vec3 f32 at 0), u16 indices (at 36), texture coordinates
/// (3 × vec2 f32 at 44) and u32 indices (at 68).
fn triangle_bin() -> Vec<u8> {
    let mut bin = Vec::new();
    for v in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        bin.extend(v.iter().flat_map(|c| c.to_le_bytes()));
    }
    bin.extend([0u16, 1, 2].iter().flat_map(|i| i.to_le_bytes()));
    bin.extend([0, 0]);
    for uv in [[0f32, 0.0], [1.0, 0.0], [0.0, 1.0]] {
        bin.extend(uv.iter().flat_map(|c| c.to_le_bytes()));
    }
    bin.extend([0u32, 1, 2].iter().flat_map(|i| i.to_le_bytes()));
    bin
}

/// A glTF with one node drawing one indexed, textured-coordinate triangle
/// from buffer 0 at `buffer_uri`. Accessors: 0 POSITION, 1 u16 indices,
/// 2 TEXCOORD_0, 3 u32 indices.
fn triangle(buffer_uri: &str) -> Value {
    json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 2}, "indices": 1}]}],
        "buffers": [{"byteLength": 80, "uri": buffer_uri}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 6},
            {"buffer": 0, "byteOffset": 44, "byteLength": 24},
            {"buffer": 0, "byteOffset": 68, "byteLength": 12}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"},
            {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5125, "count": 3, "type": "SCALAR"}
        ]
    })
}

/// The triangle with its buffer as a `data:` URI: importable from memory.
fn embedded_triangle() -> Value {
    triangle(&data_uri("application/octet-stream", &triangle_bin()))
}

/// Gives the triangle a material whose base colour is image 0 at `uri`.
fn with_image(mut gltf: Value, uri: &str) -> Value {
    gltf["images"] = json!([{"uri": uri}]);
    gltf["textures"] = json!([{"source": 0}]);
    gltf["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    gltf["meshes"][0]["primitives"][0]["material"] = json!(0);
    gltf
}

fn options(limits: ImportLimits) -> ImportOptions {
    ImportOptions { limits, ..ImportOptions::default() }
}

/// Imports a document from memory with `limits`.
fn import_memory_with(gltf: &Value, limits: ImportLimits) -> Result<(GltfImport, Scene), GltfError> {
    let mut scene = Scene::new();
    let bytes = serde_json::to_vec(gltf).unwrap();
    import_gltf_slice(&mut scene, &bytes, "untrusted.gltf", &options(limits)).map(|i| (i, scene))
}

/// Imports a document from memory with the default limits.
fn import_memory(gltf: &Value) -> Result<(GltfImport, Scene), GltfError> {
    import_memory_with(gltf, ImportLimits::default())
}

/// A scratch folder `target/tmp/gltf_untrusted/<name>/`, emptied, holding a
/// `scene/` folder (the scene's own, with `triangle.bin` and
/// `picture.png`) and an `outside/` sibling holding the same files: a URI
/// that reaches them has escaped.
struct Folder {
    root: PathBuf,
}

impl Folder {
    fn new(name: &str) -> Self {
        let root = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("gltf_untrusted").join(name);
        let _ = std::fs::remove_dir_all(&root);
        for dir in ["scene", "outside"] {
            std::fs::create_dir_all(root.join(dir)).unwrap();
            std::fs::write(root.join(dir).join("triangle.bin"), triangle_bin()).unwrap();
            std::fs::write(root.join(dir).join("picture.png"), picture()).unwrap();
        }
        Folder { root }
    }

    fn scene(&self) -> PathBuf {
        self.root.join("scene")
    }

    /// Writes `gltf` as `scene/scene.gltf` and imports it.
    fn import_with(&self, gltf: &Value, options: &ImportOptions) -> Result<(GltfImport, Scene), GltfError> {
        let path = self.scene().join("scene.gltf");
        std::fs::write(&path, serde_json::to_vec(gltf).unwrap()).unwrap();
        let mut scene = Scene::new();
        import_gltf_with(&mut scene, &path, options).map(|i| (i, scene))
    }

    fn import(&self, gltf: &Value) -> Result<(GltfImport, Scene), GltfError> {
        self.import_with(gltf, &ImportOptions::default())
    }
}

/// Runs `f` on its own thread and fails the test if it has not returned
/// within `limit` (a blocked `open` or read cannot hang the suite).
fn within<T: Send + 'static>(limit: Duration, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (send, receive) = std::sync::mpsc::channel();
    let started = Instant::now();
    std::thread::spawn(move || {
        let _ = send.send(f());
    });
    let value = receive.recv_timeout(limit).unwrap_or_else(|_| panic!("did not return within {limit:?}"));
    assert!(started.elapsed() < limit, "took {:?}", started.elapsed());
    value
}

// ---------------------------------------------------------------------------
// Small encoders.

/// A real 256 × 256 PNG from the shipped assets.
fn picture() -> Vec<u8> {
    let assets = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets");
    std::fs::read(assets.join("TwoSidedPlane/TwoSidedPlane_BaseColor.png")).unwrap()
}

/// A PNG of a signature, an IHDR claiming `width` × `height` RGBA8
/// texels, an empty IDAT and an IEND: under 80 bytes.
fn png_header_claiming(width: u32, height: u32) -> Vec<u8> {
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend(width.to_be_bytes());
    ihdr.extend(height.to_be_bytes());
    ihdr.extend([8, 6, 0, 0, 0]);
    png_chunk(&mut png, b"IHDR", &ihdr);
    // An empty zlib stream: a decoder reads the header, then runs out of data.
    png_chunk(&mut png, b"IDAT", &[0x78, 0x01, 0x01, 0x00, 0x00, 0xFF, 0xFF, 0x00, 0x00, 0x00, 0x01]);
    png_chunk(&mut png, b"IEND", &[]);
    png
}

// ---------------------------------------------------------------------------
// Assertions.

/// A URI error for `uri`, whose message names it.
fn assert_uri_refused(result: Result<(GltfImport, Scene), GltfError>, uri: &str) -> UriError {
    match result {
        Err(GltfError::Uri { uri: named, source, .. }) => {
            assert!(uri.starts_with(named.split('…').next().unwrap()), "error names '{named}', not '{uri}'");
            source
        }
        Err(other) => panic!("'{uri}': expected a URI error, got {other}"),
        Ok(_) => panic!("'{uri}' was followed"),
    }
}

/// The error of an import that must fail.
fn refused(result: Result<(GltfImport, Scene), GltfError>) -> GltfError {
    match result {
        Err(err) => err,
        Ok((import, _)) => panic!("imported ({} renderables)", import.renderables),
    }
}

/// The error's message with `uri` replaced: what a file learns from it.
fn message_without(err: &GltfError, uri: &str) -> String {
    err.to_string().replace(uri, "<uri>")
}

/// A [`GltfError::Limit`] on `limit` for `value`, whose message names both.
fn assert_limit(result: Result<(GltfImport, Scene), GltfError>, limit: &str, value: u64) {
    match result {
        Err(err @ GltfError::Limit { source: LimitExceeded { limit: l, value: v, .. }, .. }) => {
            assert_eq!((l, v), (limit, value), "{err}");
            let text = err.to_string();
            assert!(text.contains(limit) && text.contains(&value.to_string()), "{text}");
        }
        Err(other) => panic!("expected the {limit} limit, got {other}"),
        Ok(_) => panic!("expected the {limit} limit, got Ok"),
    }
}

/// A [`GltfError::Mesh`] naming mesh 0, primitive 0 and `accessor`.
fn assert_mesh_error(result: Result<(GltfImport, Scene), GltfError>, accessor: usize) -> String {
    match result {
        Err(err @ GltfError::Mesh { .. }) => {
            let GltfError::Mesh { source, .. } = &err else { unreachable!() };
            assert_eq!((source.mesh, source.primitive, source.accessor), (0, 0, Some(accessor)), "{err}");
            let text = err.to_string();
            for part in ["mesh 0", "primitive 0", &format!("accessor {accessor}")] {
                assert!(text.contains(part), "'{text}' does not name {part}");
            }
            text
        }
        Err(other) => panic!("expected a mesh error, got {other}"),
        Ok(_) => panic!("expected a mesh error, got Ok"),
    }
}

// ---------------------------------------------------------------------------
// URIs: nothing outside the scene's folder is ever read.

/// Every way of writing "outside this folder" that the importer must see
/// through.
const ESCAPES: &[&str] = &[
    "../../../etc/passwd",
    "../../../../../../../../../../../../../../etc/passwd",
    "/etc/hostname",
    "/etc/passwd",
    "file:///etc/passwd",
    "FILE:/etc/passwd",
    "%2e%2e/%2e%2e/%2e%2e/%2e%2e/%2e%2e/%2e%2e/%2e%2e/%2e%2e/etc/passwd",
    "%2E%2E%2Foutside%2Ftriangle.bin",
    "..%2f..%2f..%2f..%2f..%2f..%2f..%2f..%2fetc%2fpasswd",
    "..%2foutside/triangle.bin",
    "..\\..\\..\\etc\\passwd",
    "..\\outside\\triangle.bin",
    "..%5coutside%5ctriangle.bin",
    "../outside/triangle.bin",
    "./../outside/triangle.bin",
    "sub/../../outside/triangle.bin",
];

#[test]
fn buffer_uris_leaving_the_folder_are_refused_in_every_spelling_with_an_error_naming_the_uri() {
    let folder = Folder::new("buffer_escapes");
    for uri in ESCAPES {
        assert_uri_refused(folder.import(&triangle(uri)), uri);
    }
}

#[test]
fn image_uris_leaving_the_folder_are_refused_in_every_spelling_with_an_error_naming_the_uri() {
    let folder = Folder::new("image_escapes");
    for uri in ESCAPES {
        let escape = uri.replace("triangle.bin", "picture.png");
        assert_uri_refused(folder.import(&with_image(triangle("triangle.bin"), &escape)), &escape);
    }
}

#[test]
fn a_target_outside_the_folder_gets_the_same_error_whether_it_exists_or_not() {
    let folder = Folder::new("same_error");
    for (exists, missing) in [
        ("../outside/triangle.bin", "../outside/missing.bin"),
        ("../../../../../../../../../../../etc/passwd", "../../../../../../../../../../../etc/no-such-file"),
        ("/etc/passwd", "/etc/no-such-file"),
        ("%2e%2e/outside/triangle.bin", "%2e%2e/outside/missing.bin"),
    ] {
        let a = refused(folder.import(&triangle(exists)));
        let b = refused(folder.import(&triangle(missing)));
        assert_eq!(message_without(&a, exists), message_without(&b, missing));
    }
    // Inside the folder, a missing file reads the same as an escape.
    let inside = refused(folder.import(&triangle("missing.bin")));
    let outside = refused(folder.import(&triangle("../outside/triangle.bin")));
    assert_eq!(message_without(&inside, "missing.bin"), message_without(&outside, "../outside/triangle.bin"));
}

#[test]
fn an_existing_picture_in_a_sibling_folder_is_refused_not_rendered() {
    let folder = Folder::new("sibling_picture");
    std::fs::create_dir_all(folder.root.join("other")).unwrap();
    std::fs::write(folder.root.join("other/picture.png"), picture()).unwrap();
    let uri = "../other/picture.png";
    assert_uri_refused(folder.import(&with_image(triangle("triangle.bin"), uri)), uri);
    // The same picture beside the scene is imported: the refusal is about where.
    let (import, _) = folder.import(&with_image(triangle("triangle.bin"), "picture.png")).unwrap();
    assert_eq!(import.renderables, 1);
}

#[test]
fn a_symlink_inside_the_folder_pointing_outside_is_refused() {
    let folder = Folder::new("symlink_out");
    std::os::unix::fs::symlink("../outside/triangle.bin", folder.scene().join("link.bin")).unwrap();
    std::os::unix::fs::symlink("../outside/picture.png", folder.scene().join("link.png")).unwrap();
    assert_uri_refused(folder.import(&triangle("link.bin")), "link.bin");
    assert_uri_refused(folder.import(&with_image(triangle("triangle.bin"), "link.png")), "link.png");
}

#[test]
fn a_symlink_that_stays_inside_the_folder_is_followed() {
    let folder = Folder::new("symlink_in");
    std::os::unix::fs::symlink("triangle.bin", folder.scene().join("alias.bin")).unwrap();
    folder.import(&triangle("alias.bin")).unwrap();
}

#[test]
fn dev_zero_as_a_buffer_or_image_uri_is_refused_at_once() {
    let folder = Folder::new("dev_zero");
    std::os::unix::fs::symlink("/dev/zero", folder.scene().join("zero")).unwrap();
    let scene = folder.scene();
    within(NEVER_BLOCKS, move || {
        let folder = Folder { root: scene.parent().unwrap().to_owned() };
        for uri in ["/dev/zero", "zero", "../../../../../../../../../../../../dev/zero", "file:///dev/zero"] {
            assert_uri_refused(folder.import(&triangle(uri)), uri);
            assert_uri_refused(folder.import(&with_image(triangle("triangle.bin"), uri)), uri);
        }
        // Even a root wide enough to hold /dev/zero reads only regular files.
        let everything = ImportOptions { asset_root: Some(PathBuf::from("/")), ..ImportOptions::default() };
        let uri = "../".repeat(30) + "dev/zero";
        assert_uri_refused(folder.import_with(&triangle(&uri), &everything), &uri);
        assert_uri_refused(folder.import_with(&with_image(triangle("triangle.bin"), &uri), &everything), &uri);
        folder.import_with(&triangle("triangle.bin"), &everything).unwrap();
    });
}

#[test]
fn a_fifo_inside_the_folder_is_refused_without_blocking() {
    let folder = Folder::new("fifo");
    let status = std::process::Command::new("mkfifo").arg(folder.scene().join("pipe")).status().unwrap();
    assert!(status.success(), "mkfifo failed");
    let root = folder.root.clone();
    within(NEVER_BLOCKS, move || {
        let folder = Folder { root };
        assert_uri_refused(folder.import(&triangle("pipe")), "pipe");
        assert_uri_refused(folder.import(&with_image(triangle("triangle.bin"), "pipe")), "pipe");
    });
}

#[test]
fn a_file_imported_from_memory_reads_no_file_at_all() {
    for uri in ["triangle.bin", "../outside/triangle.bin", "/etc/passwd"] {
        let source = assert_uri_refused(import_memory(&triangle(uri)), uri);
        assert_eq!(source, UriError::NoFolder);
    }
}

#[test]
fn asset_root_lets_a_scene_read_its_neighbours_textures_but_nothing_outside_the_root() {
    let folder = Folder::new("asset_root");
    let root = folder.root.join("root");
    std::fs::create_dir_all(root.join("scenes")).unwrap();
    std::fs::create_dir_all(root.join("textures")).unwrap();
    std::fs::write(root.join("scenes/triangle.bin"), triangle_bin()).unwrap();
    std::fs::write(root.join("textures/x.png"), picture()).unwrap();
    let path = root.join("scenes/scene.gltf");
    let import = |uri: &str, asset_root: Option<&Path>| {
        let gltf = with_image(triangle("triangle.bin"), uri);
        std::fs::write(&path, serde_json::to_vec(&gltf).unwrap()).unwrap();
        let options = ImportOptions { asset_root: asset_root.map(Path::to_path_buf), ..ImportOptions::default() };
        let mut scene = Scene::new();
        import_gltf_with(&mut scene, &path, &options).map(|i| (i, scene))
    };
    let (_, scene) = import("../textures/x.png", Some(&root)).unwrap();
    assert!(scene.materials().any(|(_, m)| m.base_color_texture.is_some()));
    // Without the wider root, the scene's own folder is the limit.
    assert_uri_refused(import("../textures/x.png", None), "../textures/x.png");
    // And the wider root is a limit too.
    for uri in ["../../outside/picture.png", "../../../../../../../../../../../etc/passwd", "/etc/passwd"] {
        assert_uri_refused(import(uri, Some(&root)), uri);
    }
}

#[test]
fn data_uris_with_bad_base64_are_refused_for_buffers_and_images() {
    for payload in ["!!!!", "A", "AAAA===", "AA AA", "AAAA\n", "QUJD\u{e9}"] {
        let uri = format!("data:application/octet-stream;base64,{payload}");
        let source = assert_uri_refused(import_memory(&triangle(&uri)), &uri);
        assert!(matches!(source, UriError::Malformed(_)), "{payload:?}: {source}");
        let image = format!("data:image/png;base64,{payload}");
        let source = assert_uri_refused(import_memory(&with_image(embedded_triangle(), &image)), &image);
        assert!(matches!(source, UriError::Malformed(_)), "{payload:?}: {source}");
    }
    let plain = "data:application/octet-stream,AAAA";
    assert_uri_refused(import_memory(&triangle(plain)), plain);
}

#[test]
fn a_data_uri_shorter_than_its_buffer_is_refused() {
    let uri = data_uri("application/octet-stream", &triangle_bin()[..40]);
    let source = assert_uri_refused(import_memory(&triangle(&uri)), &uri);
    assert_eq!(source, UriError::TooShort { got: 40, need: 80 });
}

// ---------------------------------------------------------------------------
// The node graph.

/// The triangle document with `nodes` and the scene's roots replaced.
fn with_nodes(nodes: Value, roots: Value) -> Value {
    let mut gltf = embedded_triangle();
    gltf["nodes"] = nodes;
    gltf["scenes"] = json!([{"nodes": roots}]);
    gltf
}

fn graph_error(result: Result<(GltfImport, Scene), GltfError>) -> GraphError {
    match result {
        Err(GltfError::Graph { source, .. }) => source,
        Err(other) => panic!("expected a graph error, got {other}"),
        Ok(_) => panic!("expected a graph error, got Ok"),
    }
}

#[test]
fn a_node_that_is_its_own_child_is_refused_naming_it() {
    let err = graph_error(import_memory(&with_nodes(json!([{}, {"children": [1]}]), json!([0]))));
    assert_eq!(err, GraphError::Cycle { node: 1 });
    assert!(err.to_string().contains("node 1"), "{err}");
}

#[test]
fn a_two_node_cycle_is_refused() {
    let err = graph_error(import_memory(&with_nodes(json!([{"children": [1]}, {"children": [0]}]), json!([]))));
    assert!(matches!(err, GraphError::Cycle { node: 0 | 1 }), "{err}");
}

#[test]
fn a_child_shared_by_two_parents_is_refused_naming_both() {
    let nodes = json!([{"children": [2]}, {"children": [2]}, {"mesh": 0}]);
    let err = graph_error(import_memory(&with_nodes(nodes, json!([0, 1]))));
    assert_eq!(err, GraphError::TwoParents { node: 2, first: 0, second: 1 });
}

/// `depth` nodes, each the only child of the one before; the last draws
/// the triangle.
fn chain(depth: usize) -> Value {
    let nodes: Vec<Value> =
        (0..depth).map(|i| if i + 1 < depth { json!({"children": [i + 1]}) } else { json!({"mesh": 0}) }).collect();
    with_nodes(Value::Array(nodes), json!([0]))
}

/// Runs `f` on a thread with a small stack (256 KiB): a walk that recursed
/// per level would overflow it long before 10 000 levels.
fn on_small_stack<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    std::thread::Builder::new().stack_size(256 << 10).spawn(f).unwrap().join().unwrap()
}

#[test]
fn a_chain_ten_thousand_nodes_deep_is_refused_naming_the_depth_limit_without_overflowing_the_stack() {
    let result = on_small_stack(|| import_memory(&chain(10_000)).map(|(i, _)| i.renderables));
    match result {
        Err(err @ GltfError::Limit { source: LimitExceeded { limit: "max_node_depth", value: 513, max: 512 }, .. }) => {
            assert!(err.to_string().contains("max_node_depth"), "{err}");
        }
        other => panic!("expected the max_node_depth limit, got {other:?}"),
    }
}

#[test]
fn a_chain_ten_thousand_nodes_deep_imports_when_max_node_depth_is_raised() {
    let renderables = on_small_stack(|| {
        let limits = ImportLimits { max_node_depth: 10_000, ..ImportLimits::default() };
        let (import, scene) = import_memory_with(&chain(10_000), limits).unwrap();
        assert_eq!(scene.node_count(), 10_000);
        import.renderables
    });
    assert_eq!(renderables, 1);
}

#[test]
fn forty_levels_of_two_nodes_each_parenting_both_below_are_refused_at_once() {
    // 2^40 root-to-leaf paths: a walk that followed them would never end.
    let nodes: Vec<Value> = (0..80)
        .map(|i| if i / 2 + 1 < 40 { json!({"children": [2 * (i / 2 + 1), 2 * (i / 2 + 1) + 1]}) } else { json!({}) })
        .collect();
    let started = Instant::now();
    let err = graph_error(import_memory(&with_nodes(Value::Array(nodes), json!([0, 1]))));
    assert!(matches!(err, GraphError::TwoParents { .. }), "{err}");
    assert!(started.elapsed() < QUICKLY, "took {:?}", started.elapsed());
}

// ---------------------------------------------------------------------------
// Accessors: validated for their use before any byte is read.

#[test]
fn indices_of_signed_or_float_components_are_refused_naming_mesh_primitive_and_accessor() {
    for (component, name) in [(5120, "I8"), (5122, "I16"), (5126, "F32")] {
        let mut gltf = embedded_triangle();
        gltf["accessors"][1]["componentType"] = json!(component);
        let text = assert_mesh_error(import_memory(&gltf), 1);
        assert!(text.contains(name) && text.contains("Indices"), "{text}");
    }
}

#[test]
fn indices_pointing_at_the_position_accessor_are_refused() {
    let mut gltf = embedded_triangle();
    gltf["meshes"][0]["primitives"][0]["indices"] = json!(0);
    let text = assert_mesh_error(import_memory(&gltf), 0);
    assert!(text.contains("Vec3") && text.contains("Indices"), "{text}");
}

#[test]
fn texcoord_0_of_u32_components_is_refused_naming_mesh_primitive_and_accessor() {
    let mut gltf = embedded_triangle();
    gltf["accessors"][2]["componentType"] = json!(5125);
    let text = assert_mesh_error(import_memory(&gltf), 2);
    assert!(text.contains("U32") && text.contains("TexCoord"), "{text}");
}

#[test]
fn an_index_accessor_past_its_buffer_view_is_an_error_not_an_unindexed_draw() {
    let mut gltf = embedded_triangle();
    gltf["accessors"][1]["count"] = json!(6);
    let text = assert_mesh_error(import_memory(&gltf), 1);
    assert!(text.contains("do not fit"), "{text}");
}

#[test]
fn an_index_value_past_the_vertex_count_is_an_error() {
    let mut bin = triangle_bin();
    bin[40..42].copy_from_slice(&3u16.to_le_bytes());
    let gltf = triangle(&data_uri("application/octet-stream", &bin));
    let text = assert_mesh_error(import_memory(&gltf), 1);
    assert!(text.contains("index 3 is past the 3 vertices"), "{text}");
}

#[test]
fn an_unreadable_texcoord_is_an_error_not_zeros() {
    let mut gltf = embedded_triangle();
    gltf["accessors"][2]["byteOffset"] = json!(4);
    assert_mesh_error(import_memory(&gltf), 2);
    let mut gltf = embedded_triangle();
    gltf["accessors"][2]["bufferView"] = json!(9);
    assert_mesh_error(import_memory(&gltf), 2);
}

#[test]
fn non_finite_positions_are_an_error_naming_the_accessor() {
    let mut bin = triangle_bin();
    bin[12..16].copy_from_slice(&f32::NAN.to_le_bytes());
    let text = assert_mesh_error(import_memory(&triangle(&data_uri("application/octet-stream", &bin))), 0);
    assert!(text.contains("not finite"), "{text}");
}

// ---------------------------------------------------------------------------
// Import limits: each one, passed, is an error naming it and the value.

#[test]
fn max_file_bytes_is_checked_before_anything_is_parsed() {
    let bytes = serde_json::to_vec(&embedded_triangle()).unwrap();
    let limits = ImportLimits { max_file_bytes: 100, ..ImportLimits::default() };
    let result = import_gltf_slice(&mut Scene::new(), &bytes, "big.gltf", &options(limits)).map(|i| (i, Scene::new()));
    assert_limit(result, "max_file_bytes", bytes.len() as u64);
    let folder = Folder::new("max_file_bytes");
    let gltf = triangle("triangle.bin");
    let size = serde_json::to_vec(&gltf).unwrap().len() as u64;
    assert_limit(folder.import_with(&gltf, &options(limits)), "max_file_bytes", size);
}

#[test]
fn max_json_bytes_bounds_the_json() {
    let gltf = embedded_triangle();
    let size = serde_json::to_vec(&gltf).unwrap().len() as u64;
    assert_limit(
        import_memory_with(&gltf, ImportLimits { max_json_bytes: 100, ..Default::default() }),
        "max_json_bytes",
        size,
    );
}

#[test]
fn max_json_objects_bounds_the_objects_before_parsing() {
    let gltf = embedded_triangle();
    let objects = serde_json::to_string(&gltf).unwrap().matches('{').count() as u64;
    let limits = ImportLimits { max_json_objects: 5, ..Default::default() };
    assert_limit(import_memory_with(&gltf, limits), "max_json_objects", objects);
}

#[test]
fn max_nodes_bounds_the_node_list() {
    let limits = ImportLimits { max_nodes: 99, ..Default::default() };
    assert_limit(import_memory_with(&chain(100), limits), "max_nodes", 100);
}

#[test]
fn max_node_depth_bounds_the_hierarchy() {
    let limits = ImportLimits { max_node_depth: 3, ..Default::default() };
    import_memory_with(&chain(3), limits).unwrap();
    assert_limit(import_memory_with(&chain(4), limits), "max_node_depth", 4);
}

#[test]
fn max_vertices_bounds_the_vertices() {
    let limits = ImportLimits { max_vertices: 2, ..Default::default() };
    assert_limit(import_memory_with(&embedded_triangle(), limits), "max_vertices", 3);
}

#[test]
fn max_indices_bounds_the_indices() {
    let limits = ImportLimits { max_indices: 2, ..Default::default() };
    assert_limit(import_memory_with(&embedded_triangle(), limits), "max_indices", 3);
}

#[test]
fn max_vertices_counts_zero_filled_accessors_that_the_file_does_not_hold() {
    // An accessor without a bufferView is zeros: 16 Mi + 2 vertices from
    // a few hundred bytes of JSON.
    let mut gltf = embedded_triangle();
    gltf["accessors"] = json!([{"componentType": 5126, "count": (16u64 << 20) + 2, "type": "VEC3"}]);
    gltf["meshes"][0]["primitives"] = json!([{"attributes": {"POSITION": 0}}]);
    let started = Instant::now();
    assert_limit(import_memory(&gltf), "max_vertices", (16 << 20) + 2);
    assert!(started.elapsed() < QUICKLY, "took {:?}", started.elapsed());
}

#[test]
fn max_texture_dimension_bounds_each_side() {
    let gltf = with_image(embedded_triangle(), &data_uri("image/png", &picture()));
    let limits = ImportLimits { max_texture_dimension: 255, ..Default::default() };
    assert_limit(import_memory_with(&gltf, limits), "max_texture_dimension", 256);
    import_memory(&gltf).unwrap();
}

#[test]
fn a_tiny_png_claiming_100000_by_100000_texels_is_refused_before_decoding() {
    let png = png_header_claiming(100_000, 100_000);
    assert!(png.len() < 80);
    let gltf = with_image(embedded_triangle(), &data_uri("image/png", &png));
    let started = Instant::now();
    assert_limit(import_memory(&gltf), "max_texture_dimension", 100_000);
    assert!(started.elapsed() < QUICKLY, "took {:?}", started.elapsed());
}

#[test]
fn a_tiny_png_claiming_more_texels_than_the_byte_budget_is_refused_before_decoding() {
    // 8192 × 8192 passes the dimension limit but is 256 MiB of RGBA8.
    let gltf = with_image(embedded_triangle(), &data_uri("image/png", &png_header_claiming(8192, 8192)));
    let limits = ImportLimits { max_total_bytes: 128 << 20, ..Default::default() };
    match import_memory_with(&gltf, limits) {
        Err(GltfError::Limit { source: LimitExceeded { limit: "max_total_bytes", value, .. }, .. }) => {
            assert!(value >= 256 << 20, "{value}");
        }
        other => panic!("expected the max_total_bytes limit, got {:?}", other.map(|(i, _)| i.bytes_decoded)),
    }
}

#[test]
fn max_image_file_bytes_bounds_images_from_data_uris_files_and_buffer_views() {
    let png = picture();
    let limits = ImportLimits { max_image_file_bytes: 1000, ..Default::default() };
    // A data: URI (its decoded size is estimated from its length).
    let gltf = with_image(embedded_triangle(), &data_uri("image/png", &png));
    match import_memory_with(&gltf, limits) {
        Err(GltfError::Limit { source: LimitExceeded { limit: "max_image_file_bytes", value, max: 1000 }, .. }) => {
            assert!(value.abs_diff(png.len() as u64) <= 3, "{value}");
        }
        other => panic!("expected the max_image_file_bytes limit, got {:?}", other.map(|(i, _)| i.bytes_decoded)),
    }
    // A file beside the scene.
    let folder = Folder::new("max_image_file_bytes");
    let gltf = with_image(triangle("triangle.bin"), "picture.png");
    assert_limit(folder.import_with(&gltf, &options(limits)), "max_image_file_bytes", png.len() as u64);
    // A buffer view.
    let mut bin = triangle_bin();
    bin.extend(&png);
    let mut gltf = with_image(triangle(&data_uri("application/octet-stream", &bin)), "unused");
    gltf["buffers"][0]["byteLength"] = json!(bin.len());
    gltf["bufferViews"].as_array_mut().unwrap().push(json!({"buffer": 0, "byteOffset": 80, "byteLength": png.len()}));
    gltf["images"] = json!([{"bufferView": 4, "mimeType": "image/png"}]);
    import_memory(&gltf).unwrap();
    assert_limit(import_memory_with(&gltf, limits), "max_image_file_bytes", png.len() as u64);
}

#[test]
fn max_total_bytes_bounds_the_sum() {
    let gltf = embedded_triangle();
    let size = serde_json::to_vec(&gltf).unwrap().len() as u64;
    let limits = ImportLimits { max_total_bytes: size, ..Default::default() };
    match import_memory_with(&gltf, limits) {
        Err(GltfError::Limit { source: LimitExceeded { limit: "max_total_bytes", value, max }, .. }) => {
            assert!(value > max && max == size, "{value} > {max}");
        }
        other => panic!("expected the max_total_bytes limit, got {:?}", other.map(|(i, _)| i.bytes_decoded)),
    }
    let (import, _) = import_memory(&gltf).unwrap();
    assert!(import.bytes_decoded > size);
}

// ---------------------------------------------------------------------------
// Transforms, bounds and skins.

/// A translation or scale past `f32`'s range (1e39 reads as infinity) is
/// imported with a warning naming its node, whichever of the two it is; a
/// finite node gets none.
#[test]
fn a_non_finite_translation_or_scale_is_imported_with_a_warning_naming_its_node() {
    let nodes = json!([
        {"name": "far", "translation": [1e39, 0, 0]},
        {"name": "huge", "scale": [1, 1e39, 1]},
        {"name": "near", "translation": [1, 2, 3], "scale": [2, 2, 2]}
    ]);
    let (import, _) = import_memory(&with_nodes(nodes, json!([0, 1, 2]))).unwrap();
    let warned: Vec<&str> = ["far", "huge", "near"]
        .into_iter()
        .filter(|n| import.warnings.iter().any(|w| w.contains(&format!("node '{n}': non-finite transform"))))
        .collect();
    assert_eq!(warned, ["far", "huge"], "{:?}", import.warnings);
}

/// A rotation that is no usable quaternion (all zeros, or a component past
/// `f32`'s range) becomes the identity; a usable one of another length than
/// 1 is normalized.
#[test]
fn an_unusable_rotation_becomes_the_identity_and_a_long_one_is_normalized() {
    let nodes = json!([
        {"name": "zero", "rotation": [0, 0, 0, 0]},
        {"name": "huge", "rotation": [1e39, 0, 0, 1]},
        {"name": "long", "rotation": [0, 0, 2, 0]}
    ]);
    let (import, scene) = import_memory(&with_nodes(nodes, json!([0, 1, 2]))).unwrap();
    let rotation = |name| scene.node(import.node(name).unwrap()).unwrap().local.rotation;
    assert_eq!(rotation("zero"), oxygen::glam::Quat::IDENTITY);
    assert_eq!(rotation("huge"), oxygen::glam::Quat::IDENTITY);
    assert_eq!(rotation("long"), oxygen::glam::Quat::from_xyzw(0.0, 0.0, 1.0, 0.0));
}

/// A drawn node's bounds are its mesh's under its parent's transform, then
/// its own: the triangle, moved up by 5, under a parent that scales by 2 and
/// moves by 10 along x, spans (10, 10, 0) to (12, 12, 0).
#[test]
fn a_childs_bounds_are_its_mesh_under_its_parents_transform_then_its_own() {
    let nodes = json!([
        {"translation": [10, 0, 0], "scale": [2, 2, 2], "children": [1]},
        {"translation": [0, 5, 0], "mesh": 0}
    ]);
    let (import, _) = import_memory(&with_nodes(nodes, json!([0]))).unwrap();
    let bounds = import.precise_bounds.expect("the triangle is drawn");
    let (min, max) = (bounds.min.to_array(), bounds.max.to_array());
    assert!(min.iter().zip([10.0, 10.0, 0.0]).all(|(a, b)| (a - b).abs() < 1e-9), "{min:?}");
    assert!(max.iter().zip([12.0, 12.0, 0.0]).all(|(a, b)| (a - b).abs() < 1e-9), "{max:?}");
}

/// The matrix that moves a point by `y` along y.
fn lift(y: f32) -> oxygen::glam::Mat4 {
    oxygen::glam::Mat4::from_translation(oxygen::glam::Vec3::new(0.0, y, 0.0))
}

/// The triangle drawn by node "body", skinned to "knee" then "hip" (joints
/// listed in that order and after the mesh node). Buffer 1 holds two inverse
/// bind matrices, `lift(-1)` and `lift(-2)` (accessor 4); the skin uses them
/// when `matrices` is set, and the file is otherwise the same.
fn skinned(matrices: bool) -> Value {
    let nodes = json!([{"name": "body", "mesh": 0, "skin": 0}, {"name": "hip", "children": [2]}, {"name": "knee"}]);
    let mut gltf = with_nodes(nodes, json!([0, 1]));
    let bytes: Vec<u8> =
        [lift(-1.0), lift(-2.0)].iter().flat_map(|m| m.to_cols_array()).flat_map(f32::to_le_bytes).collect();
    let uri = data_uri("application/octet-stream", &bytes);
    gltf["buffers"].as_array_mut().unwrap().push(json!({"byteLength": 128, "uri": uri}));
    gltf["bufferViews"].as_array_mut().unwrap().push(json!({"buffer": 1, "byteLength": 128}));
    let accessor = json!({"bufferView": 4, "componentType": 5126, "count": 2, "type": "MAT4"});
    gltf["accessors"].as_array_mut().unwrap().push(accessor);
    let mut skin = json!({"joints": [2, 1]});
    if matrices {
        skin["inverseBindMatrices"] = json!(4);
    }
    gltf["skins"] = json!([skin]);
    gltf
}

/// A skinned node gets its skin once every node exists: the joints in the
/// skin's order, each with its inverse bind matrix, the identity when the
/// file gives none.
#[test]
fn a_skin_binds_its_joints_in_the_files_order_with_their_inverse_bind_matrices() {
    let identity = oxygen::glam::Mat4::IDENTITY;
    for (matrices, expected) in [(true, [lift(-1.0), lift(-2.0)]), (false, [identity, identity])] {
        let (import, scene) = import_memory(&skinned(matrices)).unwrap();
        let body = scene.node(import.node("body").unwrap()).unwrap();
        let skin = body.skin.as_deref().expect("the body is skinned");
        assert_eq!(skin.joints, [import.node("knee").unwrap(), import.node("hip").unwrap()]);
        assert_eq!(skin.inverse_bind_matrices, expected, "matrices given: {matrices}");
    }
}

/// Inverse bind matrices are charged to `max_total_bytes` before they are
/// read, 64 bytes each: the skin with two costs 128 bytes more than the same
/// skin without (the file's own bytes, charged too, aside), and a budget one
/// byte short of the total is refused naming the skin.
#[test]
fn inverse_bind_matrices_are_charged_64_bytes_each_naming_the_skin() {
    let total = |gltf: &Value| import_memory(gltf).unwrap().0.bytes_decoded;
    let file = |gltf: &Value| serde_json::to_vec(gltf).unwrap().len() as u64;
    let (with, without) = (skinned(true), skinned(false));
    assert_eq!((total(&with) - file(&with)) - (total(&without) - file(&without)), 2 * 64);
    let limits = ImportLimits { max_total_bytes: total(&with) - 1, ..Default::default() };
    match import_memory_with(&with, limits) {
        Err(GltfError::Limit { context, source: LimitExceeded { limit: "max_total_bytes", .. }, .. }) => {
            assert_eq!(context, "skin 0");
        }
        other => panic!("expected the max_total_bytes limit, got {:?}", other.map(|(i, _)| i.bytes_decoded)),
    }
}

// ---------------------------------------------------------------------------
// The rest of the file.

#[test]
fn a_required_extension_oxygen_does_not_support_is_refused_naming_it() {
    let mut gltf = embedded_triangle();
    gltf["extensionsUsed"] = json!(["KHR_lights_punctual", "EXT_meshopt_compression"]);
    gltf["extensionsRequired"] = json!(["KHR_lights_punctual", "EXT_meshopt_compression"]);
    match import_memory(&gltf) {
        Err(err @ GltfError::UnsupportedExtension { .. }) => {
            assert!(err.to_string().contains("EXT_meshopt_compression"), "{err}");
        }
        other => panic!("expected an unsupported-extension error, got {:?}", other.map(|(i, _)| i.renderables)),
    }
    // Used but not required: imported without it.
    gltf["extensionsRequired"] = json!([]);
    import_memory(&gltf).unwrap();
}

#[test]
fn the_triangle_used_by_these_tests_imports_from_memory_and_from_a_folder() {
    let (import, _) = import_memory(&embedded_triangle()).unwrap();
    assert_eq!(import.renderables, 1);
    let (import, _) = Folder::new("triangle").import(&triangle("triangle.bin")).unwrap();
    assert_eq!(import.renderables, 1);
}

#[test]
fn every_shipped_scene_still_imports() {
    let assets = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets");
    let mut imported = 0;
    for folder in std::fs::read_dir(&assets).unwrap() {
        for file in std::fs::read_dir(folder.unwrap().path()).unwrap() {
            let path = file.unwrap().path();
            if matches!(path.extension().and_then(|e| e.to_str()), Some("gltf" | "glb")) {
                let import = import_gltf_with(&mut Scene::new(), &path, &ImportOptions::default())
                    .unwrap_or_else(|e| panic!("{e}"));
                assert!(import.renderables > 0, "{}", path.display());
                imported += 1;
            }
        }
    }
    assert!(imported >= 8, "{imported} scenes");
}

/// A panorama's header is read before its pixels: a side past
/// `MAX_ENVIRONMENT_SIDE` is refused by size, naming the file, without
/// decoding; the largest side allowed gets as far as decoding (whose short
/// data then fails as a read error).
#[test]
fn an_hdr_panorama_past_the_size_limit_is_refused_before_decoding() {
    use oxygen::lighting::{EnvironmentFileError, MAX_ENVIRONMENT_SIDE, load_hdr_environment};
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("hdr_limits");
    std::fs::create_dir_all(&dir).unwrap();
    let panorama = |width: u32, height: u32| {
        let path = dir.join(format!("{width}x{height}.hdr"));
        let mut bytes = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {height} +X {width}\n").into_bytes();
        bytes.extend_from_slice(&[128, 128, 128, 129].repeat(4)); // far fewer texels than declared
        std::fs::write(&path, bytes).unwrap();
        path
    };
    let max = MAX_ENVIRONMENT_SIDE;
    for (width, height) in [(max + 1, 1), (1, max + 1), (max + 1, max + 1)] {
        let path = panorama(width, height);
        match load_hdr_environment(&path) {
            Err(EnvironmentFileError::Size { path: named, width: w, height: h }) => {
                assert_eq!((named, w, h), (path.clone(), width, height));
            }
            other => panic!("{width} × {height}: expected a size error, got {other:?}"),
        }
    }
    for (width, height) in [(max, 1), (1, max)] {
        let path = panorama(width, height);
        match load_hdr_environment(&path) {
            Err(EnvironmentFileError::Read { path: named, .. }) => assert_eq!(named, path),
            other => panic!("{width} × {height}: expected the short data to fail decoding, got {other:?}"),
        }
    }
    // A panorama with one empty side has no texel to light with.
    for (width, height) in [(0, 4), (4, 0)] {
        let path = panorama(width, height);
        match load_hdr_environment(&path) {
            Err(EnvironmentFileError::Size { path: named, width: w, height: h }) => {
                assert_eq!((named, w, h), (path.clone(), width, height));
            }
            other => panic!("{width} × {height}: expected a size error, got {other:?}"),
        }
    }
}
