//! Where a glTF file's bytes come from, and the confinement of its URIs.
//!
//! Inputs: the scene file's bytes (a `.glb` container or `.gltf` JSON) and,
//! for a file on disk, the folder it lives in. Outputs: the JSON part, the
//! GLB binary chunk, and the bytes behind each buffer and image URI.
//!
//! This module is the only place the importer touches the file system, and it
//! only reads regular files inside the asset root:
//!
//! * `data:` URIs are decoded here (base64 only, as glTF requires);
//! * any other URI must be a relative path: percent-decoded, with no scheme,
//!   no leading `/`, no drive letter, no backslash or NUL, and no `..` that
//!   climbs out of the root; it is resolved against the scene file's folder,
//!   canonicalized (symbolic links followed) and must still be inside the
//!   root and name a regular file;
//! * every refusal that depends on the file system (missing, outside through
//!   a link, a device, a FIFO, a folder) is *one* error, so that a crafted
//!   file cannot learn which paths exist;
//! * a buffer reads at most its `byteLength` bytes, an image at most
//!   [`ImportLimits::max_image_file_bytes`](super::ImportLimits).

use std::io::Read;
use std::path::{Component, Path, PathBuf};

/// Why a URI was refused or its bytes could not be had.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum UriError {
    /// The URI names something outside the asset root, or something that is
    /// not a readable regular file there (the same answer either way).
    #[error("refused: not a readable regular file inside {root}")]
    NotInsideRoot {
        /// The asset root, as the caller named it.
        root: PathBuf,
    },
    /// The URI has a form the importer never follows.
    #[error("refused: {0}")]
    Refused(&'static str),
    /// The file was imported from bytes, so it has no folder to read from.
    #[error("refused: the scene was imported from memory and has no folder to read external files from")]
    NoFolder,
    /// A `data:` URI or percent escape is malformed.
    #[error("malformed: {0}")]
    Malformed(String),
    /// The bytes behind the URI are more than may be read: a buffer's
    /// `byteLength` (and padding), or an image's
    /// [`ImportLimits::max_image_file_bytes`](super::ImportLimits).
    #[error("holds {bytes} bytes, more than the {max} it may")]
    TooLarge {
        /// Bytes present (for a `data:` URI, its decoded size).
        bytes: u64,
        /// Bytes allowed.
        max: u64,
    },
    /// The referenced file is shorter than the glTF says.
    #[error("the file holds {got} bytes, the glTF says {need}")]
    TooShort {
        /// Bytes present.
        got: u64,
        /// Bytes required.
        need: u64,
    },
    /// Reading failed after the file was accepted.
    #[error("read failed: {0}")]
    Io(String),
}

/// The folder that confines every external URI of one import.
#[derive(Clone, Debug)]
pub(crate) struct AssetRoot {
    /// The scene file's folder, canonical: relative URIs start here.
    base: PathBuf,
    /// The root as the caller named it (for messages).
    shown: PathBuf,
    /// The root, canonical.
    canonical: PathBuf,
}

impl AssetRoot {
    /// `base` is the scene file's folder; `root` the folder URIs must stay
    /// in (the caller's `asset_root`, or `base` itself).
    pub(crate) fn new(base: &Path, root: Option<&Path>) -> std::io::Result<Self> {
        let base = std::fs::canonicalize(base)?;
        let shown = root.map_or_else(|| base.clone(), Path::to_path_buf);
        let canonical = match root {
            Some(root) => std::fs::canonicalize(root)?,
            None => base.clone(),
        };
        Ok(AssetRoot { base, shown, canonical })
    }

    /// Resolves a relative, percent-decoded URI to a canonical path of a
    /// regular file inside the root.
    pub(crate) fn resolve(&self, uri: &str) -> Result<PathBuf, UriError> {
        let decoded = percent_decode(uri)?;
        check_relative(&decoded)?;
        // Lexical resolution first, without touching the file system, so that
        // `..` tricks are refused the same way whether the target exists.
        let mut lexical = self.base.clone();
        for part in decoded.split('/') {
            match part {
                "" | "." => {}
                ".." => {
                    if !lexical.pop() {
                        return Err(self.outside());
                    }
                }
                name => lexical.push(name),
            }
        }
        if !lexical.starts_with(&self.canonical) {
            return Err(self.outside());
        }
        // Then the file system: links followed, and only regular files.
        let canonical = std::fs::canonicalize(&lexical).map_err(|_| self.outside())?;
        if !canonical.starts_with(&self.canonical) {
            return Err(self.outside());
        }
        match std::fs::metadata(&canonical) {
            Ok(meta) if meta.is_file() => Ok(canonical),
            _ => Err(self.outside()),
        }
    }

    fn outside(&self) -> UriError {
        UriError::NotInsideRoot { root: self.shown.clone() }
    }
}

/// Where a URI's bytes may come from: a confined folder, or (for an import
/// from memory) nowhere but `data:` URIs.
#[derive(Clone, Copy, Debug)]
pub(crate) enum AssetRootRef<'a> {
    /// External files inside this root.
    Folder(&'a AssetRoot),
    /// `data:` URIs only.
    Memory,
}

impl AssetRootRef<'_> {
    /// The bytes behind `uri`: exactly `need` bytes (a buffer's
    /// `byteLength`) or, with `need == None`, at most `cap` bytes (an image).
    pub(crate) fn read(&self, uri: &str, need: Option<u64>, cap: u64) -> Result<Vec<u8>, UriError> {
        if let Some(data) = decode_data_uri(uri, need.unwrap_or(cap).max(cap)) {
            let (_, mut bytes) = data?;
            if let Some(need) = need {
                if (bytes.len() as u64) < need {
                    return Err(UriError::TooShort { got: bytes.len() as u64, need });
                }
                bytes.truncate(need as usize);
            }
            return Ok(bytes);
        }
        match self {
            AssetRootRef::Folder(root) => read_file(&root.resolve(uri)?, need, cap),
            AssetRootRef::Memory => Err(UriError::NoFolder),
        }
    }
}

/// Reads exactly `need` bytes from the start of a resolved file (a buffer),
/// or at most `cap` bytes (an image, `need == None`).
pub(crate) fn read_file(path: &Path, need: Option<u64>, cap: u64) -> Result<Vec<u8>, UriError> {
    let file = open_without_blocking(path).map_err(|e| UriError::Io(e.to_string()))?;
    // The file was a regular file when resolved; check the handle we hold, so
    // that a swap between the check and the open cannot hand us a device.
    let meta = file.metadata().map_err(|e| UriError::Io(e.to_string()))?;
    if !meta.is_file() {
        return Err(UriError::Refused("not a regular file"));
    }
    let want = need.unwrap_or(cap);
    if need.is_none() && meta.len() > cap {
        return Err(UriError::TooLarge { bytes: meta.len(), max: cap });
    }
    let mut bytes = Vec::with_capacity(want.min(meta.len()) as usize);
    // One byte past the cap tells an oversized image from one that fits.
    let take = if need.is_some() { want } else { want.saturating_add(1) };
    file.take(take).read_to_end(&mut bytes).map_err(|e| UriError::Io(e.to_string()))?;
    match need {
        Some(need) if (bytes.len() as u64) < need => Err(UriError::TooShort { got: bytes.len() as u64, need }),
        None if bytes.len() as u64 > cap => Err(UriError::TooLarge { bytes: bytes.len() as u64, max: cap }),
        _ => Ok(bytes),
    }
}

/// Opens `path` for reading. Where the platform allows, without blocking:
/// a FIFO swapped in after [`AssetRoot::resolve`] checked the path would
/// otherwise block `open` until some other process wrote to it.
fn open_without_blocking(path: &Path) -> std::io::Result<std::fs::File> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        // O_NONBLOCK; it changes nothing for the regular files that are read.
        #[cfg(any(target_os = "linux", target_os = "android"))]
        const O_NONBLOCK: i32 = 0o4000;
        #[cfg(not(any(target_os = "linux", target_os = "android")))]
        const O_NONBLOCK: i32 = 0x0004; // macOS and the BSDs.
        options.custom_flags(O_NONBLOCK);
    }
    options.open(path)
}

/// Refuses anything but a plain relative path.
fn check_relative(path: &str) -> Result<(), UriError> {
    if path.is_empty() {
        return Err(UriError::Refused("empty URI"));
    }
    if path.contains('\0') {
        return Err(UriError::Refused("NUL byte in URI"));
    }
    if path.contains('\\') {
        return Err(UriError::Refused("backslash in URI (glTF URIs use '/')"));
    }
    if path.starts_with('/') {
        return Err(UriError::Refused("absolute path"));
    }
    if has_scheme(path) {
        return Err(UriError::Refused("URI scheme other than data: (file:, http: and others are never followed)"));
    }
    if Path::new(path).components().any(|c| matches!(c, Component::Prefix(_) | Component::RootDir)) {
        return Err(UriError::Refused("absolute path"));
    }
    Ok(())
}

/// `scheme:` per RFC 3986 (a letter, then letters, digits, `+`, `-`, `.`),
/// which also catches Windows drive letters such as `C:`.
fn has_scheme(uri: &str) -> bool {
    let Some((scheme, _)) = uri.split_once(':') else { return false };
    let mut chars = scheme.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.'))
}

/// Decodes `%XX` escapes; the result must be UTF-8.
pub(crate) fn percent_decode(uri: &str) -> Result<String, UriError> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = bytes.get(i + 1..i + 3).ok_or_else(|| UriError::Malformed("truncated % escape".into()))?;
            let text = std::str::from_utf8(hex).map_err(|_| UriError::Malformed("bad % escape".into()))?;
            let value =
                u8::from_str_radix(text, 16).map_err(|_| UriError::Malformed(format!("bad % escape %{text}")))?;
            out.push(value);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| UriError::Malformed("percent-decoded URI is not UTF-8".into()))
}

/// A decoded `data:` URI: its media type (if it names one) and its bytes.
pub(crate) type DataUri = (Option<String>, Vec<u8>);

/// The payload of a `data:` URI, if `uri` is one. Only base64 payloads are
/// glTF; `cap` bounds the decoded size before anything is allocated.
pub(crate) fn decode_data_uri(uri: &str, cap: u64) -> Option<Result<DataUri, UriError>> {
    // Schemes are case-insensitive. `get` (not `[..5]`): a URI whose fifth
    // byte is inside a multi-byte character is not a data: URI, not a panic.
    let rest = uri.get(..5).filter(|scheme| scheme.eq_ignore_ascii_case("data:")).map(|_| &uri[5..])?;
    Some((|| {
        let (header, payload) =
            rest.split_once(',').ok_or_else(|| UriError::Malformed("data: URI without a ','".into()))?;
        let Some(mime) = header.strip_suffix(";base64") else {
            return Err(UriError::Malformed("data: URI is not base64 (glTF requires base64)".into()));
        };
        let decoded_len = (payload.len() as u64 / 4) * 3;
        if decoded_len > cap {
            return Err(UriError::TooLarge { bytes: decoded_len, max: cap });
        }
        let mime = (!mime.is_empty()).then(|| mime.to_owned());
        Ok((mime, base64_decode(payload)?))
    })())
}

/// Standard base64 (RFC 4648, `+/`, `=` padding optional), whitespace refused.
pub(crate) fn base64_decode(text: &str) -> Result<Vec<u8>, UriError> {
    let bytes = text.trim_end_matches('=').as_bytes();
    if text.len() - bytes.len() > 2 {
        return Err(UriError::Malformed("base64 has more than two '=' of padding".into()));
    }
    let mut out = Vec::with_capacity(bytes.len() / 4 * 3 + 3);
    let mut acc: u32 = 0;
    let mut bits = 0;
    for (i, &c) in bytes.iter().enumerate() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return Err(UriError::Malformed(format!("invalid base64 character {:?} at {i}", c as char))),
        };
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    if bits >= 6 {
        return Err(UriError::Malformed("truncated base64".into()));
    }
    Ok(out)
}

/// A `.glb` container split into its JSON chunk and optional binary chunk.
#[derive(Debug)]
pub(crate) struct Glb<'a> {
    pub(crate) json: &'a [u8],
    pub(crate) bin: Option<&'a [u8]>,
}

/// Splits a GLB file. Every length is checked against the bytes present
/// before it is used.
pub(crate) fn split_glb(bytes: &[u8]) -> Result<Glb<'_>, String> {
    let word =
        |at: usize| -> Option<u32> { bytes.get(at..at + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])) };
    let version = word(4).ok_or("GLB header truncated")?;
    if version != 2 {
        return Err(format!("GLB version {version} (only 2 is supported)"));
    }
    let total = word(8).ok_or("GLB header truncated")? as usize;
    if total > bytes.len() || total < 12 {
        return Err(format!("GLB header says {total} bytes, the file has {}", bytes.len()));
    }
    let bytes = &bytes[..total];
    // A chunk: its type, its data and where the next one starts.
    type Chunk<'a> = ([u8; 4], &'a [u8], usize);
    let chunk = |at: usize| -> Result<Option<Chunk<'_>>, String> {
        if at >= bytes.len() {
            return Ok(None);
        }
        let header = bytes.get(at..at + 8).ok_or("GLB chunk header truncated")?;
        let length = u32::from_le_bytes([header[0], header[1], header[2], header[3]]) as usize;
        let kind = [header[4], header[5], header[6], header[7]];
        let data = bytes
            .get(at + 8..(at + 8).saturating_add(length))
            .ok_or_else(|| format!("GLB chunk of {length} bytes at offset {at} runs past the file"))?;
        Ok(Some((kind, data, at + 8 + length)))
    };
    let (kind, json, next) = chunk(12)?.ok_or("GLB without a JSON chunk")?;
    if &kind != b"JSON" {
        return Err("GLB's first chunk is not JSON".into());
    }
    let bin = match chunk(next)? {
        Some((kind, data, _)) if &kind == b"BIN\0" => Some(data),
        Some(_) => None, // Unknown chunks are to be ignored (glTF 2.0, 4.4.3.3).
        None => None,
    };
    Ok(Glb { json, bin })
}

/// Counts JSON objects (`{` outside strings) so that the document's parsed
/// size is known before it is parsed.
pub(crate) fn count_json_objects(json: &[u8]) -> u64 {
    let mut count = 0;
    let mut in_string = false;
    let mut escaped = false;
    for &b in json {
        if in_string {
            if escaped {
                escaped = false;
            } else if b == b'\\' {
                escaped = true;
            } else if b == b'"' {
                in_string = false;
            }
        } else if b == b'"' {
            in_string = true;
        } else if b == b'{' {
            count += 1;
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trips_every_padding_length() {
        assert_eq!(base64_decode("").unwrap(), b"");
        assert_eq!(base64_decode("Zg==").unwrap(), b"f");
        assert_eq!(base64_decode("Zm8=").unwrap(), b"fo");
        assert_eq!(base64_decode("Zm9v").unwrap(), b"foo");
        assert_eq!(base64_decode("Zm9vYg").unwrap(), b"foob");
        assert!(base64_decode("Zm9v!").is_err());
        assert!(base64_decode("Z").is_err());
        assert!(base64_decode("Zg===").is_err());
    }

    #[test]
    fn a_uri_with_a_multi_byte_character_at_the_scheme_boundary_is_not_a_data_uri() {
        for uri in ["dataé.bin", "textü.bin", "data\u{1F600}", "ü"] {
            assert!(decode_data_uri(uri, 100).is_none(), "{uri}");
        }
        assert!(decode_data_uri("DaTa:;base64,AAAA", 100).is_some());
    }

    #[test]
    fn percent_escapes_decode_and_bad_ones_are_errors() {
        assert_eq!(percent_decode("a%20b%2e%2E").unwrap(), "a b..");
        assert!(percent_decode("%2").is_err());
        assert!(percent_decode("%zz").is_err());
        assert!(percent_decode("%ff").is_err());
    }

    #[test]
    fn only_plain_relative_paths_pass_the_lexical_check() {
        for bad in ["/etc/passwd", "file:///etc/passwd", "http://x/y", "C:/x", "c:x", "a\\b", "a\0b", ""] {
            assert!(check_relative(bad).is_err(), "{bad:?}");
        }
        for good in ["a.bin", "textures/a.png", "./a.bin", "a:b/../c"] {
            // "a:b/..." would be a scheme: refused, which errs on the safe side.
            if good.contains(':') {
                assert!(check_relative(good).is_err());
            } else {
                check_relative(good).unwrap();
            }
        }
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn reading_a_fifo_that_slipped_past_the_path_check_is_refused_without_blocking() {
        let dir = std::env::temp_dir().join(format!("oxygen-fifo-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let fifo = dir.join("pipe");
        let _ = std::fs::remove_file(&fifo);
        assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
        let (send, receive) = std::sync::mpsc::channel();
        let path = fifo.clone();
        std::thread::spawn(move || send.send(read_file(&path, Some(4), 4)).unwrap());
        let result = receive.recv_timeout(std::time::Duration::from_secs(2)).expect("read_file blocked on a FIFO");
        assert_eq!(result, Err(UriError::Refused("not a regular file")));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn glb_lengths_past_the_end_are_errors() {
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(24u32.to_le_bytes());
        glb.extend(100u32.to_le_bytes());
        glb.extend(b"JSON");
        glb.extend(b"{}  ");
        assert!(split_glb(&glb).unwrap_err().contains("runs past"));
        glb[12..16].copy_from_slice(&4u32.to_le_bytes());
        let split = split_glb(&glb).unwrap();
        assert_eq!(split.json, b"{}  ");
        glb[8..12].copy_from_slice(&5u32.to_le_bytes());
        assert!(split_glb(&glb).is_err());
    }

    #[test]
    fn braces_inside_strings_are_not_objects() {
        assert_eq!(count_json_objects(br#"{"a":"{{\"{","b":[{},{}]}"#), 3);
    }

    /// A fresh, empty folder for one test (removed first if a previous run
    /// left it).
    fn scratch_dir(test: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("oxygen-source-{test}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// `resolve` promises a regular file: a URI naming a folder inside the
    /// root is refused there, with the same answer as a path outside it (so
    /// a file cannot learn which folders exist), not left for a later read
    /// to stumble on.
    #[test]
    fn a_uri_naming_a_folder_inside_the_root_is_not_resolved() {
        let dir = scratch_dir("folder");
        std::fs::create_dir_all(dir.join("textures")).unwrap();
        std::fs::write(dir.join("a.bin"), b"1234").unwrap();
        let root = AssetRoot::new(&dir, None).unwrap();
        let refused = UriError::NotInsideRoot { root: std::fs::canonicalize(&dir).unwrap() };
        assert_eq!(root.resolve("textures"), Err(refused.clone()));
        assert_eq!(root.resolve("textures/"), Err(refused));
        assert_eq!(root.resolve("a.bin"), Ok(std::fs::canonicalize(dir.join("a.bin")).unwrap()));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// An image may be exactly `cap` bytes (`max_image_file_bytes` is the
    /// largest allowed, not the first refused); one byte more is refused,
    /// saying how large it is.
    #[test]
    fn an_image_file_of_exactly_cap_bytes_is_read_and_one_byte_more_is_too_large() {
        let dir = scratch_dir("cap");
        let path = dir.join("image.png");
        std::fs::write(&path, b"12345678").unwrap();
        assert_eq!(read_file(&path, None, 8), Ok(b"12345678".to_vec()));
        assert_eq!(read_file(&path, None, 7), Err(UriError::TooLarge { bytes: 8, max: 7 }));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A buffer file must hold at least its `byteLength`: a shorter one is
    /// an error saying how many bytes it has and how many the glTF says,
    /// not a short buffer that accessors would then be checked against.
    /// A longer one is read up to `byteLength`.
    #[test]
    fn a_buffer_file_shorter_than_its_byte_length_is_too_short() {
        let dir = scratch_dir("short");
        let path = dir.join("buffer.bin");
        std::fs::write(&path, b"123456").unwrap();
        assert_eq!(read_file(&path, Some(10), 10), Err(UriError::TooShort { got: 6, need: 10 }));
        assert_eq!(read_file(&path, Some(6), 6), Ok(b"123456".to_vec()));
        assert_eq!(read_file(&path, Some(4), 4), Ok(b"1234".to_vec()));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The image cap holds for what is read, not only for what the file's
    /// metadata claims: a regular file whose size says 0 but that holds
    /// more (a procfs file, or one that grows while read) is refused once
    /// more than `cap` bytes come out of it.
    #[cfg(target_os = "linux")]
    #[test]
    fn an_image_file_that_holds_more_than_its_metadata_says_is_still_capped() {
        let path = Path::new("/proc/self/status");
        let meta = std::fs::metadata(path).unwrap();
        assert!(meta.is_file() && meta.len() == 0, "procfs reports a regular file of 0 bytes");
        assert_eq!(read_file(path, None, 4), Err(UriError::TooLarge { bytes: 5, max: 4 }));
    }

    /// A URI scheme is a letter then letters, digits, `+`, `-` or `.`
    /// (RFC 3986): `1abc:x` and `a b:x` have none (they are relative paths
    /// with a colon in a name), while `http:`, `svn+ssh:` and a drive
    /// letter `C:` do.
    #[test]
    fn a_scheme_starts_with_a_letter_and_holds_only_scheme_characters() {
        for uri in ["http://x", "svn+ssh://x", "a.b-c:x", "C:x"] {
            assert!(has_scheme(uri), "{uri}");
        }
        for uri in ["1abc:x", "a b:x", ":x", "no-colon", "ab/c:x"] {
            assert!(!has_scheme(uri), "{uri}");
        }
    }

    /// A `data:` URI's payload may decode to exactly the cap (three bytes
    /// per four characters), not one byte more; its media type is kept
    /// when given and absent when the header is empty.
    #[test]
    fn a_data_uri_decodes_up_to_its_cap_and_keeps_its_media_type() {
        let (mime, bytes) = decode_data_uri("data:application/octet-stream;base64,AAEC", 3)
            .expect("a data: URI")
            .expect("three bytes under a cap of three");
        assert_eq!(mime.as_deref(), Some("application/octet-stream"));
        assert_eq!(bytes, [0, 1, 2]);
        let (mime, _) = decode_data_uri("data:;base64,AAEC", 3).expect("a data: URI").expect("no media type");
        assert_eq!(mime, None);
        assert!(matches!(
            decode_data_uri("data:;base64,AAECAwQF", 5),
            Some(Err(UriError::TooLarge { bytes: 6, max: 5 }))
        ));
    }

    /// A GLB's header is 12 bytes: a total below that is the header's own
    /// error, while exactly 12 (a header and nothing else) is a file
    /// without a JSON chunk.
    #[test]
    fn a_glb_total_below_its_header_is_refused_and_a_bare_header_has_no_json() {
        let glb = |total: u32| {
            let mut glb = b"glTF".to_vec();
            glb.extend(2u32.to_le_bytes());
            glb.extend(total.to_le_bytes());
            glb.extend([0u8; 8]);
            glb
        };
        let short = split_glb(&glb(8)).expect_err("a total of 8 is refused");
        assert!(short.contains("GLB header says 8 bytes"), "{short}");
        let bare = split_glb(&glb(12)).expect_err("a bare header is refused");
        assert_eq!(bare, "GLB without a JSON chunk");
    }

    /// A GLB's second chunk is its binary buffer only when its type is
    /// `BIN\0`; a chunk of another type is ignored (glTF 2.0, 4.4.3.3), not
    /// read as the buffer.
    #[test]
    fn only_a_bin_chunk_is_a_glbs_buffer() {
        let glb = |kind: &[u8; 4]| {
            let mut glb = b"glTF".to_vec();
            glb.extend(2u32.to_le_bytes());
            glb.extend(36u32.to_le_bytes());
            glb.extend(4u32.to_le_bytes());
            glb.extend(b"JSON");
            glb.extend(b"{}  ");
            glb.extend(4u32.to_le_bytes());
            glb.extend(kind);
            glb.extend([1u8, 2, 3, 4]);
            glb
        };
        assert_eq!(split_glb(&glb(b"BIN\0")).expect("a GLB").bin, Some(&[1u8, 2, 3, 4][..]));
        assert_eq!(split_glb(&glb(b"XYZ\0")).expect("a GLB").bin, None);
    }
}
