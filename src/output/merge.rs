//! `strahl merge`: joins EXR files of regions of one image (`render --region`/`--tile`, on
//! one machine or many) into the file of the whole image.
//!
//! **The rule.** Every part's pixels go to its `dataWindow` inside the common
//! `displayWindow`; the result's `dataWindow` is the whole `displayWindow`. Every channel is
//! copied, whatever its name and sample type (half, float, uint), sample for sample, and
//! every header attribute of the parts is kept. The parts must be of one render:
//!
//! - the same `strahl/sceneHash` ([`crate::scene::hash`]: scene and settings), checked first;
//! - the same header otherwise (display window, channels and their types, compression, line
//!   order, every attribute), except the attributes of one run: `capDate` and `Date` (the
//!   result has the latest), `renderTimeSeconds` and `RenderTime` (the sum), `strahl/scene`
//!   (the path as given, which may differ between machines: the top-left part's is kept),
//!   and the Cryptomatte manifests `cryptomatte/*/manifest`, which are joined: the union of
//!   their JSON objects, the first part's entries first (a name with two different ids is
//!   refused);
//! - data windows inside the display window, no two overlapping, and together covering it
//!   (the error lists the missing rectangles, `x0,y0,x1,y1` half-open).
//!
//! The parts are taken in the order of their data windows (top to bottom, then left to
//! right), so the argument order does not matter. The result is encoded by the writer every
//! render uses ([`crate::output::exr::encode_blocks`]), so merging the tiles of a render gives
//! the same bytes as rendering the whole image in one process (given fixed dates: with
//! `SOURCE_DATE_EPOCH` set, see [`crate::output::metadata`]).
//!
//! Single-part scan-line files only (what strahl writes); tiled, deep, multi-part or
//! subsampled files are refused with a message.

use std::collections::HashMap;
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use exr::block::reader::ChunksReader;
use exr::meta::attribute::{AttributeValue, IntegerBounds, Text};
use exr::meta::header::Header;
use exr::meta::{BlockDescription, MetaData};
use exr::prelude::Vec2;

use crate::output::region::{Region, uncovered};
use crate::scene::load::file::MAX_PIXELS;

/// Why parts cannot be merged: one line, naming the file(s).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct MergeError(pub String);

fn fail<T>(message: String) -> Result<T, MergeError> {
    Err(MergeError(message))
}

/// The attributes that may differ between the parts of one render (see the module docs).
const PER_RUN: [&str; 4] = ["Date", "renderTimeSeconds", "RenderTime", "strahl/scene"];

/// The scene/settings fingerprint attribute.
const SCENE_HASH: &str = "strahl/sceneHash";

/// One part: its file, header and place in the display window.
struct Part {
    path: PathBuf,
    header: Header,
    /// The data window relative to the display window's top-left corner.
    region: Region,
}

/// The merged file's bytes: the parts at `paths` joined (see the module docs), compressed on
/// `threads` threads.
pub fn merge(paths: &[PathBuf], threads: usize) -> Result<Vec<u8>, MergeError> {
    if paths.is_empty() {
        return fail("no parts to merge".into());
    }
    let mut parts = paths.iter().map(|p| read_part(p)).collect::<Result<Vec<_>, _>>()?;
    parts.sort_by_key(|p| (p.region.y0, p.region.x0));
    let first = &parts[0];
    for part in &parts[1..] {
        compare(first, part)?;
    }
    check_cover(&parts)?;

    let display = first.header.shared_attributes.display_window;
    let channels = &first.header.channels.list;
    let sample_bytes: Vec<usize> = channels.iter().map(|c| c.sample_type.bytes_per_sample()).collect();
    let width = display.size.0;
    let line_bytes = width * sample_bytes.iter().sum::<usize>();
    // A line of the frame is what a full-width block line holds: each channel's samples of the
    // line in turn. `offsets[c]` is where channel c's run starts in a line.
    let offsets: Vec<usize> =
        sample_bytes.iter().scan(0, |at, s| Some(std::mem::replace(at, *at + s * width))).collect();
    let mut frame = vec![0u8; line_bytes * display.size.1];
    for part in &parts {
        copy_pixels(part, &sample_bytes, &offsets, line_bytes, &mut frame)?;
    }

    let mut header = first.header.clone();
    header.own_attributes.layer_position = display.position;
    header.layer_size = display.size;
    let (compression, blocks, line_order) = (header.compression, header.blocks, header.line_order);
    let header = header.with_encoding(compression, blocks, line_order);
    let header = joined_attributes(header, &parts)?;
    crate::output::exr::encode_blocks(header, threads, |index| {
        let (y, h) = (index.pixel_position.1, index.pixel_size.1);
        frame[y * line_bytes..(y + h) * line_bytes].to_vec()
    })
    .map_err(|e| MergeError(format!("cannot encode the merged OpenEXR: {e}")))
}

/// Reads the header of the part at `path` and checks it is a file merge can take.
fn read_part(path: &Path) -> Result<Part, MergeError> {
    let shown = path.display();
    if !path.is_file() {
        return fail(format!("{shown}: is not a file"));
    }
    let file = File::open(path).map_err(|e| MergeError(format!("{shown}: cannot open: {e}")))?;
    let meta = MetaData::read_from_buffered(BufReader::new(file), true)
        .map_err(|e| MergeError(format!("{shown}: not a readable OpenEXR file: {e}")))?;
    let [header] = <[Header; 1]>::try_from(meta.headers.into_vec())
        .map_err(|h| MergeError(format!("{shown}: has {} parts; merge takes single-part files", h.len())))?;
    if header.deep {
        return fail(format!("{shown}: holds deep data, which merge cannot join"));
    }
    if header.blocks != BlockDescription::ScanLines {
        return fail(format!("{shown}: is tiled; merge takes scan-line files"));
    }
    if let Some(c) = header.channels.list.iter().find(|c| c.sampling != Vec2(1, 1)) {
        return fail(format!("{shown}: channel {} is subsampled; merge takes full-resolution channels", c.name));
    }
    let display = header.shared_attributes.display_window;
    if display.size.0 as u64 * display.size.1 as u64 > MAX_PIXELS {
        return fail(format!(
            "{shown}: its {} × {} display window is more than the {MAX_PIXELS} pixels strahl handles",
            display.size.0, display.size.1
        ));
    }
    let data = header.data_window();
    let relative = |a: i32, origin: i32| u32::try_from(a as i64 - origin as i64).ok();
    let region = (|| {
        let x0 = relative(data.position.0, display.position.0)?;
        let y0 = relative(data.position.1, display.position.1)?;
        let (x1, y1) = (x0.checked_add(data.size.0 as u32)?, y0.checked_add(data.size.1 as u32)?);
        let r = Region { x0, y0, x1, y1 };
        (r.x1 as usize <= display.size.0 && r.y1 as usize <= display.size.1).then_some(r)
    })()
    .ok_or_else(|| {
        MergeError(format!(
            "{shown}: its data window {} lies outside its display window {}",
            bounds(&data),
            bounds(&display)
        ))
    })?;
    Ok(Part { path: path.to_path_buf(), header, region })
}

/// `(x0, y0) – (x1, y1)`, inclusive, as `exrheader` prints windows.
fn bounds(b: &IntegerBounds) -> String {
    let max = b.max();
    format!("({} {}) - ({} {})", b.position.0, b.position.1, max.0, max.1)
}

/// A region in the file's own coordinates (the display window's origin added back).
fn absolute(r: &Region, display: &IntegerBounds) -> String {
    let (ox, oy) = (display.position.0 as i64, display.position.1 as i64);
    format!("{},{},{},{}", r.x0 as i64 + ox, r.y0 as i64 + oy, r.x1 as i64 + ox, r.y1 as i64 + oy)
}

fn text_attribute(header: &Header, name: &str) -> Option<String> {
    match header.own_attributes.other.get(&Text::from(name)) {
        Some(AttributeValue::Text(t)) => Some(t.to_string()),
        Some(other) => Some(format!("{other:?}")),
        None => None,
    }
}

fn is_manifest(name: &str) -> bool {
    name.starts_with("cryptomatte/") && name.ends_with("/manifest")
}

/// The header with what may differ between parts taken out (see the module docs).
fn comparable(header: &Header) -> Header {
    let mut h = header.clone();
    h.layer_size = Vec2(0, 0);
    h.chunk_count = 0;
    h.own_attributes.layer_position = Vec2(0, 0);
    h.own_attributes.capture_date = None;
    h.own_attributes.other.retain(|name, _| {
        let name = name.to_string();
        !PER_RUN.contains(&name.as_str()) && !is_manifest(&name)
    });
    h
}

/// Refuses `part` unless it is of the same render as `first` (see the module docs).
fn compare(first: &Part, part: &Part) -> Result<(), MergeError> {
    let (a, b) = (first.path.display(), part.path.display());
    let (ha, hb) = (text_attribute(&first.header, SCENE_HASH), text_attribute(&part.header, SCENE_HASH));
    if ha != hb {
        let show = |h: Option<String>| h.unwrap_or_else(|| "none".into());
        return fail(format!(
            "{b}: scene/settings hash {} differs from {a}'s {}: the parts are of different scenes or settings",
            show(hb),
            show(ha)
        ));
    }
    let (x, y) = (comparable(&first.header), comparable(&part.header));
    if x == y {
        return Ok(());
    }
    let what = if x.shared_attributes.display_window != y.shared_attributes.display_window {
        format!(
            "display window {} differs from {a}'s {}",
            bounds(&y.shared_attributes.display_window),
            bounds(&x.shared_attributes.display_window)
        )
    } else if x.channels != y.channels {
        let names = |h: &Header| {
            h.channels.list.iter().map(|c| format!("{}:{:?}", c.name, c.sample_type)).collect::<Vec<_>>().join(" ")
        };
        format!("channels [{}] differ from {a}'s [{}]", names(&y), names(&x))
    } else if x.compression != y.compression {
        format!("compression {:?} differs from {a}'s {:?}", y.compression, x.compression)
    } else if let Some(name) = differing_attribute(&x.own_attributes.other, &y.own_attributes.other)
        .or_else(|| differing_attribute(&x.shared_attributes.other, &y.shared_attributes.other))
    {
        format!("attribute {name} differs from {a}'s")
    } else {
        format!("its header differs from {a}'s ({:?} vs {:?})", y.own_attributes, x.own_attributes)
    };
    fail(format!("{b}: {what}: the parts are not of one render"))
}

/// The name of an attribute present in one map and not the other, or with another value.
fn differing_attribute(a: &HashMap<Text, AttributeValue>, b: &HashMap<Text, AttributeValue>) -> Option<String> {
    let mut names: Vec<String> = a.keys().chain(b.keys()).map(|k| k.to_string()).collect();
    names.sort();
    names.into_iter().find(|n| a.get(&Text::from(n.as_str())) != b.get(&Text::from(n.as_str())))
}

/// Refuses overlapping parts and an incomplete cover of the display window.
fn check_cover(parts: &[Part]) -> Result<(), MergeError> {
    let display = parts[0].header.shared_attributes.display_window;
    for (i, p) in parts.iter().enumerate() {
        for q in &parts[i + 1..] {
            if let Some(both) = p.region.intersection(&q.region) {
                return fail(format!(
                    "{} and {} overlap in {} (x0,y0,x1,y1, half-open)",
                    p.path.display(),
                    q.path.display(),
                    absolute(&both, &display)
                ));
            }
        }
    }
    let whole = Region::full(display.size.0 as u32, display.size.1 as u32);
    let regions: Vec<Region> = parts.iter().map(|p| p.region).collect();
    let missing = uncovered(&whole, &regions);
    if !missing.is_empty() {
        const SHOWN: usize = 8;
        let mut list: Vec<String> = missing.iter().take(SHOWN).map(|r| absolute(r, &display)).collect();
        if missing.len() > SHOWN {
            list.push(format!("and {} more", missing.len() - SHOWN));
        }
        return fail(format!(
            "the parts do not cover the {} × {} image: missing {} (x0,y0,x1,y1, half-open)",
            whole.x1,
            whole.y1,
            list.join("; ")
        ));
    }
    Ok(())
}

/// Decompresses `part`'s blocks into its place in `frame` (lines of `line_bytes`, each
/// channel's run at `offsets[c]`).
fn copy_pixels(
    part: &Part,
    sample_bytes: &[usize],
    offsets: &[usize],
    line_bytes: usize,
    frame: &mut [u8],
) -> Result<(), MergeError> {
    let shown = part.path.display();
    let broken = |e: exr::error::Error| MergeError(format!("{shown}: cannot read its pixels: {e}"));
    let file = File::open(&part.path).map_err(|e| MergeError(format!("{shown}: cannot open: {e}")))?;
    let reader = exr::block::read(BufReader::new(file), true).map_err(broken)?;
    let chunks = reader.all_chunks(true).map_err(broken)?;
    let expected = part.header.chunk_count;
    let mut seen = 0usize;
    chunks
        .decompress_sequential(true, |_, block| {
            let (bx, by) = (block.index.pixel_position.0, block.index.pixel_position.1);
            let (w, h) = (block.index.pixel_size.0, block.index.pixel_size.1);
            let mut at = 0;
            for line in 0..h {
                let y = part.region.y0 as usize + by + line;
                for (c, &s) in sample_bytes.iter().enumerate() {
                    let run = w * s;
                    let src = block.data.get(at..at + run).ok_or_else(|| {
                        exr::error::Error::Invalid(format!("the block at line {by} is shorter than its size").into())
                    })?;
                    let dst = y * line_bytes + offsets[c] + (part.region.x0 as usize + bx) * s;
                    frame[dst..dst + run].copy_from_slice(src);
                    at += run;
                }
            }
            seen += 1;
            Ok(())
        })
        .map_err(broken)?;
    if seen != expected {
        return fail(format!("{shown}: has {seen} of its {expected} blocks of pixels"));
    }
    Ok(())
}

/// `header` (the first part's, resized) with the attributes of one run joined over `parts`.
fn joined_attributes(mut header: Header, parts: &[Part]) -> Result<Header, MergeError> {
    let latest = |get: &dyn Fn(&Header) -> Option<String>| parts.iter().filter_map(|p| get(&p.header)).max();
    header.own_attributes.capture_date =
        latest(&|h| h.own_attributes.capture_date.as_ref().map(|t| t.to_string())).map(|t| Text::from(t.as_str()));
    let other = &mut header.own_attributes.other;
    if let Some(date) = latest(&|h| text_attribute(h, "Date")) {
        other.insert(Text::from("Date"), AttributeValue::Text(Text::from(date.as_str())));
    }
    let times: Vec<f32> = parts
        .iter()
        .filter_map(|p| match p.header.own_attributes.other.get(&Text::from("renderTimeSeconds")) {
            Some(AttributeValue::F32(t)) => Some(*t),
            _ => None,
        })
        .collect();
    if !times.is_empty() {
        let total: f64 = times.iter().map(|&t| t as f64).sum();
        other.insert(Text::from("renderTimeSeconds"), AttributeValue::F32(total as f32));
        if other.contains_key(&Text::from("RenderTime")) {
            let text = crate::output::metadata::render_time_text(total);
            other.insert(Text::from("RenderTime"), AttributeValue::Text(Text::from(text.as_str())));
        }
    }
    let manifests: Vec<Text> = other.keys().filter(|k| is_manifest(&k.to_string())).cloned().collect();
    for key in manifests {
        let name = key.to_string();
        let texts: Vec<(String, &Path)> = parts
            .iter()
            .filter_map(|p| match p.header.own_attributes.other.get(&key) {
                Some(AttributeValue::Text(t)) => Some((t.to_string(), p.path.as_path())),
                _ => None,
            })
            .collect();
        let joined = join_manifests(&name, &texts)?;
        let value = Text::new_or_none(joined.as_str())
            .ok_or_else(|| MergeError(format!("{name}: the joined manifest is not Latin-1 text")))?;
        other.insert(key, AttributeValue::Text(value));
    }
    Ok(header)
}

/// The union of Cryptomatte manifests (`{"name":"hex",…}`): the text itself when all agree,
/// else the first's entries in order, then each further name in the order it appears.
fn join_manifests(attribute: &str, texts: &[(String, &Path)]) -> Result<String, MergeError> {
    let Some((first, _)) = texts.first() else { return Ok(String::new()) };
    if texts.iter().all(|(t, _)| t == first) {
        return Ok(first.clone());
    }
    let mut entries: Vec<(String, String)> = Vec::new();
    for (text, path) in texts {
        let parsed: OrderedObject = serde_json::from_str(text)
            .map_err(|e| MergeError(format!("{}: {attribute} is not a JSON object of names: {e}", path.display())))?;
        for (name, id) in parsed.0 {
            match entries.iter().find(|(n, _)| *n == name) {
                Some((_, known)) if *known != id => {
                    return fail(format!(
                        "{}: {attribute} gives '{name}' the id {id}, another part {known}",
                        path.display()
                    ));
                }
                Some(_) => {}
                None => entries.push((name, id)),
            }
        }
    }
    let json = |s: &str| serde_json::to_string(s).unwrap_or_default();
    let body: Vec<String> = entries.iter().map(|(n, id)| format!("{}:{}", json(n), json(id))).collect();
    Ok(format!("{{{}}}", body.join(",")))
}

/// A JSON object of strings, its entries in the order of the text.
struct OrderedObject(Vec<(String, String)>);

impl<'de> serde::Deserialize<'de> for OrderedObject {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = OrderedObject;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("an object of strings")
            }
            fn visit_map<M: serde::de::MapAccess<'de>>(self, mut map: M) -> Result<OrderedObject, M::Error> {
                let mut out = Vec::new();
                while let Some(entry) = map.next_entry::<String, String>()? {
                    out.push(entry);
                }
                Ok(OrderedObject(out))
            }
        }
        d.deserialize_map(Visitor)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manifests_join_as_a_union_in_order() {
        let p = Path::new("a.exr");
        let same = join_manifests("m", &[("{\"x\":\"01\"}".into(), p), ("{\"x\":\"01\"}".into(), p)]).unwrap();
        assert_eq!(same, "{\"x\":\"01\"}");
        let texts = [("{\"b\":\"02\",\"a\":\"01\"}".into(), p), ("{\"c\":\"03\",\"a\":\"01\"}".into(), p)];
        assert_eq!(join_manifests("m", &texts).unwrap(), "{\"b\":\"02\",\"a\":\"01\",\"c\":\"03\"}");
        let clash = [("{\"a\":\"01\"}".into(), p), ("{\"a\":\"02\"}".into(), p)];
        assert!(join_manifests("m", &clash).unwrap_err().to_string().contains("'a'"));
        assert!(join_manifests("m", &[("{}".into(), p), ("[1]".into(), p)]).is_err());
    }
}
