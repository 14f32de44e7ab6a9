//! Wavefront OBJ reader, with the MTL material libraries it names.
//!
//! Read: `v x y z` (with optional `w`, ignored as the format says for polygons, or vertex
//! colours `r g b`), `vt u [v [w]]`, `vn`, `f`/`fo` faces of any size with `v`, `v/vt`,
//! `v//vn`, `v/vt/vn` corners and negative (relative) indices, `o`/`g` (each group or object
//! with faces becomes one mesh, named after it), `usemtl` and `mtllib`. Tabs, CRLF, `#`
//! comments anywhere and a last line without a newline are fine; UTF-8 and UTF-16 (with a
//! byte-order mark) are read. Lines (`l`), points (`p`), free-form curves and surfaces and
//! unknown statements are skipped with a warning; smoothing groups (`s`) and other display
//! statements silently. A corner attribute (`vt`, `vn`) that some corners of a mesh have and
//! others do not is dropped for that mesh, with a warning.
//!
//! Not through `tobj` (4.0.5), for three reasons found on the test data: its errors carry no
//! line or index (`FaceVertexOutOfBounds`, `MaterialParseError`), so the `file:line: problem`
//! the project promises is impossible; it panics on the short colour form `Ks 0` (valid MTL,
//! in assimp's `empty_mat.mtl`) through an `unwrap` in `parse_float3`; and it fails a whole
//! OBJ on `usemtl` with an empty name (Blender writes that) while only logging unknown
//! material names, which strahl must report as warnings.
//!
//! # MTL → [`Material`]
//!
//! | MTL | `Material` |
//! |---|---|
//! | `Kd r g b` | `diffuse` (constant) |
//! | `Ks r g b` | `specular` (the Blinn–Phong weight) for illum ≥ 2 except 3, 5, 8, whose `Ks` is the `mirror` |
//! | `Ns n` | `shininess` |
//! | `Ni n` (> 0) | `ior`; without it 1.5 for glass (illum 4, 6, 7, 9), 1.0 otherwise |
//! | `d a` / `Tr t` (`d` wins; `Tr` = 1 − `d`) | `transmission` = 1 − d (grey) when d < 1 |
//! | `Tf r g b` | `transmission` of glass (illum 4, 6, 7, 9) |
//! | `Ke r g b` | `emission` |
//! | `map_Kd file` | `diffuse` = the image ([`crate::texture`]: sRGB-decoded, bilinear, repeating) times `Kd` (1 when not given); the file relative to the MTL file's folder (`\\` read as `/`); a missing file, or one that is not an image: an error at its line; with options (`-s`, `-o`, …): ignored with the warning below |
//! | `Ka`, other `map_*`, `bump`, `disp`, `refl`, … | ignored (ambient is the scene's; one warning) |
//!
//! | `illum` | meaning in strahl |
//! |---|---|
//! | 0, 1 | diffuse only (`specular` = 0) |
//! | 2 (default), 10 | diffuse + highlight |
//! | 3, 5, 8 | mirror: `mirror` = `Ks`, no separate highlight (MTL's formula weights the highlight and the reflection with the same `Ks`; giving it to the mirror alone keeps diffuse + specular + mirror ≤ 1) |
//! | 4, 6, 7, 9 | glass: a dielectric with `transmission` = `Tf` (else 1 − d when d < 1, else 1), `ior` = `Ni` (else 1.5), Fresnel reflection, plus `Kd` and the `Ks` highlight |
//!
//! A colour given with one number (`Ks 0`) is grey. A missing `.mtl` file is a warning, and
//! the faces that use its materials get a default material, as do faces before any `usemtl`
//! and faces whose `usemtl` names a material no library defines.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::mesh::{LoadedMesh, MeshError, MeshOptions, Parsed, RawMesh, finish};
use super::polygon;
use super::text::{self, Tally, parse_f32, parse_i64, show};
use crate::material::{Material, Texture};
use crate::math::{Vec2, Vec3};

/// "No index" in a corner's `vt` or `vn` slot.
const NONE: u32 = u32::MAX;
/// Unknown keywords listed one by one in the warnings; the rest are summed in one line.
const MAX_LISTED: usize = 16;

/// One face corner: position, texture coordinate and normal indices (0-based, `NONE` if
/// absent).
type Corner = [u32; 3];

/// A group of faces (`g`/`o`) being read.
struct Group {
    name: String,
    triangles: Vec<[Corner; 3]>,
    /// The material-name id of each triangle (`NONE`: no `usemtl` yet).
    materials: Vec<u32>,
}

/// Parses an OBJ file's bytes; `path` names it in messages and locates its MTL libraries.
pub fn parse(path: &Path, data: &[u8], options: &MeshOptions) -> Result<LoadedMesh, MeshError> {
    let decoded;
    let data = match data {
        [0xFE, 0xFF, rest @ ..] => {
            decoded = utf16(rest, u16::from_be_bytes);
            decoded.as_bytes()
        }
        [0xFF, 0xFE, rest @ ..] => {
            decoded = utf16(rest, u16::from_le_bytes);
            decoded.as_bytes()
        }
        [0xEF, 0xBB, 0xBF, rest @ ..] => rest,
        _ => data,
    };
    if data.iter().take(4096).any(|&b| b == 0) {
        return Err(MeshError::invalid(path, "binary data, not OBJ text (UTF-16 without a byte-order mark?)"));
    }
    let mut r = Reader::new(path);
    for (line_no, line) in text::lines(data) {
        r.statement(line_no, line)?;
    }
    r.finish(options)
}

fn utf16(bytes: &[u8], unit: fn([u8; 2]) -> u16) -> String {
    let units = bytes.chunks_exact(2).map(|c| unit([c[0], c[1]]));
    char::decode_utf16(units).map(|c| c.unwrap_or(char::REPLACEMENT_CHARACTER)).collect()
}

/// The text after the keyword, trimmed: names with spaces (`usemtl`, `mtllib`, `g`).
fn rest_of<'a>(line: &'a [u8], keyword: &[u8]) -> &'a [u8] {
    let line = text::trim(line);
    text::trim(&line[keyword.len().min(line.len())..])
}

struct Reader<'p> {
    path: &'p Path,
    positions: Vec<Vec3>,
    colors: Option<Vec<Vec3>>,
    uncolored: usize,
    texcoords: Vec<Vec2>,
    normals: Vec<Vec3>,
    groups: Vec<Group>,
    /// Material names `usemtl` used, with the line of first use; ids index this.
    material_names: Vec<(String, usize)>,
    material_ids: HashMap<String, u32>,
    current_material: u32,
    libraries: Vec<(String, usize)>,
    /// Whether any corner has a `vt` or `vn` index (otherwise corners are just positions).
    attributes: bool,
    triangles_read: usize,
    degenerate: usize,
    /// Statements skipped, by keyword.
    skipped: Tally,
    corners: Vec<Corner>,
    corner_positions: Vec<Vec3>,
    ears: Vec<[u32; 3]>,
    /// Faces that were not simple polygons (one warning for the file).
    fallbacks: polygon::Fallbacks,
}

impl<'p> Reader<'p> {
    fn new(path: &'p Path) -> Self {
        Reader {
            path,
            positions: Vec::new(),
            colors: None,
            uncolored: 0,
            texcoords: Vec::new(),
            normals: Vec::new(),
            groups: vec![Group { name: default_name(path), triangles: Vec::new(), materials: Vec::new() }],
            material_names: Vec::new(),
            material_ids: HashMap::new(),
            current_material: NONE,
            libraries: Vec::new(),
            attributes: false,
            triangles_read: 0,
            degenerate: 0,
            skipped: Tally::default(),
            corners: Vec::new(),
            corner_positions: Vec::new(),
            ears: Vec::new(),
            fallbacks: polygon::Fallbacks::default(),
        }
    }

    fn statement(&mut self, line_no: usize, line: &[u8]) -> Result<(), MeshError> {
        let line = match line.iter().position(|&b| b == b'#') {
            Some(i) => &line[..i],
            None => line,
        };
        let mut words = text::tokens(line);
        let Some(keyword) = words.next() else { return Ok(()) };
        let at = |problem: String| MeshError::at(self.path, line_no, problem);
        let number = |w: &[u8]| parse_f32(w).ok_or_else(|| at(format!("'{}' is not a number", show(w))));
        match keyword {
            b"v" => {
                let values = words.map(number).collect::<Result<Vec<f32>, _>>()?;
                let p = match values.len() {
                    3 | 4 | 6 | 7 => Vec3::new(values[0], values[1], values[2]),
                    n => {
                        return Err(at(format!(
                            "a vertex has 3 coordinates, optionally w or r g b; found {n} numbers"
                        )));
                    }
                };
                if !p.is_finite() {
                    return Err(at(format!("vertex {} is not finite", self.positions.len() + 1)));
                }
                if values.len() >= 6 {
                    let c = Vec3::new(values[3], values[4], values[5]);
                    self.colors.get_or_insert_with(|| vec![Vec3::ONE; self.positions.len()]).push(c);
                } else {
                    self.uncolored += 1;
                    if let Some(c) = &mut self.colors {
                        c.push(Vec3::ONE);
                    }
                }
                self.positions.push(p);
            }
            b"vt" => {
                let values = words.map(number).collect::<Result<Vec<f32>, _>>()?;
                if values.is_empty() || values.len() > 3 {
                    return Err(at(format!("a texture coordinate has 1 to 3 numbers; found {}", values.len())));
                }
                let t = Vec2::new(values[0], values.get(1).copied().unwrap_or(0.0));
                if !t.is_finite() {
                    return Err(at("texture coordinate is not finite".into()));
                }
                self.texcoords.push(t);
            }
            b"vn" => {
                let values = words.map(number).collect::<Result<Vec<f32>, _>>()?;
                if values.len() != 3 {
                    return Err(at(format!("a normal has 3 numbers; found {}", values.len())));
                }
                let n = Vec3::new(values[0], values[1], values[2]);
                if !n.is_finite() {
                    return Err(at("normal is not finite".into()));
                }
                self.normals.push(n);
            }
            b"f" | b"fo" => self.face(line_no, words)?,
            b"o" | b"g" => {
                let name = String::from_utf8_lossy(rest_of(line, keyword)).into_owned();
                let name = if name.is_empty() { default_name(self.path) } else { name };
                let current = self.groups.last_mut().expect("there is always a group");
                if current.triangles.is_empty() {
                    current.name = name;
                } else {
                    self.groups.push(Group { name, triangles: Vec::new(), materials: Vec::new() });
                }
            }
            b"usemtl" => {
                let name = String::from_utf8_lossy(rest_of(line, keyword)).into_owned();
                let next_id = self.material_names.len() as u32;
                self.current_material = *self.material_ids.entry(name.clone()).or_insert_with(|| {
                    self.material_names.push((name, line_no));
                    next_id
                });
            }
            b"mtllib" => {
                let name = String::from_utf8_lossy(rest_of(line, keyword)).into_owned();
                if !name.is_empty() {
                    self.libraries.push((name, line_no));
                }
            }
            b"s" | b"mg" | b"lod" | b"bevel" | b"c_interp" | b"d_interp" | b"shadow_obj" | b"trace_obj" | b"maplib"
            | b"usemap" | b"call" | b"csh" => {}
            other => self.skip(other, line_no),
        }
        Ok(())
    }

    fn skip(&mut self, keyword: &[u8], line_no: usize) {
        self.skipped.add(show(keyword), line_no);
    }

    /// Resolves a 1-based (or negative, relative) OBJ index against `len` items.
    fn index(&self, line_no: usize, token: &[u8], len: usize, what: &str) -> Result<u32, MeshError> {
        let at = |problem: String| MeshError::at(self.path, line_no, problem);
        let i = parse_i64(token).ok_or_else(|| at(format!("'{}' is not a {what} index", show(token))))?;
        let resolved = match i {
            0 => return Err(at(format!("{what} index 0 (OBJ indices start at 1)"))),
            i if i > 0 => i - 1,
            i => len as i64 + i,
        };
        if resolved < 0 || resolved >= len as i64 {
            let plural = match what {
                "face" => "vertices",
                "texture coordinate" => "texture coordinates",
                _ => "normals",
            };
            return Err(at(format!("{what} index {i} out of range ({len} {plural})")));
        }
        Ok(resolved as u32)
    }

    fn face<'a>(&mut self, line_no: usize, words: impl Iterator<Item = &'a [u8]>) -> Result<(), MeshError> {
        let mut corners = std::mem::take(&mut self.corners);
        corners.clear();
        for w in words {
            let mut parts = w.split(|&b| b == b'/');
            let v = self.index(line_no, parts.next().unwrap_or(b""), self.positions.len(), "face")?;
            let mut corner = [v, NONE, NONE];
            for (slot, (len, what)) in
                [(self.texcoords.len(), "texture coordinate"), (self.normals.len(), "normal")].into_iter().enumerate()
            {
                match parts.next() {
                    None | Some(b"") => {}
                    Some(t) => {
                        corner[slot + 1] = self.index(line_no, t, len, what)?;
                        self.attributes = true;
                    }
                }
            }
            if parts.next().is_some() {
                return Err(MeshError::at(self.path, line_no, format!("bad face corner '{}'", show(w))));
            }
            corners.push(corner);
        }
        if corners.len() < 3 {
            return Err(MeshError::at(
                self.path,
                line_no,
                format!("face has {} vertices (a polygon needs at least 3)", corners.len()),
            ));
        }
        let n = corners.len();
        self.triangles_read += n - 2;
        let group = self.groups.last_mut().expect("there is always a group");
        if n == 3 {
            group.triangles.push([corners[0], corners[1], corners[2]]);
            group.materials.push(self.current_material);
        } else {
            self.corner_positions.clear();
            self.corner_positions.extend(corners.iter().map(|c| self.positions[c[0] as usize]));
            self.ears.clear();
            let how = polygon::triangulate(&self.corner_positions, &mut self.ears);
            self.fallbacks.count(how, || format!(":{line_no}"));
            self.degenerate += n - 2 - self.ears.len();
            for t in &self.ears {
                group.triangles.push(t.map(|k| corners[k as usize]));
                group.materials.push(self.current_material);
            }
        }
        self.corners = corners;
        Ok(())
    }

    fn finish(self, options: &MeshOptions) -> Result<LoadedMesh, MeshError> {
        let path = self.path;
        let mut warnings: Vec<String> = self.fallbacks.warning(path).into_iter().collect();
        let skipped = self.skipped.entries();
        for (keyword, count, line) in skipped.iter().take(MAX_LISTED) {
            let what = match keyword.as_str() {
                "l" => "line elements".to_string(),
                "p" => "point elements".to_string(),
                "vp" | "cstype" | "deg" | "bmat" | "step" | "curv" | "curv2" | "surf" | "parm" | "trim" | "hole"
                | "scrv" | "sp" | "end" | "con" => format!("free-form statements '{keyword}' (not supported)"),
                _ => format!("unknown statements '{keyword}'"),
            };
            warnings.push(format!("{}:{line}: skipped {count} {what}", path.display()));
        }
        if let Some((_, _, line)) = skipped.get(MAX_LISTED) {
            let rest = &skipped[MAX_LISTED..];
            let count: usize = rest.iter().map(|(_, c, _)| c).sum();
            warnings.push(format!(
                "{}:{line}: skipped {count} more statements of {} other unknown keywords",
                path.display(),
                rest.len()
            ));
        }
        if let Some(colors) = &self.colors {
            let uncolored = self.uncolored;
            if uncolored > 0 {
                warnings.push(format!(
                    "{}: {uncolored} of {} vertices have no colour; white is used for them",
                    path.display(),
                    colors.len()
                ));
            }
        }

        // Materials: every library's, in order; later definitions of a name win.
        let dir = path.parent().unwrap_or(Path::new(""));
        let mut materials: Vec<Material> = Vec::new();
        let mut by_name: HashMap<String, u32> = HashMap::new();
        let mut parsed: HashMap<PathBuf, Vec<Material>> = HashMap::new();
        for (name, line) in &self.libraries {
            let files = library_files(dir, name);
            if files.is_empty() {
                warnings.push(format!(
                    "{}:{line}: material library '{name}' not found; its materials are replaced by a default one",
                    path.display()
                ));
            }
            for file in files {
                // Each library is read and parsed once, however often `mtllib` names it; its
                // materials are applied at every naming, so later definitions still win.
                if !parsed.contains_key(&file) {
                    // A library that cannot be read or parsed (a texture it names missing) is an
                    // error at the `mtllib` line naming it.
                    let data = super::mesh::read_file(&file).map_err(|e| MeshError::at(path, *line, e.to_string()))?;
                    let library = parse_mtl(&file, &data, &mut warnings)
                        .map_err(|e| MeshError::at(path, *line, e.to_string()))?;
                    parsed.insert(file.clone(), library);
                }
                for m in parsed[&file].iter().cloned() {
                    match by_name.get(&m.name) {
                        Some(&i) => materials[i as usize] = m,
                        None => {
                            by_name.insert(m.name.clone(), materials.len() as u32);
                            materials.push(m);
                        }
                    }
                }
            }
        }
        // Name ids → material indices; the default material goes last, when something uses it.
        let mut default = None;
        let mut default_index = |materials: &mut Vec<Material>| {
            *default.get_or_insert_with(|| {
                materials.push(Material::default());
                materials.len() as u32 - 1
            })
        };
        let mut resolved = Vec::with_capacity(self.material_names.len());
        for (name, line) in &self.material_names {
            resolved.push(match by_name.get(name) {
                Some(&i) => Some(i),
                None => {
                    warnings.push(format!(
                        "{}:{line}: material '{name}' is not defined; a default material is used",
                        path.display()
                    ));
                    None
                }
            });
        }

        let mut meshes = Vec::new();
        let mut remap = vec![NONE; if self.attributes { 0 } else { self.positions.len() }];
        for group in self.groups.into_iter().filter(|g| !g.triangles.is_empty()) {
            let mut ids = Vec::with_capacity(group.materials.len());
            for &id in &group.materials {
                ids.push(match resolved.get(id as usize).copied().flatten() {
                    Some(i) => i,
                    None => default_index(&mut materials),
                });
            }
            meshes.push(build_group(
                path,
                group,
                ids,
                &self.positions,
                self.colors.as_deref(),
                &self.texcoords,
                &self.normals,
                &mut remap,
                &mut warnings,
            ));
        }
        let parsed = Parsed {
            meshes,
            materials,
            warnings,
            triangles_read: self.triangles_read,
            degenerate: self.degenerate,
            vertices_in_file: self.positions.len(),
        };
        finish(path, parsed, options)
    }
}

fn default_name(path: &Path) -> String {
    path.file_name().map_or_else(|| "obj".into(), |n| n.to_string_lossy().into_owned())
}

/// The MTL files an `mtllib` statement names: the whole text as one file name (names may
/// contain spaces), else each whitespace-separated name that exists. Something that exists but
/// is not a regular file (a FIFO, a directory) is returned too: reading it says what it is.
fn library_files(dir: &Path, names: &str) -> Vec<PathBuf> {
    let whole = dir.join(names);
    if whole.exists() {
        return vec![whole];
    }
    names.split_whitespace().map(|n| dir.join(n)).filter(|p| p.exists()).collect()
}

/// Turns one group's corner triangles into a mesh over its own vertices. Without any `vt`/`vn`
/// in the file, a vertex is a position and the group's vertices keep the file's order;
/// otherwise each distinct (v, vt, vn) corner is a vertex, in order of first use.
#[allow(clippy::too_many_arguments)]
fn build_group(
    path: &Path,
    group: Group,
    materials: Vec<u32>,
    positions: &[Vec3],
    colors: Option<&[Vec3]>,
    texcoords: &[Vec2],
    normals: &[Vec3],
    remap: &mut [u32],
    warnings: &mut Vec<String>,
) -> RawMesh {
    let mut keys: Vec<Corner> = Vec::new();
    let triangles: Vec<[u32; 3]> = if !remap.is_empty() || positions.is_empty() {
        let mut used: Vec<u32> = group.triangles.iter().flatten().map(|c| c[0]).collect();
        used.sort_unstable();
        used.dedup();
        for (local, &v) in used.iter().enumerate() {
            remap[v as usize] = local as u32;
        }
        let triangles = group.triangles.iter().map(|t| t.map(|c| remap[c[0] as usize])).collect();
        for &v in &used {
            remap[v as usize] = NONE;
        }
        keys.extend(used.iter().map(|&v| [v, NONE, NONE]));
        triangles
    } else {
        let mut ids: HashMap<Corner, u32> = HashMap::new();
        group
            .triangles
            .iter()
            .map(|t| {
                t.map(|c| {
                    *ids.entry(c).or_insert_with(|| {
                        keys.push(c);
                        keys.len() as u32 - 1
                    })
                })
            })
            .collect()
    };
    let name = group.name;
    let mut attribute = |slot: usize, what: &str| -> Option<Vec<u32>> {
        let with = keys.iter().filter(|k| k[slot] != NONE).count();
        if with > 0 && with < keys.len() {
            warnings.push(format!(
                "{}: mesh '{name}': {} of {} vertices have no {what}; its {what}s are ignored",
                path.display(),
                keys.len() - with,
                keys.len()
            ));
        }
        (with == keys.len() && with > 0).then(|| keys.iter().map(|k| k[slot]).collect())
    };
    let uv_index = attribute(1, "texture coordinate");
    let normal_index = attribute(2, "normal");
    RawMesh {
        positions: keys.iter().map(|k| positions[k[0] as usize]).collect(),
        colors: colors.map(|c| keys.iter().map(|k| c[k[0] as usize]).collect()),
        uvs: uv_index.map(|i| i.iter().map(|&t| texcoords[t as usize]).collect()),
        normals: normal_index.map(|i| i.iter().map(|&n| normals[n as usize]).collect()),
        name,
        triangles,
        triangle_materials: materials,
    }
}

/// One `newmtl` block as written.
#[derive(Default)]
struct MtlBlock {
    name: String,
    kd: Option<Vec3>,
    ks: Option<Vec3>,
    ke: Option<Vec3>,
    tf: Option<Vec3>,
    ns: Option<f32>,
    ni: Option<f32>,
    d: Option<f32>,
    tr: Option<f32>,
    illum: Option<i64>,
    map_kd: Option<std::sync::Arc<crate::texture::Image>>,
}

impl MtlBlock {
    /// The mapping in the module's table.
    fn material(&self) -> Material {
        let illum = self.illum.unwrap_or(2);
        let ks = self.ks.unwrap_or(Vec3::ZERO);
        let glass = matches!(illum, 4 | 6 | 7 | 9);
        let mirror = matches!(illum, 3 | 5 | 8);
        let dissolve = self.d.or(self.tr.map(|t| 1.0 - t)).unwrap_or(1.0).clamp(0.0, 1.0);
        let transmission = if glass {
            self.tf.unwrap_or(Vec3::splat(if dissolve < 1.0 { 1.0 - dissolve } else { 1.0 }))
        } else {
            Vec3::splat(1.0 - dissolve)
        };
        Material {
            name: self.name.clone(),
            diffuse: match &self.map_kd {
                Some(image) => Texture::Image(crate::material::TextureSlot::plain(crate::texture::ImageTexture {
                    image: image.clone(),
                    wrap_u: crate::texture::Wrap::Repeat,
                    wrap_v: crate::texture::Wrap::Repeat,
                    factor: self.kd.unwrap_or(Vec3::ONE),
                    mipmaps: true,
                })),
                None => Texture::Constant(self.kd.unwrap_or(Vec3::splat(0.8))),
            },
            specular: if illum <= 1 || mirror { Vec3::ZERO } else { ks },
            shininess: self.ns.unwrap_or(0.0),
            mirror: if mirror { ks } else { Vec3::ZERO },
            transmission,
            ior: self.ni.unwrap_or(if glass { 1.5 } else { 1.0 }),
            emission: self.ke.unwrap_or(Vec3::ZERO),
            emission_one_sided: false,
            area_light: false,
            pbr: None,
            coverage: None,
        }
    }
}

/// Parses an MTL file into materials (see the module's mapping table).
pub fn parse_mtl(path: &Path, data: &[u8], warnings: &mut Vec<String>) -> Result<Vec<Material>, MeshError> {
    let data = data.strip_prefix(&[0xEF, 0xBB, 0xBF]).unwrap_or(data);
    let mut blocks: Vec<MtlBlock> = Vec::new();
    let mut ignored = Tally::default();
    for (line_no, line) in text::lines(data) {
        let line = match line.iter().position(|&b| b == b'#') {
            Some(i) => &line[..i],
            None => line,
        };
        let mut words = text::tokens(line);
        let Some(keyword) = words.next() else { continue };
        let at = |problem: String| MeshError::at(path, line_no, problem);
        let number = |w: Option<&[u8]>| {
            let w = w.unwrap_or(b"");
            parse_f32(w).filter(|v| v.is_finite()).ok_or_else(|| at(format!("'{}' is not a number", show(w))))
        };
        if keyword == b"newmtl" {
            let name = String::from_utf8_lossy(rest_of(line, keyword)).into_owned();
            blocks.push(MtlBlock { name, ..Default::default() });
            continue;
        }
        let Some(block) = blocks.last_mut() else {
            ignored.add(format!("{} before any newmtl", show(keyword)), line_no);
            continue;
        };
        let color = |words: &mut dyn Iterator<Item = &[u8]>| -> Result<Option<Vec3>, MeshError> {
            let first = words.next();
            if matches!(first, Some(b"spectral") | Some(b"xyz")) {
                return Ok(None);
            }
            let r = number(first)?;
            let rest: Vec<&[u8]> = words.collect();
            match rest.len() {
                0 => Ok(Some(Vec3::splat(r))),
                2 => Ok(Some(Vec3::new(r, number(Some(rest[0]))?, number(Some(rest[1]))?))),
                n => Err(at(format!("a colour has 1 or 3 numbers; found {}", n + 1))),
            }
        };
        match keyword {
            b"Kd" => block.kd = color(&mut words)?.or(block.kd),
            b"Ks" => block.ks = color(&mut words)?.or(block.ks),
            b"Ke" => block.ke = color(&mut words)?.or(block.ke),
            b"Tf" => block.tf = color(&mut words)?.or(block.tf),
            b"Ns" => block.ns = Some(number(words.next())?.max(0.0)),
            b"Ni" => {
                let ni = number(words.next())?;
                if ni > 0.0 {
                    block.ni = Some(ni);
                } else {
                    ignored.add(format!("Ni {ni} (not an index of refraction)"), line_no);
                }
            }
            b"d" => {
                let mut w = words.next();
                if w == Some(b"-halo") {
                    w = words.next();
                }
                block.d = Some(number(w)?);
            }
            b"Tr" => block.tr = Some(number(words.next())?),
            b"illum" => {
                let w = words.next().unwrap_or(b"");
                block.illum = Some(parse_i64(w).ok_or_else(|| at(format!("illum '{}' is not an integer", show(w))))?);
            }
            b"Ka" => {}
            b"map_Kd" if !rest_of(line, keyword).starts_with(b"-") && !rest_of(line, keyword).is_empty() => {
                // Files written on Windows name textures with backslashes (`.\\wood.jpg`).
                let name = String::from_utf8_lossy(rest_of(line, keyword)).replace('\\', "/");
                let file = path.parent().unwrap_or(Path::new("")).join(&name);
                // A missing file is an error too: on a farm it is almost always a broken upload,
                // and a render without its texture would be wrong without saying so.
                block.map_kd = Some(crate::texture::open_shared(&file).map_err(|e| at(format!("map_Kd: {e}")))?);
            }
            other => ignored.add(show(other), line_no),
        }
    }
    let all = ignored.entries();
    if let Some((_, _, first_line)) = all.first() {
        let mut list: Vec<String> = all.iter().take(MAX_LISTED).map(|(k, ..)| k.clone()).collect();
        if all.len() > MAX_LISTED {
            list.push(format!("and {} more", all.len() - MAX_LISTED));
        }
        warnings.push(format!("{}:{first_line}: ignored (not supported): {}", path.display(), list.join(", ")));
    }
    Ok(blocks.iter().map(MtlBlock::material).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(text: &str) -> Result<LoadedMesh, MeshError> {
        parse(Path::new("t.obj"), text.as_bytes(), &MeshOptions::default())
    }

    #[test]
    fn relative_indices_tabs_crlf_and_no_final_newline() {
        let l = load("v 0 0 0\r\nv 1 0 0\r\n\tv\t1 1 0\r\nv 0 1 0\r\nf -4 -3 -2 -1").unwrap();
        assert_eq!(l.meshes[0].indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(l.meshes[0].positions[2], Vec3::new(1.0, 1.0, 0.0));
    }

    #[test]
    fn errors_name_the_line() {
        let e = load("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 9\n").unwrap_err();
        assert_eq!(e.to_string(), "t.obj:5: face index 9 out of range (3 vertices)");
        let e = load("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n").unwrap_err();
        assert_eq!(e.to_string(), "t.obj:4: face index -4 out of range (3 vertices)");
        let e = load("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n").unwrap_err();
        assert_eq!(e.to_string(), "t.obj:4: face index 0 (OBJ indices start at 1)");
        let e = load("v 0 0 0\nv 1 nan 0\n").unwrap_err();
        assert_eq!(e.to_string(), "t.obj:2: vertex 2 is not finite");
        let e = load("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n").unwrap_err();
        assert_eq!(e.to_string(), "t.obj:4: texture coordinate index 1 out of range (0 texture coordinates)");
        let e = load("v 0 0 0\nv 1 0 0\n").unwrap_err();
        assert_eq!(e.to_string(), "t.obj: no faces to render (2 vertices and no polygons: a point cloud or lines?)");
        let e = load("v 1 2. 3.1+e2\n").unwrap_err();
        assert_eq!(e.to_string(), "t.obj:1: '3.1+e2' is not a number");
    }

    #[test]
    fn groups_materials_and_attributes() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\nvt 0 0\n\
                    g a\nusemtl red\nf 1//1 2//1 3//1\nusemtl blue\nf 2//1 4//1 3//1\n\
                    g b\nf 1/1 2/1 3/1\n";
        let l = load(text).unwrap();
        assert_eq!(l.meshes.len(), 2);
        let a = &l.meshes[0];
        assert_eq!(a.name, "a");
        assert_eq!(a.positions.len(), 4);
        assert_eq!(a.normals.as_ref().unwrap(), &vec![Vec3::Z; 4]);
        // Two unknown materials, one default for both, and a warning for each.
        assert_eq!(l.materials.len(), 1);
        assert_eq!((a.material, a.triangle_materials.clone()), (0, None));
        assert_eq!(l.warnings.len(), 2, "{:?}", l.warnings);
        let b = &l.meshes[1];
        assert_eq!((b.name.as_str(), b.uvs.as_ref().map(Vec::len), b.normals.is_none()), ("b", Some(3), true));
    }

    #[test]
    fn vertex_colours() {
        let l = load("v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n").unwrap();
        assert_eq!(l.meshes[0].colors.as_ref().unwrap(), &vec![Vec3::X, Vec3::Y, Vec3::Z]);
    }

    #[test]
    fn mtl_mapping() {
        let mtl = "newmtl plain\nKd 0.5 0.25 1\nKs 0\nNs 20\n\
                   newmtl mirror\nKd 0.01 0.01 0.01\nKs 0.95 0.95 0.95\nillum 5\n\
                   newmtl glass\nKs 0.3 0.3 0.3\nTf 0.1 0.1 0.1\nNi 2.5\nillum 7\n\
                   newmtl lamp\nKe 17 12 4\nd 0.25\nmap_Kd -s 2 2 x.png\n";
        let mut w = vec![];
        let m = parse_mtl(Path::new("t.mtl"), mtl.as_bytes(), &mut w).unwrap();
        assert_eq!(m[0].diffuse, Texture::Constant(Vec3::new(0.5, 0.25, 1.0)));
        assert_eq!((m[0].specular, m[0].shininess, m[0].mirror), (Vec3::ZERO, 20.0, Vec3::ZERO));
        assert_eq!((m[1].mirror, m[1].specular), (Vec3::splat(0.95), Vec3::ZERO));
        assert_eq!((m[2].transmission, m[2].ior, m[2].specular), (Vec3::splat(0.1), 2.5, Vec3::splat(0.3)));
        assert_eq!((m[3].emission, m[3].transmission, m[3].ior), (Vec3::new(17.0, 12.0, 4.0), Vec3::splat(0.75), 1.0));
        assert_eq!(w, vec!["t.mtl:17: ignored (not supported): map_Kd"]);
        let e = parse_mtl(Path::new("t.mtl"), b"newmtl a\nKd 1 x 1\n", &mut w).unwrap_err();
        assert_eq!(e.to_string(), "t.mtl:2: 'x' is not a number");
    }

    #[test]
    fn garbage_never_panics() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(9);
        let base = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1 4/1/1\nf -1 -2 -3\n";
        for _ in 0..3000 {
            let mut d = base.to_vec();
            for _ in 0..rng.random_range(1..6) {
                let i = rng.random_range(0..d.len());
                d[i] = *b"0123456789-/ \n.fvg#e".get(rng.random_range(0..20)).unwrap();
            }
            let _ = parse(Path::new("g.obj"), &d, &MeshOptions { smooth_normals: true });
        }
    }

    #[test]
    fn a_library_named_again_wins_again() {
        let dir = std::env::temp_dir().join(format!("strahl-obj-mtl-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("a.mtl"), "newmtl m\nKd 1 0 0\n").unwrap();
        std::fs::write(dir.join("b.mtl"), "newmtl m\nKd 0 0 1\n").unwrap();
        let text = "mtllib a.mtl\nmtllib b.mtl\nmtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\nf 1 2 3\n";
        let l = parse(&dir.join("t.obj"), text.as_bytes(), &MeshOptions::default()).unwrap();
        assert_eq!(l.materials.len(), 1);
        assert_eq!(l.materials[0].diffuse, Texture::Constant(Vec3::new(1.0, 0.0, 0.0)));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
