//! Where a benchmark ran, for its report: today's date (UTC) and the CPU model and count from
//! `/proc/cpuinfo`. Every benchmark that writes a report takes them from here.

use std::num::NonZeroUsize;
use std::time::{SystemTime, UNIX_EPOCH};

/// The date `days` days after 1970-01-01, as `YYYY-MM-DD` (Howard Hinnant's `civil_from_days`).
pub fn civil_date(days: i64) -> String {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}")
}

/// Today's date in UTC.
pub fn today() -> String {
    let secs = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    civil_date(i64::try_from(secs / 86_400).unwrap_or(0))
}

/// The CPU model and the logical CPUs `cpuinfo` (the text of `/proc/cpuinfo`) lists.
pub fn cpu_from(cpuinfo: &str) -> (Option<String>, usize) {
    let field = |line: &str, key: &str| -> Option<String> {
        let (k, v) = line.split_once(':')?;
        (k.trim() == key).then(|| v.trim().to_string())
    };
    let model = cpuinfo.lines().find_map(|l| field(l, "model name"));
    let count = cpuinfo
        .lines()
        .filter(|l| field(l, "processor").is_some())
        .count();
    (model, count)
}

/// This machine in words: `AMD EPYC 7B13, 2 logical CPUs` (and how many this process may use
/// when that is fewer).
pub fn machine() -> String {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let (model, listed) = cpu_from(&cpuinfo);
    let usable = std::thread::available_parallelism().map_or(1, NonZeroUsize::get);
    let model = model.unwrap_or_else(|| "unknown CPU".to_string());
    let listed = if listed == 0 { usable } else { listed };
    let plural = |n: usize| if n == 1 { "" } else { "s" };
    if usable < listed {
        format!(
            "{model}, {listed} logical CPU{} ({usable} usable by this process)",
            plural(listed)
        )
    } else {
        format!("{model}, {listed} logical CPU{}", plural(listed))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates() {
        assert_eq!(civil_date(0), "1970-01-01");
        assert_eq!(civil_date(11_016), "2000-02-29");
        assert_eq!(civil_date(19_783), "2024-03-01");
        assert_eq!(civil_date(-1), "1969-12-31");
    }

    #[test]
    fn cpu_model_and_count() {
        let info = "processor\t: 0\nmodel name\t: AMD EPYC 7B13\n\nprocessor\t: 1\n\
                    model name\t: AMD EPYC 7B13\n";
        assert_eq!(cpu_from(info), (Some("AMD EPYC 7B13".to_string()), 2));
        assert_eq!(cpu_from(""), (None, 0));
    }
}
