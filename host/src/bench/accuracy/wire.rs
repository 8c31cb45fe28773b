//! Bytes on the wire: the framed `LineResult`s of an image with 16-bit pixels (what the
//! protocol carries) against 8-bit ones (what an 8-bit wire would carry), and their serial time.

use strahl_core::accel::work::QueryWork;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::stats::RayCounts;
use strahl_core::wire::error::ProtocolError;
use strahl_core::wire::frame::FrameWriter;
use strahl_core::wire::message::{encode_pixels, WorkerMessage};
use strahl_core::wire::PIXEL_WIRE_BYTES;

/// Bytes per pixel of an 8-bit wire: one byte per channel (the protocol's pixels are
/// [`PIXEL_WIRE_BYTES`], three little-endian `u16`).
pub const PIXEL_WIRE_BYTES_8: usize = 3;

/// Bits on a serial line per byte: 8N1 (start bit, 8 data bits, stop bit).
pub const SERIAL_BITS_PER_BYTE: u32 = 10;

/// The bytes one image's line results take on the wire, framed as the protocol sends them
/// (postcard payload, CRC-32, COBS, both `0x00` delimiters), with 16-bit pixels as the protocol
/// carries them and with 8-bit ones as an 8-bit wire would.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WireBytes {
    /// Pixels per line.
    pub width: u32,
    /// Lines (one `LineResult` each; an adaptive render sends a second one per refined line).
    pub lines: u32,
    /// Every line result with 16-bit pixels ([`PIXEL_WIRE_BYTES`] each).
    pub image16: usize,
    /// Every line result with 8-bit pixels ([`PIXEL_WIRE_BYTES_8`] each, in the same field).
    pub image8: usize,
}

impl WireBytes {
    /// Mean framed bytes of one line result.
    pub fn per_line(&self, eight_bit: bool) -> f64 {
        let total = if eight_bit { self.image8 } else { self.image16 };
        total as f64 / f64::from(self.lines.max(1))
    }

    /// The pixel bytes alone of one line.
    pub fn pixel_bytes(&self, eight_bit: bool) -> usize {
        self.width as usize
            * if eight_bit {
                PIXEL_WIRE_BYTES_8
            } else {
                PIXEL_WIRE_BYTES
            }
    }

    /// The share of the image's bytes an 8-bit wire would save.
    pub fn saving(&self) -> f64 {
        if self.image16 == 0 {
            0.0
        } else {
            1.0 - self.image8 as f64 / self.image16 as f64
        }
    }
}

/// Seconds `bytes` take on a serial line at `baud`, 8N1.
pub fn serial_seconds(bytes: usize, baud: u32) -> f64 {
    bytes as f64 * f64::from(SERIAL_BITS_PER_BYTE) / f64::from(baud.max(1))
}

/// The framed `LineResult` of line `line` of job `job` carrying `pixels` as the protocol encodes
/// them ([`encode_pixels`], 16 bits per channel) or, with `eight_bit`, as 8-bit channels in the
/// same field (a message the protocol does not define: decoders reject it; only its length
/// matters). Returns the frame's bytes, delimiters included.
///
/// # Errors
/// [`ProtocolError::Encode`] if postcard cannot encode the message.
pub fn line_result_frame(
    writer: &mut FrameWriter,
    job: u32,
    line: u32,
    rays: RayCounts,
    pixels: &[Pixel],
    eight_bit: bool,
) -> Result<Vec<u8>, ProtocolError> {
    let bytes: Vec<u8> = if eight_bit {
        pixels.iter().flat_map(|p| p.to_rgb8()).collect()
    } else {
        let mut wire = vec![0u8; pixels.len() * PIXEL_WIRE_BYTES];
        encode_pixels(pixels, &mut wire)?;
        wire
    };
    let frame = writer.encode(&WorkerMessage::LineResult {
        job,
        line,
        refined: false,
        rays,
        pixels: &bytes,
    })?;
    Ok(frame.to_vec())
}

/// The line results of an image (`pixels`, row-major, `width` per line) that took `rays`, one
/// per line, with 16- and with 8-bit pixels. Each line carries the image's mean rays per line
/// (a ray count takes one to a few bytes). Job 1 (job numbers take one byte up to 127).
///
/// # Errors
/// [`ProtocolError::Encode`] if a message cannot be encoded.
pub fn wire_bytes(
    pixels: &[Pixel],
    width: u32,
    rays: RayCounts,
) -> Result<WireBytes, ProtocolError> {
    let w = width.max(1) as usize;
    let lines = (pixels.len() / w) as u32;
    let n = u64::from(lines.max(1));
    let per_line = RayCounts {
        primary: rays.primary / n,
        extra_samples: rays.extra_samples / n,
        shadow: rays.shadow / n,
        reflection: rays.reflection / n,
        refraction: rays.refraction / n,
        occlusion: rays.occlusion / n,
        work: QueryWork {
            intersection_tests: rays.work.intersection_tests / n,
            octree_cells: rays.work.octree_cells / n,
        },
    };
    let mut writer = FrameWriter::new();
    let (mut image16, mut image8) = (0, 0);
    for (y, line) in pixels.chunks_exact(w).enumerate() {
        image16 += line_result_frame(&mut writer, 1, y as u32, per_line, line, false)?.len();
        image8 += line_result_frame(&mut writer, 1, y as u32, per_line, line, true)?.len();
    }
    Ok(WireBytes {
        width,
        lines,
        image16,
        image8,
    })
}

/// Bytes with thousands separated by a thin space (`1 234 567`).
pub(super) fn fmt_bytes(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push('\u{2009}');
        }
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wire_bytes_are_the_protocols_frames() {
        use strahl_core::wire::frame::{FrameReader, ReadEvent};
        use strahl_core::wire::message::decode_pixels;
        use strahl_core::wire::MAX_FRAME_LEN;
        let (w, h) = (40u32, 3u32);
        let px: Vec<Pixel> = (0..w * h)
            .map(|i| Pixel([(i * 523) as u16, (i * 97) as u16, 65535 - i as u16]))
            .collect();
        let rays = RayCounts {
            primary: u64::from(w * h),
            shadow: 300,
            ..RayCounts::default()
        };
        let wb = wire_bytes(&px, w, rays).expect("encodes");
        assert_eq!((wb.width, wb.lines), (w, h));
        assert_eq!(wb.pixel_bytes(false), 240);
        assert_eq!(wb.pixel_bytes(true), 120);
        // Each 16-bit frame is a valid line result that decodes to the line's pixels.
        let mut writer = FrameWriter::new();
        let mut total = 0;
        for (y, line) in px.chunks_exact(w as usize).enumerate() {
            let frame =
                line_result_frame(&mut writer, 1, y as u32, rays, line, false).expect("encodes");
            total += frame.len();
            let mut reader = FrameReader::new(vec![0u8; MAX_FRAME_LEN]);
            let mut link: &[u8] = &frame;
            let ReadEvent::Frame(payload) = reader.next(&mut link).expect("reads") else {
                panic!("no frame");
            };
            let WorkerMessage::LineResult {
                line: l, pixels, ..
            } = WorkerMessage::decode(payload).expect("decodes")
            else {
                panic!("not a line result");
            };
            assert_eq!(l, y as u32);
            let mut back = vec![Pixel::default(); w as usize];
            decode_pixels(pixels, &mut back).expect("whole pixels");
            assert_eq!(back, line);
        }
        // The image's bytes are those frames (with the mean rays per line, which here are
        // encoded in as many bytes as the image's).
        assert!(
            total.abs_diff(wb.image16) <= 3 * h as usize,
            "{total} {}",
            wb.image16
        );
        // 8 bits: 3 bytes less per pixel, give or take COBS's code bytes.
        let saved = wb.image16 - wb.image8;
        assert!(
            saved.abs_diff(3 * (w * h) as usize) <= 2 * h as usize,
            "{saved}"
        );
        assert!(wb.saving() > 0.4 && wb.saving() < 0.5, "{}", wb.saving());
        assert!((wb.per_line(false) - wb.image16 as f64 / 3.0).abs() < 1e-9);
        assert!((serial_seconds(11_520, 115_200) - 1.0).abs() < 1e-12);
        assert_eq!(fmt_bytes(1_234_567), "1\u{2009}234\u{2009}567");
        assert_eq!(fmt_bytes(999), "999");
    }
}
