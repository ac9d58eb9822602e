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
}

impl Raster {
    /// An empty (transparent) raster over the pixel rectangle of `area`.
    pub fn over<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>) -> Self {
        let (xr, yr) = area.get_pixel_range();
        let (w, h) = (
            (xr.end - xr.start).max(1) as u32,
            (yr.end - yr.start).max(1) as u32,
        );
        Raster {
            x0: xr.start,
            y0: yr.start,
            w,
            h,
            rgba: vec![0; (w * h * 4) as usize],
        }
    }

    /// A raster at the origin holding `rgba` (tests).
    #[cfg(test)]
    pub(crate) fn from_rgba(w: u32, h: u32, rgba: Vec<u8>) -> Self {
        assert_eq!(rgba.len(), (w * h * 4) as usize);
        Raster {
            x0: 0,
            y0: 0,
            w,
            h,
            rgba,
        }
    }

    /// Paints a `size × size` dot centred at backend pixel `(x, y)` with
    /// `color` (alpha composited over what is there).
    pub fn dot(&mut self, (x, y): (i32, i32), size: i32, color: RGBAColor) {
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

/// Compression of the scatter rasters embedded in SVG figures (and so in
/// `report.html`), which every `rwg run` writes: zlib's default level. At
/// `Best` the deflate was the larger part of the report's CPU time (and the
/// report about a third of a 3000-network CartPole cell's whole run), for
/// pages 0.4 % smaller than at `Default`; `Fast` (fdeflate) saves a little
/// more time but makes `report.html` 57–80 % larger (docs/performance.md).
/// Deterministic, as every level: the same pixels give the same bytes.
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
    let mut colours: std::collections::HashMap<[u8; 4], u8> = std::collections::HashMap::new();
    let (mut palette, mut alpha) = (Vec::new(), Vec::new());
    let mut indices = Vec::with_capacity(pixels.len() / 4);
    // Runs of one colour (transparent background, dot interiors) skip the map.
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
