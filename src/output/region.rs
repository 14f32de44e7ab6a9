//! Rectangles of pixels: the part of an image one process renders, the tiles it traces in
//! parallel, and the split of a frame over the machines of a farm.
//!
//! A [`Region`] is the half-open rectangle `[x0, x1) × [y0, y1)` in image pixels, `(0, 0)` the
//! top-left pixel, `x` right and `y` down (the camera's and OpenEXR's convention): on the
//! command line `--region x0,y0,x1,y1`. Its EXR `dataWindow` is the closed box
//! `(x0, y0) – (x1 − 1, y1 − 1)` inside the `displayWindow` `(0, 0) – (W − 1, H − 1)`.
//!
//! **Tiles** ([`Region::tiles`]) are the cells of the image's grid of [`TILE_SIZE`]² squares
//! (anchored at pixel `(0, 0)`) clipped to the region, row by row. The grid does not move
//! with the region, so a region renders exactly the pixels a full render would, in tiles a
//! full render also has (clipped).
//!
//! **The farm split** ([`Region::split`]): `--tile I/N` is the I-th, **1-based** (`1 ≤ I ≤ N`,
//! as Slurm's `--array=1-N` numbers its tasks), of `N` horizontal bands of whole rows that
//! follow one another from the top and cover the image exactly. With `C = ⌈H/16⌉` rows of
//! tiles and `N ≤ C`, band `I` holds the tile rows `⌊(I−1)·C/N⌋ ≤ r < ⌊I·C/N⌋` (pixel rows
//! `16r` to `16r + 15`, the last clipped to the image): the bands differ by at most one tile
//! row, and none cuts a tile, which adaptive sampling would trace twice
//! ([`crate::integrator::adaptive`]). With more bands than tile rows, band `I` holds the rows
//! `⌊(I−1)·H/N⌋ ≤ y < ⌊I·H/N⌋` (bands differing by at most one row). `N` may be at most `H`
//! (no empty band).

use std::fmt;

/// Edge length in pixels of the square tiles rendered in parallel (and checkpointed).
pub const TILE_SIZE: u32 = 16;

/// The half-open pixel rectangle `[x0, x1) × [y0, y1)` (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Region {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl fmt::Display for Region {
    /// `x0,y0,x1,y1`, as `--region` takes it.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{},{},{},{}", self.x0, self.y0, self.x1, self.y1)
    }
}

impl Region {
    /// The whole `width × height` image.
    pub fn full(width: u32, height: u32) -> Region {
        Region { x0: 0, y0: 0, x1: width, y1: height }
    }

    /// Width in pixels (0 when empty or reversed).
    pub fn width(&self) -> u32 {
        self.x1.saturating_sub(self.x0)
    }

    /// Height in pixels (0 when empty or reversed).
    pub fn height(&self) -> u32 {
        self.y1.saturating_sub(self.y0)
    }

    /// Number of pixels.
    pub fn pixel_count(&self) -> u64 {
        self.width() as u64 * self.height() as u64
    }

    /// True when the region holds no pixel.
    pub fn is_empty(&self) -> bool {
        self.pixel_count() == 0
    }

    /// The pixels both regions hold, if any.
    pub fn intersection(&self, o: &Region) -> Option<Region> {
        let r = Region { x0: self.x0.max(o.x0), y0: self.y0.max(o.y0), x1: self.x1.min(o.x1), y1: self.y1.min(o.y1) };
        (!r.is_empty()).then_some(r)
    }

    /// Parses `x0,y0,x1,y1` (four non-negative integers). The message says what is wrong.
    pub fn parse(text: &str) -> Result<Region, String> {
        let parts: Vec<&str> = text.split(',').map(str::trim).collect();
        if parts.len() != 4 {
            return Err(format!("'{text}' is not x0,y0,x1,y1 (four pixel bounds, half-open)"));
        }
        let mut v = [0u32; 4];
        for (slot, part) in v.iter_mut().zip(&parts) {
            *slot = part.parse().map_err(|_| format!("'{part}' in '{text}' is not a pixel coordinate (0 or more)"))?;
        }
        Ok(Region { x0: v[0], y0: v[1], x1: v[2], y1: v[3] })
    }

    /// Why the region cannot be rendered in a `width × height` image: reversed, empty, or
    /// reaching outside it. `None` when it can.
    pub fn problem(&self, width: u32, height: u32) -> Option<String> {
        if self.x1 < self.x0 || self.y1 < self.y0 {
            return Some(format!("{self} is reversed: x1 must not be less than x0, nor y1 than y0"));
        }
        if self.is_empty() {
            return Some(format!("{self} is empty (bounds are half-open: x0,y0,x1,y1 with x1 > x0, y1 > y0)"));
        }
        if self.x1 > width || self.y1 > height {
            return Some(format!("{self} reaches outside the {width} × {height} image (x1 ≤ {width}, y1 ≤ {height})"));
        }
        None
    }

    /// Band `index` (1-based) of `count` of a `width × height` image (see the module docs), or
    /// why there is none.
    pub fn split(index: u32, count: u32, width: u32, height: u32) -> Result<Region, String> {
        if count == 0 {
            return Err(format!("{index}/{count}: the number of tiles must be at least 1"));
        }
        if index == 0 || index > count {
            return Err(format!("{index}/{count}: the tile number must be from 1 to {count} (it is 1-based)"));
        }
        if count > height {
            return Err(format!("{index}/{count}: the image has {height} rows, so at most {height} tiles"));
        }
        let cells = height.div_ceil(TILE_SIZE) as u64;
        let row = |i: u32| {
            if count as u64 <= cells {
                (i as u64 * cells / count as u64 * TILE_SIZE as u64).min(height as u64) as u32
            } else {
                (i as u64 * height as u64 / count as u64) as u32
            }
        };
        Ok(Region { x0: 0, y0: row(index - 1), x1: width, y1: row(index) })
    }

    /// Parses `I/N` and gives [`Region::split`] of it.
    pub fn parse_split(text: &str, width: u32, height: u32) -> Result<Region, String> {
        let (i, n) = text.split_once('/').ok_or_else(|| format!("'{text}' is not I/N (tile I of N, 1-based)"))?;
        let number =
            |s: &str| s.trim().parse::<u32>().map_err(|_| format!("'{text}' is not I/N (tile I of N, 1-based)"));
        Region::split(number(i)?, number(n)?, width, height)
    }

    /// The tiles of the region (see the module docs), row by row.
    pub fn tiles(&self) -> Vec<Region> {
        let mut out = Vec::new();
        let mut y = cell_start(self.y0);
        while y < self.y1 {
            let mut x = cell_start(self.x0);
            while x < self.x1 {
                let cell = Region { x0: x, y0: y, x1: x.saturating_add(TILE_SIZE), y1: y.saturating_add(TILE_SIZE) };
                out.extend(cell.intersection(self));
                x = x.saturating_add(TILE_SIZE);
            }
            y = y.saturating_add(TILE_SIZE);
        }
        out
    }

    /// The cell of the image's tile grid (see the module docs) that holds the region's first
    /// pixel, clipped to the `width × height` image: for a tile, the whole of its cell.
    pub fn grid_cell(&self, width: u32, height: u32) -> Region {
        let (x0, y0) = (cell_start(self.x0), cell_start(self.y0));
        Region { x0, y0, x1: x0.saturating_add(TILE_SIZE).min(width), y1: y0.saturating_add(TILE_SIZE).min(height) }
    }

    /// The region's pixels in the order their rays are traced: blocks of 4×2 pixels, so that
    /// each 8-ray packet covers a compact patch of the image (the most coherent rays).
    pub fn pixels_in_packet_order(&self) -> Vec<(u32, u32)> {
        let mut out = Vec::with_capacity(self.pixel_count() as usize);
        for by in (self.y0..self.y1).step_by(2) {
            for bx in (self.x0..self.x1).step_by(4) {
                for y in by..(by + 2).min(self.y1) {
                    for x in bx..(bx + 4).min(self.x1) {
                        out.push((x, y));
                    }
                }
            }
        }
        out
    }
}

/// The first row (or column) of the tile grid's cell that holds row (or column) `a`.
fn cell_start(a: u32) -> u32 {
    a - a % TILE_SIZE
}

/// The parts of `whole` that none of `parts` covers, as rectangles: the uncovered runs of
/// each row, with equal runs of consecutive rows joined. Empty when `parts` cover `whole`.
/// The rows between two consecutive part edges are covered alike, so the work is per band of
/// such rows, not per row: a part's header can declare a billion rows at no cost.
pub fn uncovered(whole: &Region, parts: &[Region]) -> Vec<Region> {
    let mut edges: Vec<u32> = parts
        .iter()
        .flat_map(|p| [p.y0, p.y1])
        .chain([whole.y0, whole.y1])
        .filter(|y| (whole.y0..=whole.y1).contains(y))
        .collect();
    edges.sort_unstable();
    edges.dedup();
    let mut open: Vec<Region> = Vec::new(); // runs continuing down to the current band
    let mut done = Vec::new();
    for band in edges.windows(2) {
        let (y, y_end) = (band[0], band[1]);
        let mut covered: Vec<(u32, u32)> = parts
            .iter()
            .filter(|p| p.y0 <= y && y < p.y1)
            .map(|p| (p.x0.max(whole.x0), p.x1.min(whole.x1)))
            .filter(|(a, b)| a < b)
            .collect();
        covered.sort();
        let mut runs = Vec::new();
        let mut x = whole.x0;
        for (a, b) in covered {
            if a > x {
                runs.push((x, a));
            }
            x = x.max(b);
        }
        if x < whole.x1 {
            runs.push((x, whole.x1));
        }
        let mut next = Vec::new();
        for (a, b) in runs {
            match open.iter().position(|r| r.x0 == a && r.x1 == b) {
                Some(k) => {
                    let mut r = open.swap_remove(k);
                    r.y1 = y_end;
                    next.push(r);
                }
                None => next.push(Region { x0: a, y0: y, x1: b, y1: y_end }),
            }
        }
        done.append(&mut open);
        open = next;
    }
    done.append(&mut open);
    done.sort_by_key(|r| (r.y0, r.x0));
    done
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_and_problems() {
        assert_eq!(Region::parse("1, 2,30,40"), Ok(Region { x0: 1, y0: 2, x1: 30, y1: 40 }));
        assert!(Region::parse("1,2,3").is_err());
        assert!(Region::parse("1,2,3,-4").unwrap_err().contains("'-4'"));
        assert!(Region::parse("0,0,5,5").unwrap().problem(5, 5).is_none());
        assert!(Region::parse("0,0,6,5").unwrap().problem(5, 5).unwrap().contains("outside"));
        assert!(Region::parse("3,0,3,5").unwrap().problem(5, 5).unwrap().contains("empty"));
        assert!(Region::parse("4,0,3,5").unwrap().problem(5, 5).unwrap().contains("reversed"));
    }

    #[test]
    fn split_into_bands_covers_the_image_once() {
        for (n, h) in [(1, 1), (7, 48), (8, 48), (5, 7), (7, 7), (3, 48), (2, 47), (4, 1080), (67, 1080), (68, 1080)] {
            let bands: Vec<Region> = (1..=n).map(|i| Region::split(i, n, 10, h).unwrap()).collect();
            assert_eq!(bands[0].y0, 0);
            assert_eq!(bands[n as usize - 1].y1, h);
            for w in bands.windows(2) {
                assert_eq!(w[0].y1, w[1].y0);
            }
            assert!(bands.iter().all(|b| !b.is_empty() && b.x0 == 0 && b.x1 == 10));
            assert!(uncovered(&Region::full(10, h), &bands).is_empty());
        }
        // More bands than the 3 rows of tiles: bands of rows.
        assert_eq!(Region::split(2, 7, 10, 48).unwrap(), Region { x0: 0, y0: 6, x1: 10, y1: 13 });
        // At most as many as the rows of tiles (68 rows: 5, the last 4 pixels high): bands of
        // tile rows, the last clipped to the image.
        let rows =
            |n: u32| (1..=n).map(|i| Region::split(i, n, 10, 68).unwrap()).map(|b| (b.y0, b.y1)).collect::<Vec<_>>();
        assert_eq!(rows(2), [(0, 32), (32, 68)]);
        assert_eq!(rows(3), [(0, 16), (16, 48), (48, 68)]);
        assert_eq!(rows(5), [(0, 16), (16, 32), (32, 48), (48, 64), (64, 68)]);
        assert_eq!(rows(6)[..2], [(0, 11), (11, 22)]);
        assert!(Region::split(0, 4, 10, 10).unwrap_err().contains("1-based"));
        assert!(Region::split(5, 4, 10, 10).unwrap_err().contains("from 1 to 4"));
        assert!(Region::split(1, 0, 10, 10).is_err());
        assert!(Region::split(1, 11, 10, 10).unwrap_err().contains("at most 10"));
        assert!(Region::parse_split("3", 10, 10).is_err());
        assert_eq!(Region::parse_split("1/1", 10, 10), Ok(Region::full(10, 10)));
    }

    #[test]
    fn tiles_follow_the_image_grid_and_cover_the_region() {
        let r = Region { x0: 10, y0: 5, x1: 40, y1: 20 };
        let tiles = r.tiles();
        assert_eq!(tiles[0], Region { x0: 10, y0: 5, x1: 16, y1: 16 });
        assert_eq!(tiles[1], Region { x0: 16, y0: 5, x1: 32, y1: 16 });
        assert_eq!(tiles.len(), 6);
        assert_eq!(tiles.iter().map(Region::pixel_count).sum::<u64>(), r.pixel_count());
        assert!(uncovered(&r, &tiles).is_empty());
        let full = Region::full(33, 17).tiles();
        assert_eq!(full.len(), 3 * 2);
        assert_eq!(full[5], Region { x0: 32, y0: 16, x1: 33, y1: 17 });
        // A clipped tile's cell is the whole grid square, clipped only by the image.
        assert_eq!(tiles[0].grid_cell(40, 20), Region { x0: 0, y0: 0, x1: 16, y1: 16 });
        assert_eq!(tiles[5].grid_cell(40, 20), Region { x0: 32, y0: 16, x1: 40, y1: 20 });
        assert_eq!(full[5].grid_cell(33, 17), full[5]);
    }

    #[test]
    fn uncovered_works_per_band_of_rows() {
        // A part of 3 rows in an image its header says has 2^30 rows: found at once (a fuzzed
        // merge part took 68 s of CPU when every row was visited).
        let whole = Region::full(8, 1 << 30);
        let parts = [Region { x0: 0, y0: 3, x1: 8, y1: 6 }];
        assert_eq!(
            uncovered(&whole, &parts),
            vec![Region { x0: 0, y0: 0, x1: 8, y1: 3 }, Region { x0: 0, y0: 6, x1: 8, y1: 1 << 30 }]
        );
        // Bands joined across an edge where the uncovered run stays the same.
        let parts = [Region { x0: 0, y0: 0, x1: 4, y1: 2 }, Region { x0: 0, y0: 2, x1: 4, y1: 5 }];
        assert_eq!(uncovered(&Region::full(6, 5), &parts), vec![Region { x0: 4, y0: 0, x1: 6, y1: 5 }]);
        assert!(uncovered(&Region::full(6, 5), &[Region::full(6, 5)]).is_empty());
    }

    #[test]
    fn uncovered_lists_the_missing_rectangles() {
        let whole = Region::full(10, 6);
        let parts = [Region { x0: 0, y0: 0, x1: 10, y1: 2 }, Region { x0: 0, y0: 2, x1: 4, y1: 6 }];
        assert_eq!(uncovered(&whole, &parts), vec![Region { x0: 4, y0: 2, x1: 10, y1: 6 }]);
        let parts = [Region { x0: 3, y0: 1, x1: 5, y1: 3 }];
        assert_eq!(
            uncovered(&Region::full(6, 4), &parts),
            vec![
                Region { x0: 0, y0: 0, x1: 6, y1: 1 },
                Region { x0: 0, y0: 1, x1: 3, y1: 3 },
                Region { x0: 5, y0: 1, x1: 6, y1: 3 },
                Region { x0: 0, y0: 3, x1: 6, y1: 4 },
            ]
        );
    }
}
