//! Quantities as short text for people: ray rates in the progress bar, the summary and the
//! worker table; sizes in bytes in the summary and `bench peers`.

/// `rays` traced in `secs` seconds, as a short rate such as `2.15 M rays/s`.
pub fn format_ray_rate(rays: u64, secs: f64) -> String {
    match scaled_rate(rays, secs) {
        Some((number, "")) => format!("{number} rays/s"),
        Some((number, unit)) => format!("{number} {unit} rays/s"),
        None => "- rays/s".to_string(),
    }
}

/// A rate of `count` per `secs` as a short number for tables: `1.50M`, `239.2k`, `950`, or `-`
/// for no time.
pub fn format_rate_short(count: u64, secs: f64) -> String {
    match scaled_rate(count, secs) {
        Some((number, unit)) => format!("{number}{unit}"),
        None => "-".to_string(),
    }
}

/// `count / secs` as a number of three or four digits and its unit (`G`, `M`, `k` or none);
/// `None` for no time.
fn scaled_rate(count: u64, secs: f64) -> Option<(String, &'static str)> {
    if secs <= 0.0 || !secs.is_finite() {
        return None;
    }
    let rate = count as f64 / secs;
    Some(if rate >= 1e9 {
        (format!("{:.2}", rate / 1e9), "G")
    } else if rate >= 1e6 {
        (format!("{:.2}", rate / 1e6), "M")
    } else if rate >= 1e3 {
        (format!("{:.1}", rate / 1e3), "k")
    } else {
        (format!("{rate:.0}"), "")
    })
}

/// `n` with its digits grouped by thousands: `16,476,814`.
pub fn group_digits(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::with_capacity(digits.len() + digits.len() / 3);
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// `bytes` as a short human size: `512 B`, `3.4 KiB`, `1.2 MiB`, `2.0 GiB`.
pub fn format_bytes(bytes: usize) -> String {
    const KIB: f64 = 1024.0;
    let b = bytes as f64;
    if b < KIB {
        format!("{bytes} B")
    } else if b < KIB * KIB {
        format!("{:.1} KiB", b / KIB)
    } else if b < KIB * KIB * KIB {
        format!("{:.1} MiB", b / (KIB * KIB))
    } else {
        format!("{:.1} GiB", b / (KIB * KIB * KIB))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates() {
        assert_eq!(format_ray_rate(2_150_000, 1.0), "2.15 M rays/s");
        assert_eq!(format_ray_rate(1500, 1.0), "1.5 k rays/s");
        assert_eq!(format_ray_rate(12, 2.0), "6 rays/s");
        assert_eq!(format_ray_rate(12, 0.0), "- rays/s");
        assert_eq!(format_rate_short(2_150_000, 1.0), "2.15M");
        assert_eq!(format_rate_short(239_250, 1.0), "239.2k");
        assert_eq!(format_rate_short(950, 1.0), "950");
        assert_eq!(format_rate_short(950, 0.0), "-");
    }

    #[test]
    fn grouped_digits() {
        assert_eq!(group_digits(0), "0");
        assert_eq!(group_digits(999), "999");
        assert_eq!(group_digits(1000), "1,000");
        assert_eq!(group_digits(16_476_814), "16,476,814");
        assert_eq!(group_digits(u64::MAX), "18,446,744,073,709,551,615");
    }
}
