//! Models moved far from the origin, for the tests of f64 framing.

/// The GLB file at `path` with its default scene's roots wrapped in one
/// node translated by `offset`: the same model, far from the origin.
pub fn wrapped_glb(path: &str, offset: [f64; 3]) -> Vec<u8> {
    let glb = std::fs::read(path).unwrap();
    let chunk_length = |at: usize| u32::from_le_bytes(glb[at..at + 4].try_into().unwrap()) as usize;
    let json_length = chunk_length(12);
    let mut json: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_length]).unwrap();
    let rest = &glb[20 + json_length..];
    // A new node holding the default scene's roots.
    let scene_index = json["scene"].as_u64().unwrap_or(0) as usize;
    let roots = json["scenes"][scene_index]["nodes"].clone();
    let nodes = json["nodes"].as_array_mut().unwrap();
    nodes.push(serde_json::json!({ "name": "far away", "translation": offset, "children": roots }));
    let wrapper = nodes.len() - 1;
    json["scenes"][scene_index]["nodes"] = serde_json::json!([wrapper]);
    let mut text = serde_json::to_vec(&json).unwrap();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((12 + 8 + text.len() + rest.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(rest);
    out
}

/// Asserts that `far` (the model far from the origin) shows what `origin`
/// (the model at the origin) shows: no pixel differs by more than 8 levels
/// (measured: none at 1e6 and 3e7 out, the worst difference 1 level;
/// framed on the f32 bounds 3e7 out, 1 310 of 9 216 pixels differ in
/// tests/far_framing.rs and 2 927 in the main job's front view). `what`
/// names the case in the output.
pub fn assert_framed_alike(far: &image::RgbaImage, origin: &image::RgbaImage, what: &str) {
    let comparison = super::golden::compare(far, origin, 8);
    eprintln!("{what}: {} of {} pixels differ (worst {})", comparison.differing, comparison.total, comparison.worst);
    assert_eq!(
        comparison.differing, 0,
        "{what}: {} of {} pixels differ from the model at the origin (worst {})",
        comparison.differing, comparison.total, comparison.worst
    );
}
