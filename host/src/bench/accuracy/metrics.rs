//! Error metrics of an image against a reference: RMSE, PSNR, SSIM, the 8-bit round trip,
//! and the Pareto front of (time, error) points.

use strahl_core::render::pixel::Pixel;

/// An image as linear colours in `[0, 1]`, row-major.
pub type Colors = Vec<[f32; 3]>;

/// The colours of 16-bit pixels.
pub fn to_colors(pixels: &[Pixel]) -> Colors {
    pixels
        .iter()
        .map(|p| p.0.map(|c| f32::from(c) / 65535.0))
        .collect()
}

/// `pixels` sent as 8 bits per channel and widened back to 16 (what an 8-bit wire would deliver).
pub fn through_8_bits(pixels: &[Pixel]) -> Vec<Pixel> {
    pixels
        .iter()
        .map(|p| Pixel(p.to_rgb8().map(|c| u16::from(c) * 257)))
        .collect()
}

/// Root-mean-square difference over every channel of every pixel (colours in `[0, 1]`); 0 for
/// identical images. Images of different lengths compare over the shorter.
pub fn rmse(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let n = a.len().min(b.len());
    if n == 0 {
        return 0.0;
    }
    let sum: f64 = a
        .iter()
        .zip(b)
        .flat_map(|(p, q)| (0..3).map(move |c| f64::from(p[c]) - f64::from(q[c])))
        .map(|d| d * d)
        .sum();
    (sum / (3 * n) as f64).sqrt()
}

/// Peak signal-to-noise ratio in dB for colours in `[0, 1]`: `20·log10(1 / rmse)`, infinite for
/// identical images.
pub fn psnr(rmse: f64) -> f64 {
    if rmse <= 0.0 {
        f64::INFINITY
    } else {
        -20.0 * rmse.log10()
    }
}

/// Rec. 709 luminance of linear colours.
pub(super) fn luminance(img: &[[f32; 3]]) -> Vec<f64> {
    img.iter()
        .map(|c| 0.2126 * f64::from(c[0]) + 0.7152 * f64::from(c[1]) + 0.0722 * f64::from(c[2]))
        .collect()
}

/// Structural similarity (Wang et al. 2004) of two `width × height` images on luminance: an
/// 11×11 Gaussian window with σ = 1.5 over every position where it fits (smaller images get
/// the largest odd window that fits, σ scaled with it), `C1 = (0.01)²`, `C2 = (0.03)²` for a
/// dynamic range of 1, averaged. 1 for identical images; near or below 0 for unrelated or
/// inverted ones.
pub fn ssim(a: &[[f32; 3]], b: &[[f32; 3]], width: usize, height: usize) -> f64 {
    let n = width * height;
    if n == 0 || a.len() < n || b.len() < n {
        return 0.0;
    }
    let mut size = 11.min(width).min(height);
    if size % 2 == 0 {
        size -= 1;
    }
    let sigma = 1.5 * size as f64 / 11.0;
    let r = (size / 2) as isize;
    let mut weights: Vec<f64> = (-r..=r)
        .map(|i| (-((i * i) as f64) / (2.0 * sigma * sigma)).exp())
        .collect();
    let total: f64 = weights.iter().sum();
    weights.iter_mut().for_each(|w| *w /= total);

    let x = luminance(&a[..n]);
    let y = luminance(&b[..n]);
    let planes: [Vec<f64>; 5] = [
        x.clone(),
        y.clone(),
        x.iter().map(|v| v * v).collect(),
        y.iter().map(|v| v * v).collect(),
        x.iter().zip(&y).map(|(p, q)| p * q).collect(),
    ];
    // Separable filtering over the valid region: rows first, then columns. The two passes look
    // alike but step along different axes (stride 1, then stride `ow`); written out, each reads
    // as the formula it is.
    let (ow, oh) = (width + 1 - size, height + 1 - size);
    let filter = |plane: &[f64]| -> Vec<f64> {
        let mut rows = vec![0.0; ow * height];
        for yy in 0..height {
            for xx in 0..ow {
                rows[yy * ow + xx] = weights
                    .iter()
                    .enumerate()
                    .map(|(k, w)| w * plane[yy * width + xx + k])
                    .sum();
            }
        }
        let mut out = vec![0.0; ow * oh];
        for yy in 0..oh {
            for xx in 0..ow {
                out[yy * ow + xx] = weights
                    .iter()
                    .enumerate()
                    .map(|(k, w)| w * rows[(yy + k) * ow + xx])
                    .sum();
            }
        }
        out
    };
    let [mx, my, mxx, myy, mxy] = planes.map(|p| filter(&p));
    let (c1, c2) = (0.01f64 * 0.01, 0.03f64 * 0.03);
    let sum: f64 = (0..ow * oh)
        .map(|i| {
            let (ux, uy) = (mx[i], my[i]);
            let vx = mxx[i] - ux * ux;
            let vy = myy[i] - uy * uy;
            let cxy = mxy[i] - ux * uy;
            ((2.0 * ux * uy + c1) * (2.0 * cxy + c2)) / ((ux * ux + uy * uy + c1) * (vx + vy + c2))
        })
        .sum();
    sum / (ow * oh) as f64
}

/// The Pareto front of `(time, error)` points, both to be minimised: the indices of the points
/// that no other point matches or beats in both with one strictly better, ordered by time.
/// Points with a non-finite coordinate are left out; of equal points the first is kept.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].0.is_finite() && points[i].1.is_finite())
        .collect();
    order.sort_by(|&i, &j| {
        points[i]
            .0
            .total_cmp(&points[j].0)
            .then(points[i].1.total_cmp(&points[j].1))
            .then(i.cmp(&j))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in order {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A textured test image: a ramp plus a strong local pattern (SSIM needs local contrast
    /// well above its stabilising constants).
    fn gradient(w: usize, h: usize) -> Colors {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let v = 0.2 * x / w as f32 + 0.4 + 0.35 * (x * 1.3).sin() * (y * 0.9).cos();
                [v, v * 0.9, v * 0.8 + 0.1]
            })
            .collect()
    }

    #[test]
    fn rmse_and_psnr_of_identical_images() {
        let a = gradient(20, 15);
        assert_eq!(rmse(&a, &a), 0.0);
        assert!(psnr(rmse(&a, &a)).is_infinite());
        assert!(psnr(0.0) > 0.0);
    }

    #[test]
    fn rmse_and_psnr_of_a_known_offset() {
        let a = vec![[0.25f32, 0.5, 0.75]; 12];
        let b: Colors = a.iter().map(|c| c.map(|v| v + 0.125)).collect();
        assert!((rmse(&a, &b) - 0.125).abs() < 1e-9);
        assert!((psnr(0.1) - 20.0).abs() < 1e-9);
        assert!((psnr(0.01) - 40.0).abs() < 1e-9);
    }

    #[test]
    fn ssim_of_identical_images_is_one_and_of_the_inverse_is_low() {
        let (w, h) = (24, 18);
        let a = gradient(w, h);
        assert!((ssim(&a, &a, w, h) - 1.0).abs() < 1e-12);
        let inv: Colors = a.iter().map(|c| c.map(|v| 1.0 - v)).collect();
        let s = ssim(&a, &inv, w, h);
        assert!(s < 0.1, "SSIM of an image and its inverse: {s}");
        // A little noise keeps it high.
        let noisy: Colors = a
            .iter()
            .enumerate()
            .map(|(i, c)| c.map(|v| v + if i % 2 == 0 { 0.002 } else { -0.002 }))
            .collect();
        let s = ssim(&a, &noisy, w, h);
        assert!(s > 0.9 && s < 1.0, "SSIM with slight noise: {s}");
    }

    #[test]
    fn ssim_of_images_smaller_than_the_window() {
        let a = gradient(6, 4);
        assert!((ssim(&a, &a, 6, 4) - 1.0).abs() < 1e-12);
        assert_eq!(ssim(&a, &a, 0, 0), 0.0);
    }

    #[test]
    fn pareto_front_of_a_known_set() {
        let pts = [
            (1.0, 0.10),     // 0: front (fastest)
            (2.0, 0.05),     // 1: front
            (2.5, 0.08),     // 2: dominated by 1
            (4.0, 0.02),     // 3: front
            (4.0, 0.03),     // 4: dominated by 3 (same time, more error)
            (8.0, 0.02),     // 5: dominated by 3 (same error, slower)
            (16.0, 0.0),     // 6: front (exact)
            (f64::NAN, 0.0), // 7: left out
        ];
        assert_eq!(pareto_front(&pts), vec![0, 1, 3, 6]);
        assert!(pareto_front(&[]).is_empty());
        assert_eq!(pareto_front(&[(1.0, 1.0), (1.0, 1.0)]), vec![0]);
    }

    #[test]
    fn eight_bit_round_trip_error_is_within_half_a_step() {
        let px: Vec<Pixel> = (0..=65535u16)
            .step_by(97)
            .map(|v| Pixel([v, v / 2, 65535 - v]))
            .collect();
        let e = rmse(&to_colors(&px), &to_colors(&through_8_bits(&px)));
        assert!(e > 0.0 && e <= 0.5 / 255.0 + 1e-6, "{e}");
        let exact: Vec<Pixel> = (0..=255u16).map(|v| Pixel([v * 257; 3])).collect();
        assert_eq!(through_8_bits(&exact), exact);
    }
}
