//! Dense scatter layers drawn as a raster.
//!
//! A cell's scatter plots have up to `N × E` points (10⁵–10⁷): as SVG
//! elements that would be megabytes per figure. Dots are therefore
//! rasterised at the plot's pixel size into an RGBA buffer; an SVG figure
//! embeds that buffer as one PNG `<image>` in the plot area (axes, curves
//! and text stay vector), a PNG figure paints its pixels directly.

use super::PlotError;
use plotters::coord::Shift;
use plotters::prelude::*;

/// A pixel buffer covering one plot area, straight-alpha RGBA.
pub struct Raster {
    /// Left edge in backend pixels.
    pub x0: i32,
    /// Top edge in backend pixels.
    pub y0: i32,
    /// Width in pixels.
    pub w: u32,
    /// Height in pixels.
    pub h: u32,
    rgba: Vec<u8>,
    memo: BlendMemo,
}

impl Raster {
    /// An empty (transparent) raster over the pixel rectangle of `area`.
    pub fn over<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>) -> Self {
        let (xr, yr) = area.get_pixel_range();
        Raster::blank(
            (xr.start, yr.start),
            (xr.end - xr.start).max(1) as u32,
            (yr.end - yr.start).max(1) as u32,
        )
    }

    /// An empty (transparent) `w × h` raster whose top left pixel is
    /// backend pixel `(x0, y0)`.
    fn blank((x0, y0): (i32, i32), w: u32, h: u32) -> Self {
        Raster {
            x0,
            y0,
            w,
            h,
            rgba: vec![0; (w * h * 4) as usize],
            memo: BlendMemo::new(),
        }
    }

    /// A raster at the origin holding `rgba` (tests).
    #[cfg(test)]
    pub(crate) fn from_rgba(w: u32, h: u32, rgba: Vec<u8>) -> Self {
        assert_eq!(rgba.len(), (w * h * 4) as usize);
        Raster {
            rgba,
            ..Raster::blank((0, 0), w, h)
        }
    }

    /// Paints a `size × size` dot centred at backend pixel `(x, y)` with
    /// `color` (alpha composited over what is there; `blend`).
    ///
    /// The dot's rectangle is clipped to the raster once, and each pixel's
    /// new value is looked up in a memo of `blend` for this colour: a
    /// dense scatter blends the same colour over the same few pixel values
    /// again and again. The pixels are those `blend` gives, bit for bit.
    pub fn dot(&mut self, (x, y): (i32, i32), size: i32, color: RGBAColor) {
        let half = i64::from(size / 2);
        let left = i64::from(x) - half - i64::from(self.x0);
        let top = i64::from(y) - half - i64::from(self.y0);
        let (xs, xe) = (left.max(0), (left + i64::from(size)).min(i64::from(self.w)));
        let (ys, ye) = (top.max(0), (top + i64::from(size)).min(i64::from(self.h)));
        if xs >= xe || ys >= ye {
            return;
        }
        self.memo.set_color(color);
        let w = self.w as usize;
        for py in ys as usize..ye as usize {
            let row = &mut self.rgba[(py * w + xs as usize) * 4..(py * w + xe as usize) * 4];
            for px in row.chunks_exact_mut(4) {
                let old = u32::from_le_bytes([px[0], px[1], px[2], px[3]]);
                px.copy_from_slice(&self.memo.blend(old).to_le_bytes());
            }
        }
    }

    /// Encodes the raster as a PNG, at [`EMBEDDED`] compression: indexed
    /// (a palette with per-entry alpha) when it has at most 256 colours, as
    /// a scatter's blends of a few dot colours do (5-30 in a 3000-network
    /// cell), else RGBA. Both decode to exactly the raster's RGBA pixels; the
    /// indexed one gives deflate a quarter of the bytes (the larger part of
    /// the report's CPU time was that deflate) and is smaller.
    pub fn png(&self) -> Result<Vec<u8>, PlotError> {
        match indexed(&self.rgba) {
            Some((palette, alpha, indices)) => {
                encode_indexed_png(&indices, self.w, self.h, &palette, &alpha, EMBEDDED)
            }
            None => encode_png(&self.rgba, self.w, self.h, png::ColorType::Rgba, EMBEDDED),
        }
    }

    /// Paints the raster onto the drawing area it was created over.
    pub fn paint<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
    ) -> Result<(), PlotError> {
        for y in 0..self.h {
            for x in 0..self.w {
                let i = ((y * self.w + x) * 4) as usize;
                let p = &self.rgba[i..i + 4];
                if p[3] > 0 {
                    let c = RGBAColor(p[0], p[1], p[2], f64::from(p[3]) / 255.0);
                    area.draw_pixel((x as i32, y as i32), &c)
                        .map_err(super::draw_err)?;
                }
            }
        }
        Ok(())
    }
}

/// `color` alpha composited over the straight-alpha RGBA pixel `[r, g, b,
/// a]`, rounded to 8 bits; a pixel that stays fully transparent is
/// returned unchanged. A pure function of its arguments.
fn blend(p: [u8; 4], RGBAColor(r, g, b, a): RGBAColor) -> [u8; 4] {
    let mut p = p;
    let da = f64::from(p[3]) / 255.0;
    let oa = a + da * (1.0 - a);
    if oa <= 0.0 {
        return p;
    }
    for (c, s) in p[..3].iter_mut().zip([r, g, b]) {
        let v = (f64::from(s) * a + f64::from(*c) * da * (1.0 - a)) / oa;
        *c = v.round().clamp(0.0, 255.0) as u8;
    }
    p[3] = (oa * 255.0).round() as u8;
    p
}

/// Entries of the blend memo (direct-mapped), as a power of two.
const MEMO_BITS: u32 = 10;
/// Entries of the blend memo.
const MEMO_SIZE: usize = 1 << MEMO_BITS;

/// A direct-mapped memo of [`blend`] for one colour at a time: pixel value
/// (as a little-endian `u32`) to blended value. A key holds the colour's
/// generation in its upper 32 bits, so changing colour invalidates every
/// entry without clearing; generation 0 marks an empty entry.
struct BlendMemo {
    color: RGBAColor,
    generation: u32,
    keys: Box<[u64; MEMO_SIZE]>,
    values: Box<[u32; MEMO_SIZE]>,
}

impl BlendMemo {
    fn new() -> Self {
        BlendMemo {
            color: RGBAColor(0, 0, 0, f64::NAN),
            generation: 0,
            keys: Box::new([0; MEMO_SIZE]),
            values: Box::new([0; MEMO_SIZE]),
        }
    }

    /// Makes `color` the colour the memo blends with.
    fn set_color(&mut self, color: RGBAColor) {
        let RGBAColor(r, g, b, a) = color;
        let RGBAColor(r0, g0, b0, a0) = self.color;
        if self.generation != 0 && (r, g, b, a.to_bits()) == (r0, g0, b0, a0.to_bits()) {
            return;
        }
        self.color = color;
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            self.keys.fill(0);
            self.generation = 1;
        }
    }

    /// [`blend`] of the current colour over `pixel`.
    #[inline]
    fn blend(&mut self, pixel: u32) -> u32 {
        let slot = (pixel.wrapping_mul(0x9E37_79B1) >> (32 - MEMO_BITS)) as usize;
        let key = u64::from(self.generation) << 32 | u64::from(pixel);
        if self.keys[slot] == key {
            return self.values[slot];
        }
        let out = u32::from_le_bytes(blend(pixel.to_le_bytes(), self.color));
        self.keys[slot] = key;
        self.values[slot] = out;
        out
    }
}

/// Compression of the scatter rasters embedded in SVG figures (and so in
/// `report.html`), which every `rwg run` writes: zlib's default level. At
/// `Best` the deflate was the larger part of the report's CPU time (and the
/// report about a third of a 3000-network CartPole cell's whole run), for
/// pages 0.4 % smaller than at `Default`; `Fast` (fdeflate) saves a little
/// more time but makes `report.html` 57–80 % larger. Deterministic, as
/// every level: the same pixels give the same bytes.
pub const EMBEDDED: png::Compression = png::Compression::Default;

/// Compression of whole PNG figures (`rwg plot --png`, `rwg compare
/// --figure`): written only on request, to be kept or published, so the
/// smallest files.
pub const STANDALONE: png::Compression = png::Compression::Best;

/// Encodes 8-bit pixels as PNG.
pub fn encode_png(
    pixels: &[u8],
    w: u32,
    h: u32,
    color: png::ColorType,
    compression: png::Compression,
) -> Result<Vec<u8>, PlotError> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(color);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(compression);
        let mut writer = enc
            .write_header()
            .map_err(|e| PlotError::Png(e.to_string()))?;
        writer
            .write_image_data(pixels)
            .map_err(|e| PlotError::Png(e.to_string()))?;
    }
    Ok(out)
}

/// The palette (RGB triples), its alpha values and one index per pixel of
/// straight-alpha RGBA `pixels`, colours numbered in order of first
/// appearance; `None` above 256 colours.
pub fn indexed(pixels: &[u8]) -> Option<(Vec<u8>, Vec<u8>, Vec<u8>)> {
    // Colours as little-endian u32, in order of first appearance.
    let mut colours: Vec<u32> = Vec::new();
    // A direct-mapped cache of colour -> index: `colour << 8 | index`;
    // `u64::MAX` (no colour shifted by 8 gives it) marks an empty slot.
    let mut slots = [u64::MAX; 256];
    let mut indices = Vec::with_capacity(pixels.len() / 4);
    // Runs of one colour (transparent background, dot interiors) skip the lookup.
    let mut last: Option<(u32, u8)> = None;
    for p in pixels.chunks_exact(4) {
        let c = u32::from_le_bytes([p[0], p[1], p[2], p[3]]);
        let i = match last {
            Some((lc, li)) if lc == c => li,
            _ => {
                let slot = (c.wrapping_mul(0x9E37_79B1) >> 24) as usize;
                let i = if slots[slot] >> 8 == u64::from(c) {
                    slots[slot] as u8
                } else {
                    let i = match colours.iter().position(|&k| k == c) {
                        Some(i) => i as u8,
                        None if colours.len() < 256 => {
                            colours.push(c);
                            (colours.len() - 1) as u8
                        }
                        None => return None,
                    };
                    slots[slot] = u64::from(c) << 8 | u64::from(i);
                    i
                };
                last = Some((c, i));
                i
            }
        };
        indices.push(i);
    }
    let (mut palette, mut alpha) = (Vec::new(), Vec::new());
    for c in colours {
        let [r, g, b, a] = c.to_le_bytes();
        palette.extend_from_slice(&[r, g, b]);
        alpha.push(a);
    }
    Some((palette, alpha, indices))
}

/// Encodes 8-bit palette indices as an indexed PNG with `palette` (RGB
/// triples) and per-entry `alpha` (its `tRNS` chunk).
pub fn encode_indexed_png(
    indices: &[u8],
    w: u32,
    h: u32,
    palette: &[u8],
    alpha: &[u8],
    compression: png::Compression,
) -> Result<Vec<u8>, PlotError> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(png::ColorType::Indexed);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_palette(palette.to_vec());
        enc.set_trns(alpha.to_vec());
        enc.set_compression(compression);
        let mut writer = enc
            .write_header()
            .map_err(|e| PlotError::Png(e.to_string()))?;
        writer
            .write_image_data(indices)
            .map_err(|e| PlotError::Png(e.to_string()))?;
    }
    Ok(out)
}

/// Standard base64 (RFC 4648, with padding).
pub fn base64(data: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(data.len().div_ceil(3) * 4);
    for chunk in data.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(T[((n >> (18 - 6 * k)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The raster's dot and blend before the memo, verbatim: the
    /// reference the memoised, clipped [`Raster::dot`] must match.
    struct Reference {
        x0: i32,
        y0: i32,
        w: u32,
        h: u32,
        rgba: Vec<u8>,
    }

    impl Reference {
        fn dot(&mut self, (x, y): (i32, i32), size: i32, color: RGBAColor) {
            let half = size / 2;
            for py in y - half..y - half + size {
                for px in x - half..x - half + size {
                    self.blend(px - self.x0, py - self.y0, color);
                }
            }
        }

        fn blend(&mut self, x: i32, y: i32, RGBAColor(r, g, b, a): RGBAColor) {
            if x < 0 || y < 0 || x >= self.w as i32 || y >= self.h as i32 {
                return;
            }
            let i = ((y as u32 * self.w + x as u32) * 4) as usize;
            let p = &mut self.rgba[i..i + 4];
            let da = f64::from(p[3]) / 255.0;
            let oa = a + da * (1.0 - a);
            if oa <= 0.0 {
                return;
            }
            for (c, s) in p[..3].iter_mut().zip([r, g, b]) {
                let v = (f64::from(s) * a + f64::from(*c) * da * (1.0 - a)) / oa;
                *c = v.round().clamp(0.0, 255.0) as u8;
            }
            p[3] = (oa * 255.0).round() as u8;
        }
    }

    /// xorshift64*: reproducible test inputs.
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
        }
        fn below(&mut self, n: u64) -> u64 {
            self.next() % n
        }
    }

    /// The colours the panels draw with (`dot_style`'s alpha range, the
    /// variance panel's floor, the opaque green of the top episodes), and
    /// edge cases: alpha 0 and 1, tiny alphas, black and white.
    fn colours(rng: &mut Rng) -> Vec<RGBAColor> {
        let mut out = vec![
            RGBAColor(44, 160, 44, 1.0),
            RGBAColor(31, 119, 180, 0.15),
            RGBAColor(31, 119, 180, 0.35),
            RGBAColor(31, 119, 180, 0.8),
            RGBAColor(0, 0, 0, 0.0),
            RGBAColor(255, 255, 255, 1e-9),
            RGBAColor(255, 255, 255, 0.5),
            RGBAColor(0, 0, 0, 0.999_999),
        ];
        for _ in 0..40 {
            let alpha = 6.0 / (1.0 + rng.below(10_000) as f64 / 100.0);
            out.push(RGBAColor(31, 119, 180, alpha.clamp(0.15, 0.8)));
        }
        for _ in 0..40 {
            let [r, g, b, ..] = rng.next().to_le_bytes();
            out.push(RGBAColor(r, g, b, rng.below(1_000_001) as f64 / 1e6));
        }
        out
    }

    #[test]
    fn dots_match_the_reference_raster() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let colours = colours(&mut rng);
        for (x0, y0, w, h) in [(70, 12, 61, 37), (0, 0, 1, 1), (-3, 5, 200, 3)] {
            let mut new = Raster::blank((x0, y0), w, h);
            let mut old = Reference {
                x0,
                y0,
                w,
                h,
                rgba: vec![0; (w * h * 4) as usize],
            };
            let mut color = colours[0];
            for n in 0..60_000 {
                // runs of one colour, as the panels draw, and random switches
                if rng.below(500) == 0 {
                    color = colours[rng.below(colours.len() as u64) as usize];
                }
                // centres up to 4 pixels outside the raster on every side
                let x = x0 - 4 + rng.below(u64::from(w) + 8) as i32;
                let y = y0 - 4 + rng.below(u64::from(h) + 8) as i32;
                let size = 1 + rng.below(4) as i32;
                new.dot((x, y), size, color);
                old.dot((x, y), size, color);
                if n % 5_000 == 0 {
                    assert_eq!(new.rgba, old.rgba, "after {n} dots");
                }
            }
            assert_eq!(new.rgba, old.rgba);
            assert!(new.rgba.iter().any(|&b| b != 0));
        }
    }

    /// [`indexed`] before the lookup table, verbatim: the reference.
    fn indexed_reference(pixels: &[u8]) -> Option<(Vec<u8>, Vec<u8>, Vec<u8>)> {
        let mut colours: std::collections::HashMap<[u8; 4], u8> = std::collections::HashMap::new();
        let (mut palette, mut alpha) = (Vec::new(), Vec::new());
        let mut indices = Vec::with_capacity(pixels.len() / 4);
        let mut last: Option<([u8; 4], u8)> = None;
        for p in pixels.chunks_exact(4) {
            let c = [p[0], p[1], p[2], p[3]];
            let i = match last {
                Some((lc, li)) if lc == c => li,
                _ => {
                    let n = colours.len();
                    let i = match colours.get(&c) {
                        Some(&i) => i,
                        None if n < 256 => {
                            colours.insert(c, n as u8);
                            palette.extend_from_slice(&c[..3]);
                            alpha.push(c[3]);
                            n as u8
                        }
                        None => return None,
                    };
                    last = Some((c, i));
                    i
                }
            };
            indices.push(i);
        }
        Some((palette, alpha, indices))
    }

    /// Palettes of 1 to 300 colours (so 256 and 257 too), in runs and
    /// scattered, including colours whose cache slots collide, and a
    /// drawn scatter: [`indexed`] gives the reference's palette and indices.
    #[test]
    fn indexed_matches_the_reference() {
        let mut rng = Rng(3);
        for n in (1..=300).step_by(7).chain([255, 256, 257]) {
            let table: Vec<[u8; 4]> = (0..n)
                .map(|k| {
                    if k % 3 == 0 {
                        // colours differing in one byte: clustered slots
                        [k as u8, 7, 9, (k / 256) as u8]
                    } else {
                        let [r, g, b, a, ..] = rng.next().to_le_bytes();
                        [r, g, b, a]
                    }
                })
                .collect();
            let mut px = Vec::new();
            while px.len() < 4 * 5_000 {
                let c = table[rng.below(n as u64) as usize];
                for _ in 0..1 + rng.below(6) {
                    px.extend_from_slice(&c);
                }
            }
            for &c in &table {
                px.extend_from_slice(&c);
            }
            assert_eq!(indexed(&px), indexed_reference(&px), "{n} colours");
            assert_eq!(indexed(&px).is_some(), n <= 256, "{n} colours");
        }
        let mut r = Raster::blank((0, 0), 120, 40);
        for k in 0..3_000 {
            let c = [RGBAColor(31, 119, 180, 0.3), RGBAColor(44, 160, 44, 1.0)][k % 2];
            r.dot((rng.below(124) as i32 - 2, rng.below(44) as i32 - 2), 2, c);
        }
        assert!(indexed(&r.rgba).is_some());
        assert_eq!(indexed(&r.rgba), indexed_reference(&r.rgba));
    }

    #[test]
    fn far_off_dots_draw_nothing() {
        let mut r = Raster::blank((10, 10), 5, 5);
        let c = RGBAColor(1, 2, 3, 0.5);
        for p in [
            (i32::MAX, 12),
            (i32::MIN, 12),
            (12, i32::MAX),
            (12, i32::MIN),
            (8, 12),
            (16, 12),
        ] {
            r.dot(p, 3, c);
        }
        assert!(r.rgba.iter().all(|&b| b == 0));
        r.dot((9, 9), 3, c);
        assert_eq!(r.rgba.iter().filter(|&&b| b != 0).count(), 4);
    }

    /// Every pixel value reachable from transparent by blending the panels'
    /// colours, each blended once more with each of them, and a million
    /// random pixel values with random colours: the memo gives [`blend`]'s
    /// value, which is the reference's.
    #[test]
    fn memo_matches_the_reference_blend() {
        let mut rng = Rng(42);
        let colours = colours(&mut rng);
        let reference = |p: [u8; 4], c: RGBAColor| {
            let mut one = Reference {
                x0: 0,
                y0: 0,
                w: 1,
                h: 1,
                rgba: p.to_vec(),
            };
            one.dot((0, 0), 1, c);
            [one.rgba[0], one.rgba[1], one.rgba[2], one.rgba[3]]
        };
        let mut memo = BlendMemo::new();
        let mut check = |p: [u8; 4], c: RGBAColor| {
            memo.set_color(c);
            let got = memo.blend(u32::from_le_bytes(p)).to_le_bytes();
            let want = reference(p, c);
            assert_eq!(got, want, "{p:?} under {c:?}");
            assert_eq!(blend(p, c), want);
            want
        };
        let panel = &colours[..4];
        let mut seen = std::collections::HashSet::from([[0u8; 4]]);
        let mut todo = vec![[0u8; 4]];
        while let Some(p) = todo.pop() {
            for &c in panel {
                let q = check(p, c);
                if seen.insert(q) {
                    todo.push(q);
                }
            }
        }
        assert!(seen.len() > 100, "only {} states", seen.len());
        for _ in 0..1_000_000 {
            let p = rng.next().to_le_bytes();
            let c = colours[rng.below(colours.len() as u64) as usize];
            check([p[0], p[1], p[2], p[3]], c);
        }
    }

    #[test]
    fn base64_rfc4648_vectors() {
        for (i, o) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(i.as_bytes()), o);
        }
    }
}
