//! PLY (Stanford polygon file) reader: `ascii`, `binary_little_endian` and
//! `binary_big_endian` bodies after a text header.
//!
//! Read from the `vertex` element: `x y z` (required), `nx ny nz`, texture coordinates as
//! `u v`, `s t`, `texture_u texture_v` or `texture_s texture_t`, and colours `red green blue`
//! (or `diffuse_red …`), integers scaled by their type's maximum (uchar 0–255 → 0–1) and
//! floats taken as they are. Read from the `face` element: the `vertex_indices` (or
//! `vertex_index`) list, of any count and index type, wherever it stands among the other
//! properties; polygons are triangulated in their plane. Every other property and element
//! (edges, materials, range grids, lists anywhere) is skipped. The file defines no materials:
//! the loaded list is one default material, which every triangle uses.
//!
//! A hand-written reader rather than a crate: on the 34 MB ASCII Stanford dragon (871,414
//! triangles), `ply-rs-bw` 4.0.1 with typed elements took 415–445 ms to parse and `ply-rs`
//! 0.1.3 1.5 s (release, this machine, noisy), where this one needs about a fifth of the
//! first (see `benches/load.rs`). It also reports `file:line: problem` for ASCII data.
//!
//! An ASCII body holds one element per line (blank lines are skipped), as the format says.

use std::path::Path;

use super::mesh::{LoadedMesh, MeshError, MeshOptions, Parsed, RawMesh, finish};
use super::polygon;
use super::text::{self, parse_f32, parse_i64, show};
use crate::material::Material;
use crate::math::{Vec2, Vec3};
use crate::scene::Mesh;

/// A PLY scalar type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &[u8]) -> Option<Scalar> {
        Some(match name {
            b"char" | b"int8" => Scalar::I8,
            b"uchar" | b"uint8" => Scalar::U8,
            b"short" | b"int16" => Scalar::I16,
            b"ushort" | b"uint16" => Scalar::U16,
            b"int" | b"int32" => Scalar::I32,
            b"uint" | b"uint32" => Scalar::U32,
            b"float" | b"float32" => Scalar::F32,
            b"double" | b"float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_float(self) -> bool {
        matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// The factor that maps this type's values onto 0–1 for colours.
    fn color_scale(self) -> f32 {
        match self {
            Scalar::I8 => 1.0 / 127.0,
            Scalar::U8 => 1.0 / 255.0,
            Scalar::I16 => 1.0 / 32767.0,
            Scalar::U16 => 1.0 / 65535.0,
            Scalar::I32 => 1.0 / 2147483647.0,
            Scalar::U32 => 1.0 / 4294967295.0,
            Scalar::F32 | Scalar::F64 => 1.0,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    kind: Kind,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
    /// Header line that declares it.
    line: usize,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encoding {
    Ascii,
    LittleEndian,
    BigEndian,
}

struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    /// Byte offset of the body.
    body: usize,
    /// Number of the body's first line (ASCII).
    body_line: usize,
}

fn parse_header(path: &Path, data: &[u8], warnings: &mut Vec<String>) -> Result<Header, MeshError> {
    let mut pos = 0;
    let mut line_no = 0;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some(nl) = data[pos..].iter().position(|&b| b == b'\n') else {
            return Err(if line_no == 0 {
                MeshError::invalid(path, if data.is_empty() { "empty file" } else { "not a PLY file" })
            } else {
                MeshError::invalid(path, "the header has no end_header line")
            });
        };
        let raw = &data[pos..pos + nl];
        pos += nl + 1;
        line_no += 1;
        let line = text::trim(raw);
        let mut words = text::tokens(line);
        let keyword = words.next().unwrap_or(b"");
        let at = |problem: String| MeshError::at(path, line_no, problem);
        if line_no == 1 {
            if line != b"ply" {
                return Err(MeshError::invalid(path, "not a PLY file (the first line is not 'ply')"));
            }
            continue;
        }
        match keyword {
            b"format" => {
                let name = words.next().unwrap_or(b"");
                encoding = Some(match name {
                    b"ascii" => Encoding::Ascii,
                    b"binary_little_endian" => Encoding::LittleEndian,
                    b"binary_big_endian" => Encoding::BigEndian,
                    _ => return Err(MeshError::invalid(path, format!("unknown PLY format '{}'", show(name)))),
                });
            }
            b"element" => {
                let (Some(name), Some(count)) = (words.next(), words.next()) else {
                    return Err(at("an element needs a name and a count".into()));
                };
                let count = parse_i64(count)
                    .and_then(|c| usize::try_from(c).ok())
                    .ok_or_else(|| at(format!("element count '{}' is not a number ≥ 0", show(count))))?;
                let name = String::from_utf8_lossy(name).into_owned();
                if elements.iter().any(|e| e.name == name) {
                    return Err(at(format!("element '{name}' declared twice")));
                }
                elements.push(Element { name, count, properties: Vec::new(), line: line_no });
            }
            b"property" => {
                let Some(element) = elements.last_mut() else {
                    return Err(at("a property before any element".into()));
                };
                let ty = |w: Option<&[u8]>| {
                    let w = w.unwrap_or(b"");
                    Scalar::parse(w).ok_or_else(|| at(format!("unknown property type '{}'", show(w))))
                };
                let first = words.next();
                let kind = if first == Some(b"list") {
                    let count = ty(words.next())?;
                    let item = ty(words.next())?;
                    if count.is_float() {
                        return Err(at("a list count must be an integer type".into()));
                    }
                    Kind::List { count, item }
                } else {
                    Kind::Scalar(ty(first)?)
                };
                let name = words.next().ok_or_else(|| at("a property needs a name".into()))?;
                let name = String::from_utf8_lossy(name).into_owned();
                if element.properties.iter().any(|p| p.name == name) {
                    return Err(at(format!("property '{name}' declared twice in element '{}'", element.name)));
                }
                element.properties.push(Property { name, kind });
            }
            b"end_header" => break,
            b"comment" | b"obj_info" | b"" => {}
            _ => {
                warnings.push(format!("{}:{line_no}: header line '{}' is not PLY; ignored", path.display(), show(line)))
            }
        }
    }
    let encoding = encoding.ok_or_else(|| MeshError::invalid(path, "the header has no format line"))?;
    Ok(Header { encoding, elements, body: pos, body_line: line_no + 1 })
}

/// Where a vertex property's value goes.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Slot {
    Skip,
    Position(usize),
    Normal(usize),
    Uv(usize),
    Color(usize, f32),
}

/// The vertex element's properties mapped to slots, and which optional arrays it fills.
struct VertexPlan {
    slots: Vec<Slot>,
    normals: bool,
    uvs: bool,
    colors: bool,
}

fn vertex_plan(path: &Path, e: &Element, warnings: &mut Vec<String>) -> Result<VertexPlan, MeshError> {
    let find = |name: &str| e.properties.iter().position(|p| p.name == name && matches!(p.kind, Kind::Scalar(_)));
    let mut slots = vec![Slot::Skip; e.properties.len()];
    let all = |names: &[&str]| names.iter().map(|n| find(n)).collect::<Option<Vec<usize>>>();
    let xyz = all(&["x", "y", "z"]).ok_or_else(|| {
        MeshError::at(path, e.line, "the vertex element has no scalar x, y and z properties".to_string())
    })?;
    for (k, i) in xyz.into_iter().enumerate() {
        slots[i] = Slot::Position(k);
    }
    let normals = match all(&["nx", "ny", "nz"]) {
        Some(n) => {
            n.into_iter().enumerate().for_each(|(k, i)| slots[i] = Slot::Normal(k));
            true
        }
        None => false,
    };
    if !normals && ["nx", "ny", "nz"].iter().any(|n| find(n).is_some()) {
        warnings.push(format!("{}:{}: incomplete normals (not all of nx ny nz); ignored", path.display(), e.line));
    }
    let uv_pair = [["u", "v"], ["s", "t"], ["texture_u", "texture_v"], ["texture_s", "texture_t"]]
        .iter()
        .find_map(|names| all(names));
    if let Some(uv) = &uv_pair {
        uv.iter().enumerate().for_each(|(k, &i)| slots[i] = Slot::Uv(k));
    }
    let rgb = all(&["red", "green", "blue"]).or_else(|| all(&["diffuse_red", "diffuse_green", "diffuse_blue"]));
    if let Some(rgb) = &rgb {
        for (k, &i) in rgb.iter().enumerate() {
            let Kind::Scalar(s) = e.properties[i].kind else { unreachable!("found as scalar") };
            slots[i] = Slot::Color(k, s.color_scale());
        }
    }
    Ok(VertexPlan { slots, normals, uvs: uv_pair.is_some(), colors: rgb.is_some() })
}

/// The vertex arrays being filled.
#[derive(Default)]
struct Vertices {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    colors: Vec<Vec3>,
}

impl Vertices {
    fn with_capacity(plan: &VertexPlan, n: usize) -> Vertices {
        let cap = |on: bool| if on { n } else { 0 };
        Vertices {
            positions: Vec::with_capacity(n),
            normals: Vec::with_capacity(cap(plan.normals)),
            uvs: Vec::with_capacity(cap(plan.uvs)),
            colors: Vec::with_capacity(cap(plan.colors)),
        }
    }

    /// Stores one vertex's values (one per slot; `Skip` slots ignored). Returns the name of
    /// the first non-finite position or normal component, if any.
    fn push(&mut self, plan: &VertexPlan, values: &[f32]) -> Option<&'static str> {
        let (mut p, mut n, mut uv, mut c) = ([0.0f32; 3], [0.0f32; 3], [0.0f32; 2], [0.0f32; 3]);
        for (slot, &v) in plan.slots.iter().zip(values) {
            match *slot {
                Slot::Skip => {}
                Slot::Position(k) => p[k] = v,
                Slot::Normal(k) => n[k] = v,
                Slot::Uv(k) => uv[k] = v,
                Slot::Color(k, scale) => c[k] = v * scale,
            }
        }
        self.positions.push(Vec3::from(p));
        if plan.normals {
            self.normals.push(Vec3::from(n));
        }
        if plan.uvs {
            self.uvs.push(Vec2::from(uv));
        }
        if plan.colors {
            self.colors.push(Vec3::from(c));
        }
        if !Vec3::from(p).is_finite() {
            Some("position")
        } else if !Vec3::from(n).is_finite() {
            Some("normal")
        } else {
            None
        }
    }
}

/// The faces being read: all corners in one array, each face's corner count beside it, and
/// where the non-triangles stand in the file (for messages).
#[derive(Default)]
struct Faces {
    corners: Vec<u32>,
    sizes: Vec<u32>,
    /// (face number, ASCII line or 0) of every face with more than three corners.
    polygons: Vec<(usize, usize)>,
}

fn plural(element: &str) -> String {
    match element {
        "vertex" => "vertices".into(),
        "face" => "faces".into(),
        other => format!("'{other}' elements"),
    }
}

/// Parses a PLY file's bytes (`path` names it in messages).
pub fn parse(path: &Path, data: &[u8], options: &MeshOptions) -> Result<LoadedMesh, MeshError> {
    let mut warnings = Vec::new();
    let header = parse_header(path, data, &mut warnings)?;
    let vertex_element = header.elements.iter().find(|e| e.name == "vertex");
    let n_vertices = vertex_element.map_or(0, |e| e.count);
    if n_vertices > u32::MAX as usize {
        return Err(MeshError::invalid(path, format!("{n_vertices} vertices are more than 32-bit indices address")));
    }
    let face_list = match header.elements.iter().find(|e| e.name == "face") {
        Some(e) => Some(
            e.properties
                .iter()
                .position(|p| {
                    matches!(p.kind, Kind::List { .. }) && matches!(&*p.name, "vertex_indices" | "vertex_index")
                })
                .ok_or_else(|| MeshError::at(path, e.line, "the face element has no vertex_indices list"))?,
        ),
        None => None,
    };
    if face_list.is_some() && vertex_element.is_none() {
        return Err(MeshError::invalid(path, "faces but no vertex element"));
    }
    let plan = match vertex_element {
        Some(e) => Some(vertex_plan(path, e, &mut warnings)?),
        None => None,
    };
    for e in header.elements.iter().filter(|e| e.name != "vertex" && e.name != "face") {
        warnings.push(format!("{}:{}: element '{}' ({} items) skipped", path.display(), e.line, e.name, e.count));
    }

    let mut vertices = Vertices::default();
    let mut faces = Faces::default();
    let body = &data[header.body..];
    match header.encoding {
        Encoding::Ascii => {
            read_ascii(path, &header, body, plan.as_ref(), face_list, n_vertices, &mut vertices, &mut faces)?
        }
        e => read_binary(
            path,
            &header,
            body,
            e == Encoding::BigEndian,
            plan.as_ref(),
            face_list,
            n_vertices,
            &mut vertices,
            &mut faces,
        )?,
    }

    // Triangulate in file order.
    let mut triangles = Vec::with_capacity(faces.sizes.len());
    let mut triangles_read = 0;
    let mut degenerate = 0;
    let mut start = 0usize;
    let mut polygons = faces.polygons.iter();
    let mut scratch = Vec::new();
    let mut corners3 = Vec::new();
    let mut fallbacks = polygon::Fallbacks::default();
    for &size in &faces.sizes {
        let size = size as usize;
        let c = &faces.corners[start..start + size];
        start += size;
        triangles_read += size - 2;
        if size == 3 {
            triangles.push([c[0], c[1], c[2]]);
            continue;
        }
        let &(face, line) = polygons.next().expect("every polygon was recorded");
        corners3.clear();
        corners3.extend(c.iter().map(|&i| vertices.positions[i as usize]));
        scratch.clear();
        let how = polygon::triangulate(&corners3, &mut scratch);
        fallbacks.count(how, || if line == 0 { format!(", face {face}") } else { format!(":{line}") });
        degenerate += size - 2 - scratch.len();
        triangles.extend(scratch.iter().map(|t| t.map(|k| c[k as usize])));
    }
    warnings.extend(fallbacks.warning(path));

    let name = path.file_name().map_or_else(|| "ply".into(), |n| n.to_string_lossy().into_owned());
    let Vertices { positions, normals, uvs, colors } = vertices;
    let plan = plan.unwrap_or(VertexPlan { slots: vec![], normals: false, uvs: false, colors: false });
    let raw = RawMesh {
        name,
        positions,
        normals: plan.normals.then_some(normals),
        uvs: plan.uvs.then_some(uvs),
        colors: plan.colors.then_some(colors),
        triangles,
        triangle_materials: Vec::new(),
    };
    let parsed = Parsed {
        meshes: vec![raw],
        materials: vec![Material::default()],
        warnings,
        triangles_read,
        degenerate,
        vertices_in_file: n_vertices,
    };
    finish(path, parsed, options)
}

/// Reads a face's index list into `faces`, checking every index against `n_vertices`.
fn push_face(faces: &mut Faces, indices: &[i64], n_vertices: usize, line: usize) -> Result<(), String> {
    let count = indices.len();
    if count < 3 {
        return Err(format!("face has {count} vertices (a polygon needs at least 3)"));
    }
    for &index in indices {
        if index < 0 || index as usize >= n_vertices {
            return Err(format!("face index {index} out of range ({n_vertices} vertices)"));
        }
        faces.corners.push(index as u32);
    }
    if count > 3 {
        faces.polygons.push((faces.sizes.len(), line));
    }
    faces.sizes.push(count as u32);
    Ok(())
}

/// A cursor over an ASCII body: tokens within a line, lines counted as it goes.
struct Scan<'a> {
    data: &'a [u8],
    pos: usize,
    line: usize,
}

impl<'a> Scan<'a> {
    /// Moves to the first token of the next non-blank line; `false` at the end of the data.
    fn next_line(&mut self) -> bool {
        while let Some(&b) = self.data.get(self.pos) {
            match b {
                b'\n' => self.line += 1,
                b' ' | b'\t' | b'\r' | 0x0b | 0x0c => {}
                _ => return true,
            }
            self.pos += 1;
        }
        false
    }

    /// The next token on the current line, `None` at its end.
    #[inline]
    fn token(&mut self) -> Option<&'a [u8]> {
        while let Some(&b) = self.data.get(self.pos) {
            if !matches!(b, b' ' | b'\t' | b'\r' | 0x0b | 0x0c) {
                break;
            }
            self.pos += 1;
        }
        let start = self.pos;
        while let Some(&b) = self.data.get(self.pos) {
            if b.is_ascii_whitespace() {
                break;
            }
            self.pos += 1;
        }
        (self.pos > start).then(|| &self.data[start..self.pos])
    }
}

#[allow(clippy::too_many_arguments)]
fn read_ascii(
    path: &Path,
    header: &Header,
    body: &[u8],
    plan: Option<&VertexPlan>,
    face_list: Option<usize>,
    n_vertices: usize,
    vertices: &mut Vertices,
    faces: &mut Faces,
) -> Result<(), MeshError> {
    let mut scan = Scan { data: body, pos: 0, line: header.body_line };
    let mut values = Vec::new();
    let mut corners = Vec::new();
    for e in &header.elements {
        let is_vertex = e.name == "vertex";
        let is_face = e.name == "face";
        if is_vertex {
            let cap = e.count.min(body.len() / 6);
            *vertices = Vertices::with_capacity(plan.expect("a vertex element has a plan"), cap);
        }
        // Each item is a line of at least one byte: a count the rest of the file cannot hold is
        // refused before its loop runs.
        let remaining = body.len() - scan.pos;
        if e.count > remaining {
            return Err(MeshError::at(
                path,
                e.line,
                format!(
                    "element '{}' declares {} items, but only {remaining} bytes remain (each needs a line)",
                    e.name, e.count
                ),
            ));
        }
        if is_face {
            faces.sizes.reserve(e.count.min(body.len() / 6));
            faces.corners.reserve(3 * e.count.min(body.len() / 6));
        }
        for i in 0..e.count {
            if !scan.next_line() {
                return Err(MeshError::at(
                    path,
                    scan.line,
                    format!("the file ends after {i} of {} {}", e.count, plural(&e.name)),
                ));
            }
            let line_no = scan.line;
            let at = |problem: String| MeshError::at(path, line_no, problem);
            let missing =
                |what: &str| at(format!("missing {what}: the line has fewer values than the header declares"));
            if !is_vertex && !is_face {
                while scan.token().is_some() {}
                continue;
            }
            if is_vertex {
                values.clear();
                for p in &e.properties {
                    let w = scan.token().ok_or_else(|| missing(&p.name))?;
                    match p.kind {
                        Kind::Scalar(s) => {
                            let v = if s.is_float() { parse_f32(w) } else { parse_i64(w).map(|i| i as f32) };
                            values.push(v.ok_or_else(|| at(format!("'{}' is not a {s:?} for {}", show(w), p.name)))?);
                        }
                        Kind::List { .. } => {
                            let n = parse_i64(w).filter(|&n| n >= 0).ok_or_else(|| at(bad_count(w)))?;
                            for _ in 0..n {
                                scan.token().ok_or_else(|| missing(&p.name))?;
                            }
                            values.push(0.0);
                        }
                    }
                }
                if let Some(what) = vertices.push(plan.expect("vertex plan"), &values) {
                    return Err(at(format!("vertex {i} has a non-finite {what}")));
                }
            } else {
                for (k, p) in e.properties.iter().enumerate() {
                    let w = scan.token().ok_or_else(|| missing(&p.name))?;
                    let Kind::List { item, .. } = p.kind else { continue };
                    let n = parse_i64(w).filter(|&n| n >= 0).ok_or_else(|| at(bad_count(w)))? as usize;
                    if Some(k) == face_list {
                        corners.clear();
                        for _ in 0..n {
                            let w = scan.token().ok_or_else(|| missing("face index"))?;
                            let v = if item.is_float() { None } else { parse_i64(w) };
                            corners.push(v.ok_or_else(|| at(format!("'{}' is not a face index", show(w))))?);
                        }
                        push_face(faces, &corners, n_vertices, line_no).map_err(at)?;
                    } else {
                        for _ in 0..n {
                            scan.token().ok_or_else(|| missing(&p.name))?;
                        }
                    }
                }
            }
            if let Some(extra) = scan.token() {
                return Err(at(format!(
                    "more values than the header declares for a {} ('{}')",
                    if is_vertex { "vertex" } else { "face" },
                    show(extra)
                )));
            }
        }
    }
    Ok(())
}

fn bad_count(w: &[u8]) -> String {
    format!("list count '{}' is not a number ≥ 0", show(w))
}

/// A cursor over binary PLY data.
struct Binary<'a> {
    data: &'a [u8],
    pos: usize,
    big: bool,
}

impl Binary<'_> {
    fn take<const N: usize>(&mut self) -> Option<[u8; N]> {
        let bytes: [u8; N] = self.data.get(self.pos..self.pos + N)?.try_into().ok()?;
        self.pos += N;
        Some(bytes)
    }

    /// The next value of type `s` as f64 (exact for every PLY type); `None` at the end.
    fn value(&mut self, s: Scalar) -> Option<f64> {
        macro_rules! num {
            ($t:ty, $n:expr) => {{
                let b = self.take::<$n>()?;
                (if self.big { <$t>::from_be_bytes(b) } else { <$t>::from_le_bytes(b) }) as f64
            }};
        }
        Some(match s {
            Scalar::I8 => self.take::<1>()?[0] as i8 as f64,
            Scalar::U8 => self.take::<1>()?[0] as f64,
            Scalar::I16 => num!(i16, 2),
            Scalar::U16 => num!(u16, 2),
            Scalar::I32 => num!(i32, 4),
            Scalar::U32 => num!(u32, 4),
            Scalar::F32 => num!(f32, 4),
            Scalar::F64 => num!(f64, 8),
        })
    }

    fn skip(&mut self, bytes: usize) -> Option<()> {
        let end = self.pos.checked_add(bytes).filter(|&e| e <= self.data.len())?;
        self.pos = end;
        Some(())
    }
}

#[allow(clippy::too_many_arguments)]
fn read_binary(
    path: &Path,
    header: &Header,
    body: &[u8],
    big: bool,
    plan: Option<&VertexPlan>,
    face_list: Option<usize>,
    n_vertices: usize,
    vertices: &mut Vertices,
    faces: &mut Faces,
) -> Result<(), MeshError> {
    let mut bin = Binary { data: body, pos: 0, big };
    let mut values = Vec::new();
    let mut corners = Vec::new();
    for e in &header.elements {
        let truncated = |i: usize| {
            MeshError::invalid(path, format!("truncated binary PLY: {i} of {} {}", e.count, plural(&e.name)))
        };
        // The smallest an item can be: a bound on how many the rest of the file can hold.
        let min_size: usize = e
            .properties
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(s) => s.size(),
                Kind::List { count, .. } => count.size(),
            })
            .sum();
        // Every element's count is checked against the bytes left before its loop runs, so no
        // loop's count comes from the header alone. An item of no bytes at all (an element
        // without properties) cannot be checked, and means nothing: refused when there are any.
        let remaining = body.len() - bin.pos;
        if min_size == 0 && e.count > 0 {
            return Err(MeshError::at(
                path,
                e.line,
                format!("element '{}' has {} items but no properties (nothing to read)", e.name, e.count),
            ));
        }
        let fits = remaining / min_size.max(1);
        if e.count > fits {
            return Err(MeshError::at(
                path,
                e.line,
                format!(
                    "element '{}' declares {} items of at least {min_size} bytes each, but only {remaining} bytes \
                     remain (truncated or corrupt binary PLY)",
                    e.name, e.count
                ),
            ));
        }
        if e.name == "vertex" {
            *vertices = Vertices::with_capacity(plan.expect("a vertex element has a plan"), e.count.min(fits));
        }
        for i in 0..e.count {
            if e.name == "vertex" {
                values.clear();
                for p in &e.properties {
                    match p.kind {
                        Kind::Scalar(s) => values.push(bin.value(s).ok_or_else(|| truncated(i))? as f32),
                        Kind::List { count, item } => {
                            let n = list_count(&mut bin, count).ok_or_else(|| truncated(i))?;
                            bin.skip(n * item.size()).ok_or_else(|| truncated(i))?;
                            values.push(0.0);
                        }
                    }
                }
                if let Some(what) = vertices.push(plan.expect("vertex plan"), &values) {
                    return Err(MeshError::invalid(path, format!("vertex {i} has a non-finite {what}")));
                }
            } else if e.name == "face" {
                for (k, p) in e.properties.iter().enumerate() {
                    match p.kind {
                        Kind::Scalar(s) => bin.skip(s.size()).ok_or_else(|| truncated(i))?,
                        Kind::List { count, item } => {
                            let n = list_count(&mut bin, count).ok_or_else(|| truncated(i))?;
                            if Some(k) != face_list {
                                bin.skip(n * item.size()).ok_or_else(|| truncated(i))?;
                                continue;
                            }
                            if item.is_float() {
                                return Err(MeshError::invalid(path, "face indices of a floating-point type"));
                            }
                            corners.clear();
                            for _ in 0..n {
                                corners.push(bin.value(item).ok_or_else(|| truncated(i))? as i64);
                            }
                            push_face(faces, &corners, n_vertices, 0)
                                .map_err(|p| MeshError::invalid(path, format!("face {i}: {p}")))?;
                        }
                    }
                }
            } else {
                for p in &e.properties {
                    match p.kind {
                        Kind::Scalar(s) => bin.skip(s.size()).ok_or_else(|| truncated(i))?,
                        Kind::List { count, item } => {
                            let n = list_count(&mut bin, count).ok_or_else(|| truncated(i))?;
                            bin.skip(n * item.size()).ok_or_else(|| truncated(i))?;
                        }
                    }
                }
            }
        }
    }
    Ok(())
}

/// A list's length; `None` at the end of the data (a negative count reads as the end too: no
/// file can hold it).
fn list_count(bin: &mut Binary, count: Scalar) -> Option<usize> {
    let n = bin.value(count)?;
    if n < 0.0 { None } else { Some(n as usize) }
}

/// Writes `mesh` as an ASCII PLY: positions, normals when it has them (six decimals, so the
/// text is the same wherever the numbers were computed to within rounding), and triangles.
pub fn write_ascii(mesh: &Mesh, out: &mut impl std::io::Write, comment: &str) -> std::io::Result<()> {
    writeln!(out, "ply\nformat ascii 1.0\ncomment {comment}\nelement vertex {}", mesh.positions.len())?;
    writeln!(out, "property float x\nproperty float y\nproperty float z")?;
    if mesh.normals.is_some() {
        writeln!(out, "property float nx\nproperty float ny\nproperty float nz")?;
    }
    writeln!(out, "element face {}\nproperty list uchar uint vertex_indices\nend_header", mesh.indices.len())?;
    for (i, p) in mesh.positions.iter().enumerate() {
        write!(out, "{:.6} {:.6} {:.6}", p.x, p.y, p.z)?;
        if let Some(n) = &mesh.normals {
            write!(out, " {:.6} {:.6} {:.6}", n[i].x, n[i].y, n[i].z)?;
        }
        writeln!(out)?;
    }
    for [a, b, c] in &mesh.indices {
        writeln!(out, "3 {a} {b} {c}")?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(text: &str) -> Result<LoadedMesh, MeshError> {
        parse(Path::new("t.ply"), text.as_bytes(), &MeshOptions::default())
    }

    const QUAD: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
        property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
        element face 1\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0 255 0 0\n1 0 0 0 255 0\n1 1 0 0 0 255\n0 1 0 255 255 255\n4 0 1 2 3\n";

    #[test]
    fn ascii_quad_with_colours() {
        let l = load(QUAD).unwrap();
        let m = &l.meshes[0];
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.colors.as_ref().unwrap()[1], Vec3::Y);
        assert_eq!((l.triangles_read, l.degenerate_dropped, l.materials.len()), (2, 0, 1));
    }

    #[test]
    fn errors_name_the_line() {
        let e = load(&QUAD.replace("4 0 1 2 3", "4 0 1 2 9")).unwrap_err();
        assert_eq!(e.to_string(), "t.ply:17: face index 9 out of range (4 vertices)");
        let e = load(&QUAD.replace("1 1 0 0 0 255", "1 nan 0 0 0 255")).unwrap_err();
        assert_eq!(e.to_string(), "t.ply:15: vertex 2 has a non-finite position");
        let e = load(&QUAD.replace("4 0 1 2 3\n", "")).unwrap_err();
        assert_eq!(e.to_string(), "t.ply:17: the file ends after 0 of 1 faces");
        let e = load(&QUAD.replace("ascii", "binary_middle_endian")).unwrap_err();
        assert_eq!(e.to_string(), "t.ply: unknown PLY format 'binary_middle_endian'");
        let e = load(&QUAD.replace("1 0 0 0 255 0", "1 0 0 0 255 0 7")).unwrap_err();
        assert_eq!(e.to_string(), "t.ply:14: more values than the header declares for a vertex ('7')");
        let e = load(&QUAD.replace("4 0 1 2 3", "2 0 1")).unwrap_err();
        assert_eq!(e.to_string(), "t.ply:17: face has 2 vertices (a polygon needs at least 3)");
        let e = load(&QUAD.replace("element face 1", "element vertex 1\nproperty float x")).unwrap_err();
        assert_eq!(e.to_string(), "t.ply:10: element 'vertex' declared twice");
        let e = load(&QUAD.replace("4 0 1 2 3", "4 0 1 2")).unwrap_err();
        assert_eq!(e.to_string(), "t.ply:17: missing face index: the line has fewer values than the header declares");
    }

    #[test]
    fn binary_both_byte_orders_and_truncation() {
        for big in [false, true] {
            let mut d = format!(
                "ply\nformat binary_{}_endian 1.0\nelement vertex 3\nproperty double x\nproperty float y\n\
                 property float z\nelement face 2\nproperty uchar flags\nproperty list uint ushort vertex_indices\n\
                 property list uchar float other\nend_header\n",
                if big { "big" } else { "little" }
            )
            .into_bytes();
            let f32b = |v: f32| if big { v.to_be_bytes() } else { v.to_le_bytes() };
            for p in [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]] {
                d.extend(if big { (p[0] as f64).to_be_bytes() } else { (p[0] as f64).to_le_bytes() });
                d.extend(f32b(p[1]));
                d.extend(f32b(p[2]));
            }
            for _ in 0..2 {
                d.push(7);
                d.extend(if big { 3u32.to_be_bytes() } else { 3u32.to_le_bytes() });
                for i in [0u16, 1, 2] {
                    d.extend(if big { i.to_be_bytes() } else { i.to_le_bytes() });
                }
                d.push(1);
                d.extend(f32b(5.0));
            }
            let l = parse(Path::new("b.ply"), &d, &MeshOptions::default()).unwrap();
            assert_eq!(l.meshes[0].positions[2], Vec3::new(0.0, 2.0, 0.0));
            assert_eq!(l.meshes[0].indices, vec![[0, 1, 2], [0, 1, 2]]);
            d.truncate(d.len() - 3);
            let e = parse(Path::new("b.ply"), &d, &MeshOptions::default()).unwrap_err();
            assert_eq!(e.to_string(), "b.ply: truncated binary PLY: 1 of 2 faces");
        }
    }

    #[test]
    fn garbage_never_panics() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(5);
        let bin = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                   property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
        for _ in 0..3000 {
            let mut d = if rng.random_bool(0.5) { QUAD.as_bytes().to_vec() } else { bin.as_bytes().to_vec() };
            d.extend((0..rng.random_range(0..60)).map(|_| rng.random::<u8>()));
            for _ in 0..rng.random_range(0..4) {
                let i = rng.random_range(0..d.len());
                d[i] = rng.random();
            }
            let cut = rng.random_range(0..=d.len());
            let _ = parse(Path::new("g.ply"), &d[..cut], &MeshOptions::default());
        }
    }
}
