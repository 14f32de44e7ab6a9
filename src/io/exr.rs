//! The rendered film as OpenEXR: float32 scan lines, ZIP compression (16 lines per block),
//! one layer with these channels (EXR stores channels sorted by name):
//!
//! | channel | meaning |
//! |---|---|
//! | `R`, `G`, `B` | linear radiance, averaged over the pixel's samples |
//! | `A` | fraction of the pixel's samples whose primary ray hit geometry |
//! | `Z` | distance along the primary ray from the eye to the first hit; `+inf` where nothing is hit |
//! | `N.X`, `N.Y`, `N.Z` | world-space shading normal at the first hit (0 where nothing is hit) |
//! | `albedo.R`, `albedo.G`, `albedo.B` | diffuse albedo at the first hit (0 where nothing is hit) |
//!
//! `Z` is `+inf` (not 0 or a large finite number) for rays that escape: that is the true
//! distance to the first hit, it sorts behind every surface in depth compositing, and it
//! cannot be mistaken for a real distance.
//!
//! The bytes are deterministic: blocks are written in increasing line order whatever the
//! number of compression threads.

use std::io::Cursor;
use std::path::Path;

use exr::block::writer::{ParallelBlocksCompressor, SequentialBlocksCompressor};
use exr::image::write::layers::{LayersWriter, WritableLayers};
use exr::prelude::*;

use super::atomic::{WriteError, write_atomically};
use crate::film::Film;

/// The channel names written, in the order the docs list them.
pub const CHANNELS: [&str; 11] = ["R", "G", "B", "A", "Z", "N.X", "N.Y", "N.Z", "albedo.R", "albedo.G", "albedo.B"];

/// Encodes `film` as an OpenEXR file in memory, compressing on `threads` threads.
pub fn encode(film: &Film, threads: usize) -> std::result::Result<Vec<u8>, exr::error::Error> {
    let (w, h) = (film.width as usize, film.height as usize);
    let channel = |name: &str, sample: &dyn Fn(usize) -> f32| {
        AnyChannel::new(name, FlatSamples::F32((0..w * h).map(sample).collect()))
    };
    let channels = SmallVec::from_vec(vec![
        channel("R", &|i| film.rgba[i][0]),
        channel("G", &|i| film.rgba[i][1]),
        channel("B", &|i| film.rgba[i][2]),
        channel("A", &|i| film.rgba[i][3]),
        channel("Z", &|i| film.depth[i]),
        channel("N.X", &|i| film.normal[i].x),
        channel("N.Y", &|i| film.normal[i].y),
        channel("N.Z", &|i| film.normal[i].z),
        channel("albedo.R", &|i| film.albedo[i].x),
        channel("albedo.G", &|i| film.albedo[i].y),
        channel("albedo.B", &|i| film.albedo[i].z),
    ]);
    let encoding =
        Encoding { compression: Compression::ZIP16, blocks: Blocks::ScanLines, line_order: LineOrder::Increasing };
    let image =
        Image::from_layer(Layer::new((w, h), LayerAttributes::default(), encoding, AnyChannels::sort(channels)));

    // `image.write().to_buffered()` compresses on a pool of its own with a thread per core;
    // the same steps with a pool of `threads` threads keep to the command's `--threads`.
    let headers = image.layer_data.infer_headers(&image.attributes);
    let layers = image.layer_data.create_writer(&headers);
    let mut bytes = Cursor::new(Vec::new());
    exr::block::write(&mut bytes, headers, true, |meta, chunk_writer| {
        let blocks = meta.collect_ordered_block_data(|index| layers.extract_uncompressed_block(&meta.headers, index));
        if threads > 1 {
            let pool = || rayon::ThreadPoolBuilder::new().num_threads(threads).build();
            if let Some(mut parallel) = ParallelBlocksCompressor::new_with_thread_pool(&meta, chunk_writer, pool) {
                for (index, block) in blocks {
                    parallel.add_block_to_compression_queue(index, block)?;
                }
                return Ok(());
            }
        }
        let mut sequential = SequentialBlocksCompressor::new(&meta, chunk_writer);
        for (index, block) in blocks {
            sequential.compress_block(index, block)?;
        }
        Ok(())
    })?;
    Ok(bytes.into_inner())
}

/// Writes `film` to `path` as OpenEXR, atomically, compressing on `threads` threads.
pub fn write(film: &Film, path: &Path, threads: usize) -> std::result::Result<(), WriteError> {
    let bytes = encode(film, threads).map_err(|e| WriteError::new(path, format!("cannot encode OpenEXR: {e}")))?;
    write_atomically(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    /// A film whose every channel differs per pixel, with misses (+inf depth) on row 0.
    fn film(w: u32, h: u32) -> Film {
        let mut f = Film::new(w, h);
        for y in 0..h {
            for x in 0..w {
                let i = f.index(x, y);
                let v = (x + 1000 * y) as f32;
                f.rgba[i] = [v, v + 0.25, v + 0.5, if y == 0 { 0.0 } else { 1.0 }];
                f.depth[i] = if y == 0 { f32::INFINITY } else { 1.0 + v / 7.0 };
                f.normal[i] = if y == 0 { Vec3::ZERO } else { Vec3::new(x as f32, -(y as f32), 0.5).normalize() };
                f.albedo[i] = Vec3::new(0.1, 0.2, 0.3) * (x % 3) as f32;
            }
        }
        f
    }

    fn read(bytes: &[u8]) -> exr::image::FlatImage {
        exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .all_layers()
            .all_attributes()
            .from_buffered(Cursor::new(bytes))
            .unwrap()
    }

    #[test]
    fn every_channel_reads_back_exactly() {
        let f = film(37, 40); // 40 lines: three ZIP blocks, the last one short
        let image = read(&encode(&f, 1).unwrap());
        assert_eq!(image.layer_data.len(), 1);
        let layer = &image.layer_data[0];
        assert_eq!(layer.size, exr::math::Vec2(37, 40));
        assert_eq!(layer.encoding.compression, Compression::ZIP16);
        let names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
        let mut expected: Vec<&str> = CHANNELS.to_vec();
        expected.sort();
        assert_eq!(names, expected);
        let get = |name: &str| -> Vec<f32> {
            let c = layer.channel_data.list.iter().find(|c| c.name == *name).unwrap();
            match &c.sample_data {
                FlatSamples::F32(v) => v.clone(),
                other => panic!("{name} is not f32: {other:?}"),
            }
        };
        let n = f.rgba.len();
        let columns: [(&str, Vec<f32>); 11] = [
            ("R", (0..n).map(|i| f.rgba[i][0]).collect()),
            ("G", (0..n).map(|i| f.rgba[i][1]).collect()),
            ("B", (0..n).map(|i| f.rgba[i][2]).collect()),
            ("A", (0..n).map(|i| f.rgba[i][3]).collect()),
            ("Z", f.depth.clone()),
            ("N.X", f.normal.iter().map(|v| v.x).collect()),
            ("N.Y", f.normal.iter().map(|v| v.y).collect()),
            ("N.Z", f.normal.iter().map(|v| v.z).collect()),
            ("albedo.R", f.albedo.iter().map(|v| v.x).collect()),
            ("albedo.G", f.albedo.iter().map(|v| v.y).collect()),
            ("albedo.B", f.albedo.iter().map(|v| v.z).collect()),
        ];
        for (name, want) in columns {
            assert_eq!(get(name), want, "channel {name}");
        }
        assert_eq!(get("Z")[5], f32::INFINITY);
    }

    #[test]
    fn same_bytes_on_any_number_of_threads() {
        let f = film(64, 100);
        let one = encode(&f, 1).unwrap();
        assert_eq!(encode(&f, 2).unwrap(), one);
        assert_eq!(encode(&f, 3).unwrap(), one);
    }
}
