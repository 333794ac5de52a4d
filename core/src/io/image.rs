//! Raster images for occupancy maps: PGM (P2 ascii, P5 binary; maxval up to 65535) and PNG
//! (gray, gray+alpha, RGB, RGBA, palette; 1–16 bits) decoding, and PGM / PNG encoding.
//!
//! Decoding keeps the samples as stored (one or two big-endian bytes each) and normalises on
//! access, so a W × H image costs W·H·channels·bytes of memory once. O(W·H).
//!
//! Allocation caps: a PGM must hold all its samples in the input (checked before reserving);
//! a PNG's raw scanlines may not exceed 1,100 × the file size (deflate expands at most 1,032:1),
//! its decoded buffer is capped at 1 GiB, and the decoder's own allocations are limited to the
//! same.

use super::MapError;

/// Maximum decoded PNG buffer: far beyond any real occupancy map.
const MAX_DECODED_BYTES: usize = 1 << 30;
/// Deflate's maximum expansion ratio (1,032:1) plus PNG's per-row filter byte, rounded up.
const MAX_DEFLATE_RATIO: usize = 1_100;

/// A decoded image: row 0 is the TOP row, samples interleaved by channel.
#[derive(Clone, Debug)]
pub(crate) struct Raster {
    pub width: usize,
    pub height: usize,
    /// 1 gray, 2 gray+alpha, 3 RGB, 4 RGBA.
    pub channels: usize,
    /// 1 or 2 (big-endian).
    bytes_per_sample: usize,
    /// The value of a fully bright (or opaque) sample.
    max_value: f64,
    data: Vec<u8>,
}

impl Raster {
    /// Whether the last channel is alpha.
    pub(crate) fn has_alpha(&self) -> bool {
        self.channels == 2 || self.channels == 4
    }

    /// Sample `k` of the flat sample array as stored (0–255 or 0–65535).
    #[inline]
    fn stored(&self, k: usize) -> f64 {
        if self.bytes_per_sample == 1 {
            f64::from(self.data[k])
        } else {
            f64::from(u16::from_be_bytes([self.data[2 * k], self.data[2 * k + 1]]))
        }
    }

    /// Sample `k` of the flat sample array, normalised to [0, 1].
    #[inline]
    fn sample(&self, k: usize) -> f64 {
        self.stored(k) / self.max_value
    }

    /// Channel `channel` of pixel `index` (row-major from the top-left) as stored, not
    /// normalised: a DEM's pixel value.
    #[inline]
    pub(crate) fn stored_sample(&self, index: usize, channel: usize) -> f64 {
        self.stored(index * self.channels + channel)
    }

    /// Colour and alpha of pixel `index` (row-major from the top-left), each in [0, 1]: the
    /// colour is the gray value or the mean of R, G, B; alpha is 1 when the image has none.
    #[inline]
    pub fn pixel(&self, index: usize) -> (f64, f64) {
        let base = index * self.channels;
        match self.channels {
            1 => (self.sample(base), 1.0),
            2 => (self.sample(base), self.sample(base + 1)),
            3 => ((self.sample(base) + self.sample(base + 1) + self.sample(base + 2)) / 3.0, 1.0),
            _ => ((self.sample(base) + self.sample(base + 1) + self.sample(base + 2)) / 3.0, self.sample(base + 3)),
        }
    }
}

/// Decodes PGM (P2/P5) or PNG bytes, recognised by their magic bytes.
pub(crate) fn decode_image(bytes: &[u8], name: &str) -> Result<Raster, MapError> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        decode_png(bytes, name)
    } else if bytes.starts_with(b"P5") || bytes.starts_with(b"P2") {
        decode_pgm(bytes, name)
    } else {
        Err(image_err(name, "not a PGM (P2/P5) or PNG image".to_string()))
    }
}

/// Refuses an image of more pixels than a map may have cells
/// ([`crate::grid::MAX_CELLS`]), from its header, before anything is decoded: every
/// pixel becomes a cell of the grids built from it.
fn check_pixels(name: &str, width: usize, height: usize) -> Result<(), MapError> {
    let limit = crate::grid::MAX_CELLS;
    match width.checked_mul(height) {
        Some(n) if n <= limit => Ok(()),
        _ => Err(image_err(name, format!("{width} × {height} pixels is over the limit of {limit} cells (a coarser or cropped image?)"))),
    }
}

fn image_err(name: &str, detail: String) -> MapError {
    MapError::Image { name: name.to_string(), detail }
}

/// Byte cursor over a netpbm header: whitespace and `#` comments between tokens.
struct Netpbm<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl Netpbm<'_> {
    fn skip_space_and_comments(&mut self) {
        while let Some(&b) = self.bytes.get(self.pos) {
            if b == b'#' {
                while let Some(&c) = self.bytes.get(self.pos) {
                    if c == b'\n' || c == b'\r' {
                        break;
                    }
                    self.pos += 1;
                }
            } else if b.is_ascii_whitespace() {
                self.pos += 1;
            } else {
                break;
            }
        }
    }

    /// Next unsigned decimal token (at most 9 digits, so no overflow); `None` if absent.
    fn number(&mut self) -> Option<u32> {
        self.skip_space_and_comments();
        let start = self.pos;
        let mut value: u32 = 0;
        while let Some(&b) = self.bytes.get(self.pos) {
            if !b.is_ascii_digit() || self.pos - start >= 9 {
                break;
            }
            value = value * 10 + u32::from(b - b'0');
            self.pos += 1;
        }
        let ends_cleanly = self.bytes.get(self.pos).is_none_or(|b| b.is_ascii_whitespace() || *b == b'#');
        (self.pos > start && ends_cleanly).then_some(value)
    }
}

fn decode_pgm(bytes: &[u8], name: &str) -> Result<Raster, MapError> {
    let binary = bytes.starts_with(b"P5");
    let mut cur = Netpbm { bytes, pos: 2 };
    let mut header = |what: &str| cur.number().ok_or_else(|| image_err(name, format!("PGM header: missing or invalid {what}")));
    let width = header("width")? as usize;
    let height = header("height")? as usize;
    let maxval = header("maxval")?;
    if width == 0 || height == 0 {
        return Err(image_err(name, format!("PGM size {width} × {height} is empty")));
    }
    if maxval == 0 || maxval > 65_535 {
        return Err(image_err(name, format!("PGM maxval {maxval} is not in 1..=65535")));
    }
    let bytes_per_sample = if maxval > 255 { 2 } else { 1 };
    check_pixels(name, width, height)?;
    let count = width * height;
    let need = count.saturating_mul(bytes_per_sample);
    let data = if binary {
        // Exactly one whitespace byte separates maxval from the samples.
        let start = cur.pos + 1;
        let available = bytes.len().saturating_sub(start);
        if available < need {
            return Err(image_err(name, format!("PGM data truncated: {width} × {height} pixels need {need} bytes, found {available}")));
        }
        bytes[start..start + need].to_vec()
    } else {
        // Every ascii sample takes at least two bytes (digit and separator), so the reservation
        // is bounded by the input length.
        let mut data = Vec::with_capacity(need.min(bytes.len()));
        for k in 0..count {
            let v = cur.number().ok_or_else(|| image_err(name, format!("PGM data: sample {k} of {count} is missing or not a number")))?;
            if v > maxval {
                return Err(image_err(name, format!("PGM data: sample {k} is {v}, above maxval {maxval}")));
            }
            if bytes_per_sample == 1 {
                data.push(v as u8);
            } else {
                data.extend_from_slice(&(v as u16).to_be_bytes());
            }
        }
        data
    };
    if binary && maxval < 255 && bytes_per_sample == 1 {
        if let Some(k) = data.iter().position(|&v| u32::from(v) > maxval) {
            return Err(image_err(name, format!("PGM data: sample {k} is {}, above maxval {maxval}", data[k])));
        }
    } else if binary
        && bytes_per_sample == 2
        && maxval < 65_535
        && let Some(k) = data.chunks_exact(2).position(|c| u32::from(u16::from_be_bytes([c[0], c[1]])) > maxval)
    {
        return Err(image_err(name, format!("PGM data: sample {k} is above maxval {maxval}")));
    }
    Ok(Raster { width, height, channels: 1, bytes_per_sample, max_value: f64::from(maxval), data })
}

/// Refuses a PNG whose PLTE chunk is not a whole number of RGB entries, as the PNG spec does: the
/// png crate (0.18.1, the latest release) accepts any length from 3 to 768 bytes and then panics
/// expanding such a palette (image-rs/image-png#694, fixed upstream by #682 after that release).
/// Scans the chunk headers only.
fn check_png_palette(bytes: &[u8], name: &str) -> Result<(), MapError> {
    let mut at = 8usize; // after the signature
    while let Some(&[l0, l1, l2, l3, t0, t1, t2, t3]) = bytes.get(at..at.saturating_add(8)) {
        let len = u32::from_be_bytes([l0, l1, l2, l3]) as usize;
        if [t0, t1, t2, t3] == *b"PLTE" && !len.is_multiple_of(3) {
            return Err(image_err(name, format!("invalid PNG: a PLTE chunk of {len} bytes is not a whole number of RGB entries")));
        }
        at = at.saturating_add(12).saturating_add(len); // length, type, data, CRC
    }
    Ok(())
}

fn decode_png(bytes: &[u8], name: &str) -> Result<Raster, MapError> {
    let png_err = |e: png::DecodingError| image_err(name, format!("invalid PNG: {e}"));
    check_png_palette(bytes, name)?;
    let cap = bytes.len().saturating_mul(MAX_DEFLATE_RATIO).saturating_add(1 << 16).min(MAX_DECODED_BYTES);
    let mut decoder = png::Decoder::new_with_limits(std::io::Cursor::new(bytes), png::Limits { bytes: cap });
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(png_err)?;
    let (width, height) = reader.info().size();
    check_pixels(name, width as usize, height as usize)?;
    let raw_len = reader.info().raw_row_length().saturating_mul(height as usize);
    let too_big = || image_err(name, format!("PNG of {width} × {height} pixels is implausibly large for a {} byte file", bytes.len()));
    if raw_len > cap {
        return Err(too_big());
    }
    let out_len = reader.output_buffer_size().ok_or_else(too_big)?;
    if out_len > MAX_DECODED_BYTES {
        return Err(too_big());
    }
    let mut data = vec![0u8; out_len];
    let info = reader.next_frame(&mut data).map_err(png_err)?;
    data.truncate(info.buffer_size());
    let channels = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => return Err(image_err(name, "PNG palette was not expanded".to_string())),
    };
    let (bytes_per_sample, max_value) = match info.bit_depth {
        png::BitDepth::Sixteen => (2, 65_535.0),
        png::BitDepth::Eight => (1, 255.0),
        other => return Err(image_err(name, format!("PNG bit depth {other:?} was not expanded"))),
    };
    let (width, height) = (info.width as usize, info.height as usize);
    let expected = width * height * channels * bytes_per_sample;
    if data.len() < expected {
        return Err(image_err(name, format!("PNG frame holds {} bytes, {expected} expected", data.len())));
    }
    data.truncate(expected);
    Ok(Raster { width, height, channels, bytes_per_sample, max_value, data })
}

/// Binary PGM (P5, maxval 255) of 8-bit gray rows, top row first.
pub(crate) fn write_pgm(width: usize, height: usize, rows_top_first: &[u8], comment: &str) -> Vec<u8> {
    let comment: String = comment.chars().filter(|c| *c != '\n' && *c != '\r').collect();
    let mut out = format!("P5\n# {comment}\n{width} {height}\n255\n").into_bytes();
    out.extend_from_slice(rows_top_first);
    out
}

fn write_png(width: usize, height: usize, pixels: &[u8], color: png::ColorType) -> Result<Vec<u8>, MapError> {
    let samples = color.samples();
    let expected = width.saturating_mul(height).saturating_mul(samples);
    if pixels.len() != expected || width == 0 || height == 0 {
        return Err(MapError::ImageSize { width, height, expected, got: pixels.len() });
    }
    let (Ok(w), Ok(h)) = (u32::try_from(width), u32::try_from(height)) else {
        return Err(MapError::ImageSize { width, height, expected, got: pixels.len() });
    };
    let enc_err = |e: png::EncodingError| MapError::Image { name: "PNG encoder".to_string(), detail: e.to_string() };
    let mut out = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut out, w, h);
        encoder.set_color(color);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(enc_err)?;
        writer.write_image_data(pixels).map_err(enc_err)?;
        writer.finish().map_err(enc_err)?;
    }
    Ok(out)
}

/// PNG (8-bit gray) of `width × height` pixels given row by row, top row first.
/// Errors if `rows_top_first.len() != width * height` or a side is zero.
pub fn write_png_gray8(width: usize, height: usize, rows_top_first: &[u8]) -> Result<Vec<u8>, MapError> {
    write_png(width, height, rows_top_first, png::ColorType::Grayscale)
}

/// PNG (8-bit RGB) of `width × height` pixels, `[r, g, b]` interleaved, top row first
/// (e.g. score images). Errors if `rgb_top_first.len() != 3 * width * height` or a side is zero.
pub fn write_png_rgb8(width: usize, height: usize, rgb_top_first: &[u8]) -> Result<Vec<u8>, MapError> {
    write_png(width, height, rgb_top_first, png::ColorType::Rgb)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An image of more pixels than a map may have cells is refused from its header: a 3 MB
    /// PNG of one colour would otherwise decode into 9 · 10⁸ cells.
    #[test]
    fn an_image_larger_than_a_map_may_be_is_refused_before_decoding() {
        let side = 3000; // 9 M pixels > MAX_CELLS (8.4 M)
        let png = write_png_gray8(side, side, &vec![254u8; side * side]).unwrap();
        let e = decode_image(&png, "big.png").unwrap_err().to_string();
        assert!(e.contains("big.png") && e.contains("3000 × 3000 pixels is over the limit of 8388608 cells"), "{e}");
        let e = decode_image(b"P5\n3000 3000\n255\n\0\0", "big.pgm").unwrap_err().to_string();
        assert!(e.contains("big.pgm") && e.contains("over the limit"), "{e}");
        // At the limit's side it decodes.
        let side = 2896; // 2896² = 8,386,816 ≤ 8,388,608
        let png = write_png_gray8(side, side, &vec![254u8; side * side]).unwrap();
        assert_eq!(decode_image(&png, "ok.png").unwrap().width, side);
    }
    use proptest::prelude::*;

    #[test]
    fn pgm_p5_8bit_with_comments() {
        let mut bytes = b"P5\n# made by hand\n3 2 # size\n255\n".to_vec();
        bytes.extend_from_slice(&[0, 128, 255, 10, 20, 30]);
        let r = decode_image(&bytes, "a.pgm").unwrap();
        assert_eq!((r.width, r.height, r.channels), (3, 2, 1));
        assert_eq!(r.pixel(0), (0.0, 1.0));
        assert_eq!(r.pixel(2), (1.0, 1.0));
        assert_eq!(r.pixel(3).0, 10.0 / 255.0);
    }

    #[test]
    fn pgm_p5_16bit_is_big_endian_over_maxval() {
        let mut bytes = b"P5 2 1 1000\n".to_vec();
        bytes.extend_from_slice(&[0x01, 0xF4, 0x03, 0xE8]); // 500, 1000
        let r = decode_image(&bytes, "a.pgm").unwrap();
        assert_eq!(r.pixel(0).0, 0.5);
        assert_eq!(r.pixel(1).0, 1.0);
    }

    #[test]
    fn pgm_p2_ascii() {
        let r = decode_image(b"P2\n2 2\n# c\n10\n0 5\n10 # end\n 2\n", "a.pgm").unwrap();
        let v: Vec<f64> = (0..4).map(|i| r.pixel(i).0).collect();
        assert_eq!(v, vec![0.0, 0.5, 1.0, 0.2]);
    }

    #[test]
    fn pgm_errors_are_clear() {
        let e = decode_image(b"P5\n4 4\n255\n\x00\x01", "m.pgm").unwrap_err();
        assert_eq!(e.to_string(), "m.pgm: PGM data truncated: 4 × 4 pixels need 16 bytes, found 2");
        let e = decode_image(b"P2 2 1 255 3", "m.pgm").unwrap_err();
        assert!(e.to_string().contains("sample 1 of 2 is missing"), "{e}");
        let e = decode_image(b"P2 2 1 9 3 10", "m.pgm").unwrap_err();
        assert!(e.to_string().contains("above maxval 9"), "{e}");
        let e = decode_image(b"P5 2 1 100\n\x00\xff", "m.pgm").unwrap_err();
        assert!(e.to_string().contains("above maxval 100"), "{e}");
        let e = decode_image(b"P5 0 1 255\n", "m.pgm").unwrap_err();
        assert!(e.to_string().contains("empty"), "{e}");
        let e = decode_image(b"P5 9999999 9999999 255\n\x00", "m.pgm").unwrap_err();
        assert!(e.to_string().contains("over the limit"), "{e}");
        let e = decode_image(b"P5 99 99 255\n\x00", "m.pgm").unwrap_err();
        assert!(e.to_string().contains("truncated"), "{e}");
        let e = decode_image(b"GIF89a", "m.gif").unwrap_err();
        assert_eq!(e.to_string(), "m.gif: not a PGM (P2/P5) or PNG image");
    }

    #[test]
    fn png_gray_roundtrip_and_rgb_mean() {
        let px = [0u8, 100, 200, 255, 1, 2];
        let png = write_png_gray8(3, 2, &px).unwrap();
        let r = decode_image(&png, "a.png").unwrap();
        assert_eq!((r.width, r.height, r.channels), (3, 2, 1));
        for (i, &v) in px.iter().enumerate() {
            assert_eq!(r.pixel(i), (f64::from(v) / 255.0, 1.0));
        }
        let rgb = write_png_rgb8(1, 1, &[30, 60, 90]).unwrap();
        let r = decode_image(&rgb, "c.png").unwrap();
        assert!((r.pixel(0).0 - 60.0 / 255.0).abs() < 1e-12);
        assert!(matches!(write_png_gray8(2, 2, &[0; 3]), Err(MapError::ImageSize { expected: 4, got: 3, .. })));
        assert!(write_png_gray8(0, 0, &[]).is_err());
    }

    #[test]
    fn png_16bit_gray_alpha() {
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, 1, 1);
            enc.set_color(png::ColorType::GrayscaleAlpha);
            enc.set_depth(png::BitDepth::Sixteen);
            let mut w = enc.write_header().unwrap();
            w.write_image_data(&[0x80, 0x00, 0xFF, 0xFF]).unwrap();
            w.finish().unwrap();
        }
        let r = decode_image(&out, "a.png").unwrap();
        assert_eq!(r.channels, 2);
        assert_eq!(r.pixel(0), (32_768.0 / 65_535.0, 1.0));
    }

    #[test]
    fn truncated_png_is_an_error() {
        let png = write_png_gray8(4, 4, &[7; 16]).unwrap();
        for cut in [8, 20, png.len() - 13] {
            assert!(decode_image(&png[..cut], "t.png").is_err(), "cut {cut}");
        }
    }

    /// fuzz: a palette PNG whose PLTE chunk is not a multiple of 3 bytes made the png crate panic
    /// ("range end index 3 out of range for slice of length 2" in its palette expansion;
    /// image-rs/image-png#694).
    #[test]
    fn palette_of_a_partial_rgb_entry_is_an_error_not_a_panic() {
        let mut valid = Vec::new();
        {
            let mut encoder = png::Encoder::new(&mut valid, 2, 1);
            encoder.set_color(png::ColorType::Indexed);
            encoder.set_depth(png::BitDepth::Eight);
            encoder.set_palette(vec![0, 0, 0, 255, 255, 255]);
            let mut writer = encoder.write_header().unwrap();
            writer.write_image_data(&[0, 1]).unwrap();
            writer.finish().unwrap();
        }
        let r = decode_image(&valid, "p.png").unwrap();
        assert_eq!((r.pixel(0).0, r.pixel(1).0), (0.0, 1.0));
        // The same file with a PLTE chunk of `n` bytes (a correct CRC, so only the length is wrong).
        let with_palette = |n: usize| {
            let at = valid.windows(4).position(|w| w == b"PLTE").unwrap() - 4;
            let mut chunk = (n as u32).to_be_bytes().to_vec();
            chunk.extend_from_slice(b"PLTE");
            chunk.extend((0..n).map(|i| (i * 40) as u8));
            let crc = crc32fast::hash(&chunk[4..]);
            chunk.extend_from_slice(&crc.to_be_bytes());
            [&valid[..at], &chunk[..], &valid[at + 12 + 6..]].concat()
        };
        assert!(decode_image(&with_palette(9), "p.png").is_ok());
        for n in [4, 5, 7, 8, 767] {
            let e = decode_image(&with_palette(n), "p.png").unwrap_err().to_string();
            assert_eq!(e, format!("p.png: invalid PNG: a PLTE chunk of {n} bytes is not a whole number of RGB entries"));
        }
    }

    proptest! {
        #[test]
        fn arbitrary_bytes_never_panic(prefix in prop::sample::select(vec![&b""[..], b"P5", b"P2", b"\x89PNG\r\n\x1a\n"]), tail in prop::collection::vec(any::<u8>(), 0..300)) {
            let mut bytes = prefix.to_vec();
            bytes.extend_from_slice(&tail);
            let _ = decode_image(&bytes, "x");
        }

        #[test]
        fn mutated_png_never_panics(pos in any::<prop::sample::Index>(), byte in any::<u8>(), cut in any::<prop::sample::Index>()) {
            let png = write_png_gray8(5, 3, &[1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15]).unwrap();
            let mut m = png.clone();
            let i = pos.index(m.len());
            m[i] = byte;
            let _ = decode_image(&m, "x.png");
            let _ = decode_image(&png[..cut.index(png.len())], "x.png");
        }

        #[test]
        fn pgm_write_read_roundtrip(w in 1usize..20, h in 1usize..20, seed in any::<u64>()) {
            let px: Vec<u8> = (0..w * h).map(|i| (seed.wrapping_mul(i as u64 + 7) >> 13) as u8).collect();
            let pgm = write_pgm(w, h, &px, "c\nd");
            let r = decode_image(&pgm, "x.pgm").unwrap();
            prop_assert_eq!((r.width, r.height), (w, h));
            for (i, &v) in px.iter().enumerate() {
                prop_assert_eq!(r.pixel(i).0, f64::from(v) / 255.0);
            }
        }
    }
}
