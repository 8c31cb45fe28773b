//! Statistics shared by the benchmarks.

use std::time::Duration;

/// The median of `times` (the upper one of an even count); zero for no times, which no
/// benchmark passes (each takes at least one run).
pub(crate) fn median(times: Vec<Duration>) -> Duration {
    debug_assert!(!times.is_empty(), "the median of no times");
    median_by(times, Ord::cmp).unwrap_or_default()
}

/// The median of `values` in the order `order` (the upper one of an even count), or `None` for
/// no values: the one rule every benchmark's median follows.
pub(crate) fn median_by<T: Copy>(
    mut values: Vec<T>,
    order: impl FnMut(&T, &T) -> std::cmp::Ordering,
) -> Option<T> {
    values.sort_by(order);
    values.get(values.len() / 2).copied()
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
        assert_eq!(
            median_by(vec![0.4, 0.1, 0.3, 0.2], f64::total_cmp),
            Some(0.3)
        );
        assert_eq!(median_by(Vec::<f64>::new(), f64::total_cmp), None);
    }
}
