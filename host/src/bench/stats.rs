//! Statistics shared by the benchmarks.

use std::time::Duration;

/// The median of `times` (the upper one of an even count); zero for no times, which no
/// benchmark passes (each takes at least one run).
pub(crate) fn median(mut times: Vec<Duration>) -> Duration {
    debug_assert!(!times.is_empty(), "the median of no times");
    times.sort();
    times.get(times.len() / 2).copied().unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even_counts() {
        let ms = |v: &[u64]| {
            v.iter()
                .map(|&m| Duration::from_millis(m))
                .collect::<Vec<_>>()
        };
        assert_eq!(median(ms(&[3, 1, 2])), Duration::from_millis(2));
        assert_eq!(median(ms(&[4, 1, 3, 2])), Duration::from_millis(3));
    }
}
