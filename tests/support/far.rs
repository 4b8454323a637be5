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
