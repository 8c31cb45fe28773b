//! Number formatting for the report's tables and text.

use super::Row;
use std::time::Duration;
use strahl_core::scene::RenderSettings;

/// `v` with three significant digits, without exponent.
pub(super) fn sig3(v: f64) -> String {
    if v == 0.0 {
        return "0".to_string();
    }
    if !v.is_finite() {
        return v.to_string();
    }
    let mag = v.abs().log10().floor() as i32;
    let decimals = (2 - mag).max(0) as usize;
    format!("{v:.decimals$}")
}

pub(super) fn fmt_psnr(p: f64) -> String {
    if p.is_infinite() {
        "∞".to_string()
    } else {
        format!("{p:.2}")
    }
}

pub(super) fn fmt_ssim(s: f64) -> String {
    if s == 1.0 {
        "1".to_string()
    } else {
        format!("{s:.5}")
    }
}

pub(super) fn fmt_secs(t: Duration) -> String {
    format!("{:.3}", t.as_secs_f64())
}

pub(super) fn fmt_ratio(r: f64) -> String {
    if r >= 10.0 {
        format!("{r:.1}×")
    } else {
        format!("{r:.2}×")
    }
}

pub(super) fn fmt_rays(r: u64) -> String {
    if r >= 10_000_000 {
        format!("{:.0} M", r as f64 / 1e6)
    } else if r >= 1_000_000 {
        format!("{:.1} M", r as f64 / 1e6)
    } else if r >= 10_000 {
        format!("{:.0} k", r as f64 / 1e3)
    } else {
        r.to_string()
    }
}

/// Two figures to three significant digits, or five where three would look the same.
pub(super) fn sig_pair(a: f64, b: f64) -> (String, String) {
    let (x, y) = (sig3(a), sig3(b));
    if x != y || a == b {
        return (x, y);
    }
    let five = |v: f64| {
        let mag = v.abs().log10().floor() as i32;
        let decimals = (4 - mag).max(0) as usize;
        format!("{v:.decimals$}")
    };
    (five(a), five(b))
}

/// "lowers RMSE from a to b", "raises ...", or "leaves RMSE at a".
pub(super) fn rmse_change(a: f64, b: f64) -> String {
    let (x, y) = sig_pair(a, b);
    if a == b {
        format!("leaves RMSE at {x}")
    } else if b < a {
        format!("lowers RMSE from {x} to {y}")
    } else {
        format!("raises RMSE from {x} to {y}")
    }
}

pub(super) fn settings_summary(s: &RenderSettings) -> String {
    format!(
        "multisample {}, shadows {}, reflections {}, cut-off {}, depth cap {}, AO {}",
        s.samples,
        if s.shadows { "on" } else { "off" },
        if s.reflections { "on" } else { "off" },
        percent(s.min_reflection_weight),
        s.max_depth,
        s.ambient_occlusion
    )
}

/// One result row on stdout, in aligned columns.
pub(super) fn stdout_row(
    out: &mut impl std::io::Write,
    scene: &str,
    r: &Row,
    rays: u64,
) -> std::io::Result<()> {
    let [scene, knob, value, time, ratio, rmse, psnr, ssim, rays, reference] =
        row_cells(scene, r, rays);
    writeln!(
        out,
        "{scene:<28} {knob:<26} {value:>12} {time:>9} {ratio:>8} {rmse:>10} {psnr:>7} {ssim:>8} \
         {rays:>8}  {reference}"
    )
}

/// The cells of a result row, in table order: scene, knob, value, time, × baseline, RMSE, PSNR,
/// SSIM, `rays` and what it is compared with.
pub(super) fn row_cells(scene: &str, r: &Row, rays: u64) -> [String; 10] {
    [
        scene.to_string(),
        r.knob.name().to_string(),
        r.value.clone(),
        fmt_secs(r.time),
        fmt_ratio(r.ratio),
        sig3(r.errors.rmse),
        fmt_psnr(r.errors.psnr),
        fmt_ssim(r.errors.ssim),
        fmt_rays(rays),
        r.reference.name().to_string(),
    ]
}

/// A fraction as a percentage with at most two decimals (`0.1` is `10 %`, `0.005` is `0.5 %`).
pub(super) fn percent(v: f32) -> String {
    let p = format!("{:.2}", f64::from(v) * 100.0);
    let p = p.trim_end_matches('0').trim_end_matches('.');
    format!("{p} %")
}

/// Values joined as prose: `a`, `a and b`, `a, b and c`.
pub(super) fn join_values(v: &[String]) -> String {
    match v {
        [] => String::new(),
        [a] => a.clone(),
        [rest @ .., last] => format!("{} and {last}", rest.join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sig3_formats() {
        assert_eq!(sig3(0.012345), "0.0123");
        assert_eq!(sig3(1.5), "1.50");
        assert_eq!(sig3(0.0), "0");
    }
}
