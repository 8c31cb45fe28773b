//! Consistent Overhead Byte Stuffing (Cheshire and Baker, 1999), a run at a time.
//!
//! COBS replaces every `0x00` of a payload, so that `0x00` can delimit frames ([`super::frame`]).
//! The encoding is a sequence of blocks: a code byte `k` (1 to 255), then `k − 1` bytes that are
//! not zero; a block with `k < 255` stands for its bytes followed by a zero, except the last
//! block, whose zero is not there. A run of 254 bytes without a zero takes a block of code 255,
//! which implies no zero.
//!
//! [`encode`] and [`decode_in_place`] give the bytes of the `cobs` crate's `encode` and
//! `decode_in_place` (the tests compare them on every run length and on random payloads), but
//! they find each zero eight bytes at a time and copy each block whole, where the crate's
//! encoder steps a state machine per byte: about 22 instructions a byte, over a quarter of a
//! worker's instructions on an image of background only (callgrind).

/// The most bytes a payload of `len` bytes encodes to: one code byte per started run of 254.
pub const fn max_encoding_length(len: usize) -> usize {
    len + len.div_ceil(254)
}

/// The longest run of bytes a block holds.
const RUN: usize = 254;

/// Encodes `src` into `dst`, which must be at least [`max_encoding_length`] of `src` long, and
/// returns the encoding's length (0 for an empty `src`). No `0x00` is written.
///
/// # Panics
/// If `dst` is shorter than [`max_encoding_length`] of `src`.
pub fn encode(src: &[u8], dst: &mut [u8]) -> usize {
    if src.is_empty() {
        return 0;
    }
    let (mut rest, mut out) = (src, 0);
    loop {
        let window = &rest[..rest.len().min(RUN)];
        let zero = first_zero(window);
        let run = zero.unwrap_or(window.len());
        dst[out] = run as u8 + 1;
        dst[out + 1..out + 1 + run].copy_from_slice(&rest[..run]);
        out += run + 1;
        match zero {
            // The zero is the block's; a zero that ends the payload leaves an empty last block.
            Some(_) => {
                rest = &rest[run + 1..];
                if rest.is_empty() {
                    dst[out] = 1;
                    return out + 1;
                }
            }
            None => {
                rest = &rest[run..];
                if rest.is_empty() {
                    return out;
                }
            }
        }
    }
}

/// Decodes the COBS encoding at the start of `buf` (up to its first `0x00`, if any) in place
/// and returns the decoded length, or `None` if `buf` is empty or a block runs past the end.
pub fn decode_in_place(buf: &mut [u8]) -> Option<usize> {
    if buf.is_empty() {
        return None;
    }
    let end = first_zero(buf).unwrap_or(buf.len());
    let (mut src, mut dst) = (0, 0);
    while src < end {
        let code = usize::from(buf[src]);
        if src + code > end {
            return None;
        }
        buf.copy_within(src + 1..src + code, dst);
        dst += code - 1;
        src += code;
        if code != RUN + 1 && src < end {
            buf[dst] = 0;
            dst += 1;
        }
    }
    Some(dst)
}

/// The index of the first `0x00` in `bytes`: eight bytes at a time, by the bit trick that flags
/// a zero byte in a word (`(w − 0x01…01) & !w & 0x80…80` is not zero exactly when a byte of `w`
/// is; the first flagged byte is the first zero), then the rest one at a time.
fn first_zero(bytes: &[u8]) -> Option<usize> {
    const ONES: u64 = 0x0101_0101_0101_0101;
    const HIGHS: u64 = 0x8080_8080_8080_8080;
    let mut words = bytes.chunks_exact(8);
    for (k, word) in words.by_ref().enumerate() {
        let mut w = [0u8; 8];
        w.copy_from_slice(word);
        let w = u64::from_le_bytes(w);
        let flags = w.wrapping_sub(ONES) & !w & HIGHS;
        if flags != 0 {
            return Some(8 * k + flags.trailing_zeros() as usize / 8);
        }
    }
    let done = bytes.len() - words.remainder().len();
    words
        .remainder()
        .iter()
        .position(|&b| b == 0)
        .map(|i| done + i)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::mesh::Rng;
    use alloc::vec;
    use alloc::vec::Vec;

    /// The `cobs` crate's encoding of `src`.
    fn crate_encoding(src: &[u8]) -> Vec<u8> {
        let mut out = vec![0u8; cobs::max_encoding_length(src.len())];
        let n = cobs::encode(src, &mut out);
        out.truncate(n);
        out
    }

    fn ours(src: &[u8]) -> Vec<u8> {
        let mut out = vec![0u8; max_encoding_length(src.len())];
        let n = encode(src, &mut out);
        out.truncate(n);
        out
    }

    /// Payloads of every length up to three blocks, of no zeros, of zeros only, and with zeros
    /// at the ends of and around each block boundary; then random payloads, zeros frequent or
    /// rare.
    fn payloads() -> Vec<Vec<u8>> {
        let mut all = Vec::new();
        for len in 0..=3 * RUN + 3 {
            all.push(vec![0x55; len]);
            all.push(vec![0; len]);
            for at in [0, 1, RUN - 1, RUN, RUN + 1, len.saturating_sub(1)] {
                let mut p = vec![0xAA; len];
                if at < len {
                    p[at] = 0;
                    all.push(p);
                }
            }
        }
        let mut rng = Rng::new(5);
        for case in 0..2_000 {
            let len = (rng.next_u64() % 1500) as usize;
            let zeros = [2, 16, 300][case % 3];
            let p = (0..len)
                .map(|_| match rng.next_u64() % zeros {
                    0 => 0,
                    v => v as u8 | 1,
                })
                .collect();
            all.push(p);
        }
        all
    }

    #[test]
    fn encodes_as_the_cobs_crate_does_and_decodes_back() {
        for p in payloads() {
            let enc = ours(&p);
            assert_eq!(enc, crate_encoding(&p), "payload of {} bytes", p.len());
            assert!(enc.len() <= max_encoding_length(p.len()));
            assert!(!enc.contains(&0));
            if p.is_empty() {
                continue;
            }
            let mut buf = enc.clone();
            let n = decode_in_place(&mut buf).expect("decodes");
            assert_eq!(&buf[..n], &p[..], "payload of {} bytes", p.len());
        }
    }

    /// On any bytes, a valid encoding or not, the decoder accepts what the crate accepts and
    /// gives the same bytes: random bytes, and blocks laid end to end (valid) with one byte
    /// changed at random in every other case.
    #[test]
    fn decodes_any_bytes_as_the_cobs_crate_does() {
        let mut rng = Rng::new(11);
        let mut accepted = 0;
        for case in 0..20_000 {
            let len = (rng.next_u64() % 700) as usize;
            let mut buf: Vec<u8> = Vec::with_capacity(len);
            if case % 4 < 2 {
                while buf.len() < len {
                    let code = [(rng.next_u64() % 12) as u8 + 1, 255][usize::from(case % 8 == 0)];
                    buf.push(code);
                    buf.extend((1..code).map(|_| (rng.next_u64() as u8).max(1)));
                }
                if case % 2 == 1 && !buf.is_empty() {
                    let at = (rng.next_u64() % buf.len() as u64) as usize;
                    buf[at] = rng.next_u64() as u8;
                }
            } else {
                buf.extend((0..len).map(|_| rng.next_u64() as u8));
            }
            let mut theirs = buf.clone();
            let want = cobs::decode_in_place(&mut theirs).ok();
            let got = decode_in_place(&mut buf);
            assert_eq!(got, want, "case {case}");
            if let Some(n) = got {
                assert_eq!(buf[..n], theirs[..n], "case {case}");
                accepted += 1;
            }
        }
        assert!(accepted > 5_000, "only {accepted} buffers decoded");
    }

    #[test]
    fn finds_the_first_zero_at_every_position() {
        for len in 0..40 {
            assert_eq!(first_zero(&vec![7u8; len]), None);
            for at in 0..len {
                // 0x01 after a zero is where the word trick flags a byte that is not zero.
                let fill = if len % 2 == 0 { 0x80u8 } else { 0x01 };
                let mut b = vec![fill; len];
                b[at] = 0;
                if at + 1 < len {
                    b[len - 1] = 0;
                }
                assert_eq!(first_zero(&b), Some(at), "len {len}, zero at {at}");
            }
        }
    }
}
