//! Whether this processor runs the tracer as it was built: optimised x86_64 builds compile the
//! core for x86-64-v3 (`pgo/rustc-wrapper`), whose instructions stop an older processor with
//! `Illegal instruction`. This module is compiled for any x86-64, so [`check`] can say so first
//! (`pgo/check.sh` runs the release build on an emulated older processor to see it).

use anyhow::bail;
use strahl_core::X86_FEATURES;

/// Fails, naming what is missing and how to build for this machine, if the core was compiled
/// for an x86 extension this processor lacks.
///
/// # Errors
/// The missing extensions and the build command that needs none.
pub fn check() -> anyhow::Result<()> {
    let missing = missing(&X86_FEATURES, detected);
    if missing.is_empty() {
        return Ok(());
    }
    bail!(
        "this strahl's tracer was built for x86-64-v3, and this processor lacks {}; build it for \
         any x86-64 processor with `STRAHL_CPU=x86-64 cargo build --release -p strahl-host` \
         (README, \"Building for older x86 processors\")",
        missing.join(", ")
    )
}

/// The extensions `required` says the build uses and `has` says the processor lacks.
fn missing<'a>(required: &[(&'a str, bool)], has: impl Fn(&str) -> bool) -> Vec<&'a str> {
    required
        .iter()
        .filter(|&&(name, used)| used && !has(name))
        .map(|&(name, _)| name)
        .collect()
}

/// Whether this processor has the x86 extension `name` (one of [`X86_FEATURES`]).
#[cfg(target_arch = "x86_64")]
fn detected(name: &str) -> bool {
    match name {
        "avx" => std::arch::is_x86_feature_detected!("avx"),
        "avx2" => std::arch::is_x86_feature_detected!("avx2"),
        "bmi1" => std::arch::is_x86_feature_detected!("bmi1"),
        "bmi2" => std::arch::is_x86_feature_detected!("bmi2"),
        "f16c" => std::arch::is_x86_feature_detected!("f16c"),
        "fma" => std::arch::is_x86_feature_detected!("fma"),
        "lzcnt" => std::arch::is_x86_feature_detected!("lzcnt"),
        "movbe" => std::arch::is_x86_feature_detected!("movbe"),
        _ => false,
    }
}

/// Elsewhere the core is never built for x86 extensions: nothing to detect.
#[cfg(not(target_arch = "x86_64"))]
fn detected(_: &str) -> bool {
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_what_the_build_uses_and_the_processor_lacks_is_missing() {
        let required = [
            ("avx", true),
            ("avx2", true),
            ("fma", false),
            ("bmi2", true),
        ];
        assert_eq!(missing(&required, |n| n == "avx"), ["avx2", "bmi2"]);
        assert!(missing(&required, |_| true).is_empty());
        assert!(missing(&[("avx2", false)], |_| false).is_empty());
    }
}
