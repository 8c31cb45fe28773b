//! The conclusion that ends each knob's paragraph, computed from the measured rows: which
//! differences the reference resolves (its residual), and what to pick and why.

use super::format::{fmt_ratio, fmt_ssim, join_values, sig3};
use super::metrics::{rmse, through_8_bits, to_colors, Colors};
use super::wire::WireBytes;
use super::{Errors, Knob, Row, SceneRun};
use std::fmt::Write as _;

/// One setting of a knob as the conclusions see it.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Point {
    /// The setting as the text names it (`4`, `10 %`, `0.1`).
    pub(super) label: String,
    /// Its value (samples per side, threshold, cut-off, depth cap, level, bits).
    pub(super) num: f64,
    /// Median time against the baseline's.
    pub(super) ratio: f64,
    /// Rays of one render.
    pub(super) rays: u64,
    pub(super) rmse: f64,
    pub(super) ssim: f64,
}

/// The settings of one comparison, and what tells them apart.
pub(super) struct Sweep {
    pub(super) points: Vec<Point>,
    /// `dist[i][j]`: RMSE between the images of points `i` and `j`.
    pub(super) dist: Vec<Vec<f64>>,
    /// The residual of the reference they are compared with.
    pub(super) residual: f64,
    /// `1 −` the residual render's SSIM against that reference: SSIM differences up to this
    /// are not taken as resolved.
    pub(super) ssim_tol: f64,
}

impl Sweep {
    /// Whether the reference tells which of points `i` and `j` is closer to the truth. With the
    /// reference `F = T + ε`, `‖A − T‖² − ‖B − T‖² = ‖A − F‖² − ‖B − F‖² + 2⟨A − B, ε⟩` and
    /// `|⟨A − B, ε⟩| ≤ d·‖ε‖` (Cauchy–Schwarz, all per channel), so the measured squared RMSEs
    /// give the true order when they differ by more than `2·d·residual`, `d` being the RMSE
    /// between the two images and the residual the bound on `‖ε‖`. Identical images are never
    /// told apart.
    fn resolved(&self, i: usize, j: usize) -> bool {
        let (a, b) = (self.points[i].rmse, self.points[j].rmse);
        (a * a - b * b).abs() > 2.0 * self.dist[i][j] * self.residual
    }

    /// Whether point `i` is closer to the truth than `j` by a margin the reference resolves.
    fn beats(&self, i: usize, j: usize) -> bool {
        self.points[i].rmse < self.points[j].rmse && self.resolved(i, j)
    }

    /// Of `among`, the cheapest (fewest rays; of equal rays the first) that none of `among`
    /// beats.
    fn cheapest_unbeaten(&self, among: &[usize]) -> Option<usize> {
        among
            .iter()
            .copied()
            .filter(|&i| !among.iter().any(|&j| self.beats(j, i)))
            .min_by_key(|&i| (self.points[i].rays, i))
    }

    /// The first position in `order` (not the last) from which no two of the points that follow
    /// are told apart; `None` if even the last two are.
    fn settled_from(&self, order: &[usize]) -> Option<usize> {
        let mut found = None;
        for start in (0..order.len().saturating_sub(1)).rev() {
            let a = order[start];
            if order[start + 1..].iter().any(|&b| self.resolved(a, b)) {
                break;
            }
            found = Some(start);
        }
        found
    }
}

/// `part` of `whole` as a whole percentage (`0` for an empty whole).
pub(super) fn share(part: f64, whole: f64) -> f64 {
    if whole > 0.0 {
        100.0 * part / whole
    } else {
        0.0
    }
}

/// `more` rays against `base` rays: `12 % more rays`, `3 % fewer rays`, `the same rays`.
pub(super) fn rays_change(base: u64, more: u64) -> String {
    if base == more || base == 0 {
        return "the same rays".to_string();
    }
    let d = share(more as f64 - base as f64, base as f64);
    if d >= 0.0 {
        format!("{:.0} % more rays", d.max(1.0))
    } else {
        format!("{:.0} % fewer rays", (-d).max(1.0))
    }
}

/// The multisample paragraph's resolution sentence and conclusion; `p` in increasing samples,
/// the first multisample 1. `other` names the baseline's other differences from the reference
/// (cut-off, depth cap) when they can matter.
pub(super) fn multisample_conclusion(sw: &Sweep, other: Option<&str>) -> String {
    let p = &sw.points;
    let n = p.len();
    if n < 2 {
        return String::new();
    }
    let mut s = multisample_resolution(sw);
    let order: Vec<usize> = (0..n).collect();
    let settled = sw.settled_from(&order);
    let last = n - 1;
    if settled == Some(0) {
        let _ = write!(
            s,
            " Conclusion: this reference cannot tell multisample {} from {} (RMSE {} against {}): \
             more samples buy nothing measurable here, so multisample {} is enough.",
            p[0].label,
            p[last].label,
            sig3(p[0].rmse),
            sig3(p[last].rmse),
            p[0].label
        );
        return s;
    }
    if let Some(i) = settled {
        let _ = write!(
            s,
            " From multisample {} on (RMSE {} to {}) no two settings are told apart: whether more \
             than {} samples per side help is below what this reference resolves.",
            p[i].label,
            sig3(p[i..].iter().map(|q| q.rmse).fold(0.0, f64::max)),
            sig3(p[i..].iter().map(|q| q.rmse).fold(f64::INFINITY, f64::min)),
            p[i].label
        );
    }
    let drop = p[0].rmse - p[last].rmse;
    if drop <= 0.0 {
        let _ = write!(
            s,
            " Conclusion: more samples did not lower the RMSE here; multisample {} is enough.",
            p[0].label
        );
        return s;
    }
    s.push_str(&multisample_pick(sw, settled, drop));
    s.push_str(&multisample_leftover(sw, other));
    s
}

/// The residual and the multisample steps it does not resolve.
fn multisample_resolution(sw: &Sweep) -> String {
    let p = &sw.points;
    let n = p.len();
    let mut s = String::new();
    let unresolved: Vec<String> = (0..n - 1)
        .filter(|&i| !sw.resolved(i, i + 1))
        .map(|i| format!("{} → {}", p[i].label, p[i + 1].label))
        .collect();
    let _ = write!(
        s,
        " The reference's residual is {} (RMSE); a step is resolved only when the residual \
         cannot explain the change of RMSE.",
        sig3(sw.residual)
    );
    if unresolved.is_empty() {
        let _ = write!(s, " Every step here is resolved.");
    } else {
        let _ = write!(
            s,
            " Not resolved: multisample {}.",
            join_values(&unresolved)
        );
    }
    s
}

/// Which multisample to pick when quality matters: the knee (90 % of the RMSE reduction `drop`),
/// no later than where the reference stops resolving (`settled`).
fn multisample_pick(sw: &Sweep, settled: Option<usize>, drop: f64) -> String {
    let p = &sw.points;
    let n = p.len();
    let last = n - 1;
    let mut s = String::new();
    let knee = (1..n)
        .find(|&i| p[0].rmse - p[i].rmse >= 0.9 * drop)
        .unwrap_or(last);
    let pick = settled.map_or(knee, |i| knee.min(i.max(1)));
    if pick == last {
        let _ = write!(
            s,
            " Conclusion: pick multisample {} (the most measured, {} the baseline time) when \
             quality matters: every step up to it lowers the RMSE by a margin the reference \
             resolves, and the last step, from multisample {}, still removes {:.0} % of the \
             whole reduction from multisample {}.",
            p[last].label,
            fmt_ratio(p[last].ratio),
            p[last - 1].label,
            share(p[last - 1].rmse - p[last].rmse, drop).max(0.0),
            p[0].label
        );
    } else {
        let _ = write!(
            s,
            " Conclusion: pick multisample {} when quality matters: it buys {:.0} % of the RMSE \
             reduction that multisample {} buys at {} the baseline time; the rest costs {} as \
             much time again ({} the baseline time){}.",
            p[pick].label,
            share(p[0].rmse - p[pick].rmse, drop),
            p[last].label,
            fmt_ratio(p[pick].ratio),
            fmt_ratio(p[last].ratio / p[pick].ratio.max(1e-12)),
            fmt_ratio(p[last].ratio),
            if settled.is_some_and(|i| i <= pick) {
                " and is not resolved by this reference"
            } else {
                ""
            }
        );
    }
    s
}

/// What is left at the most samples when it is more than the residual explains.
fn multisample_leftover(sw: &Sweep, other: Option<&str>) -> String {
    let p = &sw.points;
    let last = p.len() - 1;
    let mut s = String::new();
    if p[last].rmse > 2.0 * sw.residual {
        match other {
            Some(o) => {
                let _ = write!(
                    s,
                    " What is left at multisample {} (RMSE {}) is more than the reference's \
                     residual explains (more than twice it); the baseline also differs from the reference in {o}, \
                     and more samples cannot remove that part.",
                    p[last].label,
                    sig3(p[last].rmse)
                );
            }
            None => {
                let _ = write!(
                    s,
                    " Multisample {} is still more than twice the reference's residual from it \
                     (RMSE {}): more samples would still help.",
                    p[last].label,
                    sig3(p[last].rmse)
                );
            }
        }
    }
    s
}

/// The adaptive paragraph's conclusion: point 0 is full multisample 4, `thresholds` the
/// adaptive points, `multisample` the plain multisample points.
pub(super) fn adaptive_conclusion(
    sw: &Sweep,
    thresholds: std::ops::Range<usize>,
    multisample: std::ops::Range<usize>,
) -> String {
    let p = &sw.points;
    let Some(full) = p.first() else {
        return String::new();
    };
    let matching: Vec<usize> = thresholds
        .clone()
        .filter(|&i| p[i].rmse <= full.rmse * 1.1 || !sw.beats(0, i))
        .collect();
    let pct = |i: usize| share(p[i].ratio, full.ratio);
    let close = matching
        .iter()
        .copied()
        .min_by(|&a, &b| p[a].ratio.total_cmp(&p[b].ratio).then(a.cmp(&b)));
    let mut s = String::new();
    match close {
        Some(c) => {
            let _ = write!(
                s,
                " Conclusion: use threshold {} rather than full multisampling: its RMSE ({}) is \
                 {} full multisample 4's ({}) at {:.0} % of its time.",
                p[c].label,
                sig3(p[c].rmse),
                if sw.beats(0, c) {
                    "within 10 % of"
                } else {
                    "not told apart from"
                },
                sig3(full.rmse),
                pct(c)
            );
            let same_time = multisample
                .filter(|&m| p[m].ratio <= p[c].ratio * 1.05)
                .max_by(|&a, &b| p[a].ratio.total_cmp(&p[b].ratio));
            if let Some(m) = same_time.filter(|&m| sw.beats(c, m)) {
                let _ = write!(
                    s,
                    " In that time plain multisampling gets no further than multisample {} ({}, \
                     RMSE {}).",
                    p[m].label,
                    fmt_ratio(p[m].ratio),
                    sig3(p[m].rmse)
                );
            }
        }
        None => {
            let best = thresholds.min_by(|&a, &b| p[a].rmse.total_cmp(&p[b].rmse));
            if let Some(b) = best {
                let _ = write!(
                    s,
                    " Conclusion: no threshold matched full multisample 4 here (RMSE {}); the \
                     closest, {}, has RMSE {} at {:.0} % of its time. A refined pixel is exactly \
                     full multisample 4's, so the difference lies in pixels whose centre matched \
                     its neighbours' and kept one ray: where that matters, use full \
                     multisampling or a lower threshold.",
                    sig3(full.rmse),
                    p[b].label,
                    sig3(p[b].rmse),
                    pct(b)
                );
            }
        }
    }
    s
}

/// The reflection cut-off's conclusion: `own` is the scene's own cut-off's point, `aliasing`
/// the RMSE that multisample 2 removes from the baseline (when measured).
pub(super) fn cutoff_conclusion(
    sw: &Sweep,
    own: Option<usize>,
    aliasing: Option<f64>,
    same: bool,
) -> String {
    let p = &sw.points;
    let all: Vec<usize> = (0..p.len()).collect();
    let Some(pick) = sw.cheapest_unbeaten(&all) else {
        return String::new();
    };
    let own_label = own.map_or_else(String::new, |o| p[o].label.clone());
    if same {
        let most = all
            .iter()
            .copied()
            .max_by_key(|&i| p[i].rays)
            .unwrap_or(pick);
        return format!(
            " Conclusion: keep the scene's {own_label}: lower cut-offs buy nothing here{}.",
            if p[most].rays > p[pick].rays {
                format!(
                    ", and cut-off {} traces {} for the same pixels",
                    p[most].label,
                    rays_change(p[pick].rays, p[most].rays)
                )
            } else {
                String::new()
            }
        );
    }
    let mut s = format!(
        " Conclusion: for accuracy, pick cut-off {}, the cheapest setting that no other beats \
         by a margin the reference resolves (RMSE {}).",
        p[pick].label,
        sig3(p[pick].rmse)
    );
    if let Some(o) = own {
        if o == pick {
            s.push_str(" That is the scene's own.");
        } else if sw.beats(pick, o) {
            let gain = p[o].rmse - p[pick].rmse;
            let _ = write!(
                s,
                " The scene's {} falls short: {} lowers RMSE from {} to {} for {} ({} the \
                 baseline time against {}).",
                p[o].label,
                p[pick].label,
                sig3(p[o].rmse),
                sig3(p[pick].rmse),
                rays_change(p[o].rays, p[pick].rays),
                fmt_ratio(p[pick].ratio),
                fmt_ratio(p[o].ratio)
            );
            if let Some(a) = aliasing.filter(|&a| a > gain) {
                let _ = write!(
                    s,
                    " That gain is {:.0} times smaller than what multisample 2 removes ({}); but \
                     the cut-off's error is a bias that multisampling does not remove, so it \
                     matters most in multisampled images.",
                    a / gain.max(1e-12),
                    sig3(a)
                );
            }
        } else {
            let _ = write!(
                s,
                " The scene's {} is as good by what the reference resolves, with {}.",
                p[o].label,
                rays_change(p[pick].rays, p[o].rays)
            );
        }
    }
    s
}

/// The depth cap's conclusion; `p` in increasing caps, `own` the scene's cap's point.
pub(super) fn depth_conclusion(sw: &Sweep, own: Option<usize>, same: bool) -> String {
    let p = &sw.points;
    let all: Vec<usize> = (0..p.len()).collect();
    let Some(pick) = sw.cheapest_unbeaten(&all) else {
        return String::new();
    };
    if same {
        return format!(
            " Conclusion: no path here needs more than {} bounce{} (every cap gave the same \
             image), so the cap buys nothing; any value will do.",
            p[0].label,
            if p[0].num == 1.0 { "" } else { "s" }
        );
    }
    let mut s = format!(
        " Conclusion: a depth cap of {} is enough: no deeper cap beats it by a margin the \
         reference resolves (RMSE {}).",
        p[pick].label,
        sig3(p[pick].rmse)
    );
    if let Some(o) = own {
        if o == pick {
            s.push_str(" That is the scene's own.");
        } else if sw.beats(pick, o) {
            let _ = write!(
                s,
                " The scene's own cap, {}, is too low: RMSE {} against {}.",
                p[o].label,
                sig3(p[o].rmse),
                sig3(p[pick].rmse)
            );
        } else {
            let _ = write!(
                s,
                " The scene's own cap, {}, is more than enough ({}).",
                p[o].label,
                rays_change(p[pick].rays, p[o].rays)
            );
        }
    }
    if pick > 0 && sw.beats(pick, 0) {
        let _ = write!(
            s,
            " Lower caps cut paths short: cap {} has RMSE {} (SSIM {}) for {}.",
            p[0].label,
            sig3(p[0].rmse),
            fmt_ssim(p[0].ssim),
            rays_change(p[pick].rays, p[0].rays)
        );
    }
    s
}

/// The ambient-occlusion conclusion: the points' `num` is the level (0 is off); `own` is the
/// scene's level; `reference` names what they are compared with.
pub(super) fn occlusion_conclusion(sw: &Sweep, own: u32, reference: &str) -> String {
    let p = &sw.points;
    let Some(off) = p.iter().position(|q| q.num == 0.0) else {
        return String::new();
    };
    let levels: Vec<usize> = (0..p.len()).filter(|&i| i != off).collect();
    let worse_ssim = |i: usize| p[i].ssim < p[off].ssim - sw.ssim_tol;
    let worse: Vec<usize> = levels
        .iter()
        .copied()
        .filter(|&i| worse_ssim(i) || sw.beats(off, i))
        .collect();
    let mut s = worse_than_off(sw, off, &worse, reference);
    let beats_off: Vec<usize> = levels
        .iter()
        .copied()
        .filter(|&i| sw.beats(i, off) && !worse_ssim(i))
        .collect();
    s.push_str(&unresolved_levels(sw, off, &levels));
    let candidates: Vec<usize> = (0..p.len()).filter(|i| !worse.contains(i)).collect();
    let pick = sw.cheapest_unbeaten(&candidates).unwrap_or(off);
    if pick == off {
        let _ = write!(
            s,
            " Conclusion: at multisample 1 no level measured here beats leaving occlusion off by \
             a margin the reference resolves{}: leave it off, or pair it with multisampling, which \
             averages the occlusion rays of a pixel's samples (not measured here).",
            if beats_off.is_empty() {
                String::new()
            } else {
                " on both RMSE and SSIM".to_string()
            }
        );
    } else {
        let _ = write!(
            s,
            " Conclusion: pick level {} ({} the baseline time): the cheapest level that scores no \
             worse than off and that no other level beats by a margin the reference resolves \
             (RMSE {}, SSIM {}, against off's {} and {}).",
            p[pick].label,
            fmt_ratio(p[pick].ratio),
            sig3(p[pick].rmse),
            fmt_ssim(p[pick].ssim),
            sig3(p[off].rmse),
            fmt_ssim(p[off].ssim)
        );
        if let Some(&first) = beats_off.first().filter(|&&f| f != pick) {
            let _ = write!(
                s,
                " Level {} is the first to beat off on both RMSE and SSIM.",
                p[first].label
            );
        }
    }
    if own > 0 {
        if let Some(o) = p.iter().position(|q| q.num == f64::from(own)) {
            if o != pick {
                let _ = write!(
                    s,
                    " The scene's own level {} {}.",
                    p[o].label,
                    if sw.beats(pick, o) || worse.contains(&o) {
                        "does worse".to_string()
                    } else {
                        format!(
                            "is as good by what the reference resolves, at {}",
                            fmt_ratio(p[o].ratio)
                        )
                    }
                );
            }
        }
    }
    s
}

/// Why the levels in `worse` do worse than occlusion off (point `off`): too few rays make
/// noise; empty when none does.
fn worse_than_off(sw: &Sweep, off: usize, worse: &[usize], reference: &str) -> String {
    let p = &sw.points;
    let mut s = String::new();
    if worse.is_empty() {
        return s;
    }
    let items: Vec<String> = worse
        .iter()
        .map(|&i| {
            if p[i].rmse >= p[off].rmse {
                format!(
                    "level {} (SSIM {} against {}, RMSE {} against {})",
                    p[i].label,
                    fmt_ssim(p[i].ssim),
                    fmt_ssim(p[off].ssim),
                    sig3(p[i].rmse),
                    sig3(p[off].rmse)
                )
            } else {
                format!(
                    "level {} in SSIM ({} against {}), though its RMSE is lower ({} against \
                     {})",
                    p[i].label,
                    fmt_ssim(p[i].ssim),
                    fmt_ssim(p[off].ssim),
                    sig3(p[i].rmse),
                    sig3(p[off].rmse)
                )
            }
        })
        .collect();
    let rays: Vec<String> = worse
        .iter()
        .map(|&i| {
            let n = (p[i].num * p[i].num) as u32;
            format!(
                "{n} ray{} at level {}",
                if n == 1 { "" } else { "s" },
                p[i].label
            )
        })
        .collect();
    let _ = write!(
        s,
        " Worse than off: {}. With so few occlusion rays per shaded point ({}) the share that \
         escapes is coarse{}, so the ambient term turns into noise from pixel to pixel; at \
         multisample 1 nothing averages it, and the {reference} it is compared with is \
         smooth. That noise costs more than the occlusion it adds, and SSIM, which weighs \
         local structure, shows it most.",
        items.join("; "),
        join_values(&rays),
        if worse.iter().any(|&i| p[i].num == 1.0) {
            " (with one ray, 0 or 1)"
        } else {
            ""
        }
    );
    s
}

/// The levels that score better than off (point `off`) on both RMSE and SSIM by less than the
/// reference resolves; empty when there are none.
fn unresolved_levels(sw: &Sweep, off: usize, levels: &[usize]) -> String {
    let p = &sw.points;
    let mut s = String::new();
    let unresolved: Vec<usize> = levels
        .iter()
        .copied()
        .filter(|&i| p[i].rmse < p[off].rmse && p[i].ssim > p[off].ssim && !sw.beats(i, off))
        .collect();
    if !unresolved.is_empty() {
        let labels: Vec<String> = unresolved.iter().map(|&i| p[i].label.clone()).collect();
        let _ = write!(
            s,
            " Level{} {} score{} better than off in both RMSE and SSIM, but by less than that \
             reference resolves (its residual is {}): a sharper reference would be needed to \
             tell.",
            if unresolved.len() == 1 { "" } else { "s" },
            join_values(&labels),
            if unresolved.len() == 1 { "s" } else { "" },
            sig3(sw.residual)
        );
    }
    s
}

/// The octree's conclusion: `times` are `(label, time against the default octree's)`, `noise`
/// the run's timing noise (a fraction).
pub(super) fn octree_conclusion(times: &[(String, f64)], noise: Option<f64>) -> String {
    let Some((fast, f)) = times.iter().min_by(|a, b| a.1.total_cmp(&b.1)) else {
        return String::new();
    };
    let Some((slow, sl)) = times.iter().max_by(|a, b| a.1.total_cmp(&b.1)) else {
        return String::new();
    };
    let noise_text = noise.map_or_else(
        || "this run has no estimate of its timing noise".to_string(),
        |n| format!("the timing noise of this run is up to {:.0} %", n * 100.0),
    );
    let spread = sl / f.max(1e-12) - 1.0;
    // The default octree is the baseline: ratio 1.
    let gain = 1.0 / f.max(1e-12) - 1.0;
    format!(
        " Conclusion: the octree settings change only the time. The fastest here was {fast} \
         ({}), the slowest {slow} ({}), a spread of {:.0} %; {noise_text}, so {}.",
        fmt_ratio(*f),
        fmt_ratio(*sl),
        spread * 100.0,
        if *f >= 1.0 {
            "no setting beat the default: keep it".to_string()
        } else if noise.is_some_and(|n| gain <= n) {
            format!(
                "the fastest gains {:.0} % on the default, within the noise: keep the default",
                gain * 100.0
            )
        } else if noise.is_none() {
            format!(
                "the fastest gains {:.0} % on the default, which this run cannot tell from \
                 noise: keep the default unless a repeat run confirms it",
                gain * 100.0
            )
        } else {
            format!(
                "the fastest gains {:.0} % on the default, more than the noise: it may be worth \
                 a try on scenes like this one; the default is never wrong, only slower",
                gain * 100.0
            )
        }
    )
}

/// The pixel precision's conclusion: point 0 is the baseline with 16-bit pixels, point 1 with
/// 8-bit ones; `quantization` the RMSE between the two; `closest` the label and RMSE of the
/// scene's render closest to the reference.
pub(super) fn precision_conclusion(
    sw: &Sweep,
    quantization: f64,
    closest: Option<(&str, f64)>,
    wire: &WireBytes,
) -> String {
    let p = &sw.points;
    if p.len() < 2 {
        return String::new();
    }
    let mut s = format!(
        " Conclusion: 8-bit pixels would save {:.0} % of the line-result bytes for RMSE {} \
         against the 16-bit pixels; against the reference they move the baseline's SSIM from {} \
         to {}",
        wire.saving() * 100.0,
        sig3(quantization),
        fmt_ssim(p[0].ssim),
        fmt_ssim(p[1].ssim)
    );
    s.push_str(if sw.resolved(0, 1) {
        " and its RMSE by a margin the reference resolves."
    } else {
        " and its RMSE by less than the reference resolves."
    });
    if let Some((label, best)) = closest.filter(|c| c.1 > 0.0) {
        let k = best / quantization.max(1e-12);
        // Quantisation adds about independently of the render's own error.
        let with8 = best.hypot(quantization);
        let more = share(with8 - best, best);
        if k >= 3.0 {
            let _ = write!(
                s,
                " Even the closest render here, {label} at RMSE {}, is {k:.0} times further from \
                 the reference than 8 bits move a pixel: 8 bits would raise its RMSE only to \
                 about {} (+{more:.0} %, adding independently), so at these settings they would \
                 cost nothing that matters and save {:.0} % of the traffic, which counts on slow \
                 links such as serial lines; 16 bits matter once a render's own error nears the \
                 8-bit step.",
                sig3(best),
                sig3(with8),
                wire.saving() * 100.0
            );
        } else {
            let _ = write!(
                s,
                " The closest render here, {label} at RMSE {}, is only {k:.1} times the 8-bit \
                 error: 8 bits would raise its RMSE to about {} (+{more:.0} %, adding \
                 independently), so keep 16-bit pixels for such renders unless the link is the \
                 bottleneck{}.",
                sig3(best),
                sig3(with8),
                if sw.resolved(0, 1) {
                    ""
                } else {
                    "; for renders as rough as the baseline, where the change is not resolved, \
                     8 bits would do"
                }
            );
        }
    }
    s
}

/// The colours a row is measured by: its render's, through 8 bits for an 8-bit row.
pub(super) fn row_colors(r: &Row, sc: &SceneRun) -> Colors {
    let m = &sc.measured[r.measured];
    if r.eight_bit {
        to_colors(&through_8_bits(&m.pixels))
    } else {
        m.colors.clone()
    }
}

/// The rows as a [`Sweep`], compared with `residual`.
pub(super) fn sweep_of(rs: &[&Row], sc: &SceneRun) -> Sweep {
    let residual = rs
        .first()
        .and_then(|r| sc.residual_errors(r.reference))
        .unwrap_or(Errors {
            rmse: 0.0,
            psnr: f64::INFINITY,
            ssim: 1.0,
        });
    let colors: Vec<Colors> = rs.iter().map(|r| row_colors(r, sc)).collect();
    let n = rs.len();
    let mut dist = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in i + 1..n {
            let same = rs[i].measured == rs[j].measured && rs[i].eight_bit == rs[j].eight_bit;
            let d = if same {
                0.0
            } else {
                rmse(&colors[i], &colors[j])
            };
            dist[i][j] = d;
            dist[j][i] = d;
        }
    }
    let points = rs
        .iter()
        .map(|r| {
            let num = r.setting.num();
            Point {
                label: match r.knob {
                    Knob::Multisample | Knob::Occlusion | Knob::Depth => format!("{num}"),
                    _ => r.value.clone(),
                },
                num,
                ratio: r.ratio,
                rays: sc.measured[r.measured].rays.total(),
                rmse: r.errors.rmse,
                ssim: r.errors.ssim,
            }
        })
        .collect();
    Sweep {
        points,
        dist,
        residual: residual.rmse,
        ssim_tol: (1.0 - residual.ssim).max(0.0),
    }
}

/// Whether every row gave the same image.
pub(super) fn all_same(rs: &[&Row], sc: &SceneRun) -> bool {
    rs.windows(2)
        .all(|w| sc.measured[w[0].measured].image == sc.measured[w[1].measured].image)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pt(label: &str, num: f64, ratio: f64, rays: u64, rmse: f64, ssim: f64) -> Point {
        Point {
            label: label.to_string(),
            num,
            ratio,
            rays,
            rmse,
            ssim,
        }
    }

    /// A sweep whose images differ as independent errors would: `d = √(a² + b²)`.
    fn independent(points: Vec<Point>, residual: f64) -> Sweep {
        let dist = points
            .iter()
            .map(|a| {
                points
                    .iter()
                    .map(|b| if a == b { 0.0 } else { a.rmse.hypot(b.rmse) })
                    .collect()
            })
            .collect();
        Sweep {
            points,
            dist,
            residual,
            ssim_tol: 0.0,
        }
    }

    #[test]
    fn resolution_follows_the_residual() {
        // Two settings 0.01 and 0.009 with independent errors (d ≈ 0.0135): resolved when
        // 0.01² − 0.009² = 1.9e-5 > 2·d·residual, i.e. residual < about 0.0007.
        let pts = vec![
            pt("a", 1.0, 1.0, 10, 0.010, 0.9),
            pt("b", 2.0, 2.0, 20, 0.009, 0.9),
        ];
        assert!(independent(pts.clone(), 0.0005).resolved(0, 1));
        assert!(!independent(pts.clone(), 0.001).resolved(0, 1));
        // Close images (small d) are told apart by smaller differences.
        let mut close = independent(pts, 0.001);
        close.dist[0][1] = 0.002;
        close.dist[1][0] = 0.002;
        assert!(close.resolved(0, 1));
        assert!(close.beats(1, 0) && !close.beats(0, 1));
        // Identical images are never told apart, even with a zero residual.
        let same = independent(
            vec![
                pt("a", 1.0, 1.0, 1, 0.01, 1.0),
                pt("a", 1.0, 1.0, 1, 0.01, 1.0),
            ],
            0.0,
        );
        assert!(!same.resolved(0, 1));
    }

    #[test]
    fn cheapest_unbeaten_and_settled() {
        let sw = independent(
            vec![
                pt("1", 1.0, 1.0, 100, 0.0500, 0.9),
                pt("2", 2.0, 2.0, 200, 0.0200, 0.9),
                pt("3", 3.0, 3.0, 300, 0.0102, 0.9),
                pt("4", 4.0, 4.0, 400, 0.0100, 0.9),
            ],
            0.001,
        );
        // 3 and 4 are not told apart; 2 is beaten.
        assert_eq!(sw.cheapest_unbeaten(&[0, 1, 2, 3]), Some(2));
        assert_eq!(sw.settled_from(&[0, 1, 2, 3]), Some(2));
        let exact = independent(sw.points.clone(), 0.0);
        assert_eq!(exact.settled_from(&[0, 1, 2, 3]), None);
        assert_eq!(exact.cheapest_unbeaten(&[0, 1, 2, 3]), Some(3));
    }

    #[test]
    fn multisample_conclusion_names_what_is_not_resolved() {
        let pts = vec![
            pt("1", 1.0, 1.0, 100, 0.0138, 0.989),
            pt("2", 2.0, 3.0, 400, 0.0064, 0.997),
            pt("4", 4.0, 11.0, 1600, 0.0026, 0.9995),
            pt("6", 6.0, 26.0, 3600, 0.0015, 0.9998),
            pt("8", 8.0, 46.0, 6400, 0.0011, 0.9999),
        ];
        let text = multisample_conclusion(&independent(pts.clone(), 0.0009), None);
        assert!(
            text.contains("Not resolved: multisample 4 → 6 and 6 → 8."),
            "{text}"
        );
        // 4 and 8 are told apart, 6 and 8 are not.
        assert!(text.contains("From multisample 6 on"), "{text}");
        assert!(
            text.contains("Conclusion: pick multisample 6 when quality matters"),
            "{text}"
        );
        assert!(text.contains("is not resolved by this reference"), "{text}");
        assert!(!text.contains("more samples would still help"), "{text}");
        // With an exact reference every step counts and the last one still has error left.
        let text = multisample_conclusion(&independent(pts.clone(), 0.0), Some("its cut-off"));
        assert!(text.contains("Every step here is resolved."), "{text}");
        assert!(text.contains("Conclusion: pick multisample 6"), "{text}");
        assert!(!text.contains("not resolved by this reference"), "{text}");
        assert!(
            text.contains("differs from the reference in its cut-off"),
            "{text}"
        );
        // A reference too coarse to resolve anything.
        let text = multisample_conclusion(&independent(pts, 0.05), None);
        assert!(text.contains("cannot tell multisample 1 from 8"), "{text}");
        assert!(text.contains("multisample 1 is enough"), "{text}");
    }

    #[test]
    fn occlusion_conclusion_says_when_few_rays_are_worse_than_none() {
        // The last run's room: level 1 worse than off in SSIM and RMSE, level 4 better.
        let pts = vec![
            pt("0", 0.0, 1.0, 85, 0.0170, 0.98468),
            pt("1", 1.0, 1.35, 129, 0.0184, 0.92371),
            pt("2", 2.0, 2.04, 258, 0.0147, 0.97219),
            pt("4", 4.0, 5.0, 776, 0.0137, 0.98648),
        ];
        let text = occlusion_conclusion(&independent(pts.clone(), 0.002), 0, "level-9 reference");
        assert!(
            text.contains("Worse than off: level 1 (SSIM 0.92371 against 0.98468"),
            "{text}"
        );
        assert!(
            text.contains("level 2 in SSIM (0.97219 against 0.98468), though its RMSE is lower"),
            "{text}"
        );
        assert!(text.contains("(with one ray, 0 or 1)"), "{text}");
        assert!(text.contains("Conclusion: pick level 4"), "{text}");
        // When no level beats off by a resolved margin, the advice is to leave it off, and a
        // level better on both counts is named as not resolved.
        let text = occlusion_conclusion(&independent(pts, 0.02), 0, "level-9 reference");
        assert!(text.contains("leave it off"), "{text}");
        assert!(
            text.contains("Level 4 scores better than off in both RMSE and SSIM, but by less"),
            "{text}"
        );
        // An SSIM drop within the residual's own SSIM is not "worse".
        let mut sw = independent(
            vec![
                pt("0", 0.0, 1.0, 85, 0.0227, 0.97294),
                pt("2", 2.0, 2.0, 258, 0.0202, 0.97292),
            ],
            0.001,
        );
        sw.ssim_tol = 0.002;
        let text = occlusion_conclusion(&sw, 0, "level-9 reference");
        assert!(!text.contains("Worse than off"), "{text}");
        assert!(text.contains("Conclusion: pick level 2"), "{text}");
        // No level worse than off: no such sentence.
        let text = occlusion_conclusion(
            &independent(
                vec![
                    pt("0", 0.0, 1.0, 85, 0.0170, 0.980),
                    pt("2", 2.0, 2.0, 258, 0.0120, 0.990),
                ],
                0.001,
            ),
            2,
            "level-9 reference",
        );
        assert!(!text.contains("Worse than off"), "{text}");
        assert!(text.contains("Conclusion: pick level 2"), "{text}");
    }

    #[test]
    fn cutoff_and_depth_conclusions_follow_the_numbers() {
        let cut = vec![
            pt("10 %", 0.1, 1.0, 258, 0.0157, 0.9827),
            pt("1 %", 0.01, 1.03, 265, 0.0146, 0.9846),
            pt("0 %", 0.0, 1.03, 268, 0.0146, 0.9846),
        ];
        let mut sw = independent(cut, 0.0009);
        // Cut-off changes are small image changes.
        for (i, j, d) in [(0, 1, 0.004), (0, 2, 0.0041), (1, 2, 0.0002)] {
            sw.dist[i][j] = d;
            sw.dist[j][i] = d;
        }
        let text = cutoff_conclusion(&sw, Some(0), Some(0.0066), false);
        assert!(
            text.contains("Conclusion: for accuracy, pick cut-off 1 %"),
            "{text}"
        );
        assert!(text.contains("The scene's 10 % falls short"), "{text}");
        assert!(
            text.contains("bias that multisampling does not remove"),
            "{text}"
        );
        let same = independent(
            vec![
                pt("10 %", 0.1, 1.0, 98, 0.0133, 0.99),
                pt("0 %", 0.0, 1.0, 98, 0.0133, 0.99),
            ],
            0.001,
        );
        let text = cutoff_conclusion(&same, Some(0), None, true);
        assert!(
            text.contains("keep the scene's 10 %: lower cut-offs buy nothing"),
            "{text}"
        );

        let depth = vec![
            pt("1", 1.0, 0.9, 209, 0.0518, 0.899),
            pt("2", 2.0, 1.0, 241, 0.0257, 0.957),
            pt("4", 4.0, 1.0, 253, 0.0166, 0.978),
            pt("8", 8.0, 1.0, 256, 0.0158, 0.982),
            pt("16", 16.0, 1.0, 258, 0.0157, 0.983),
        ];
        let mut sw = independent(depth, 0.0009);
        for i in 0..5 {
            for j in 0..5 {
                if i != j {
                    sw.dist[i][j] = (sw.points[i].rmse - sw.points[j].rmse).abs() + 0.002;
                }
            }
        }
        let text = depth_conclusion(&sw, Some(1), false);
        assert!(
            text.contains("Conclusion: a depth cap of 8 is enough"),
            "{text}"
        );
        assert!(
            text.contains("The scene's own cap, 2, is too low"),
            "{text}"
        );
        assert!(text.contains("cap 1 has RMSE 0.0518"), "{text}");
        let text = depth_conclusion(&sw, Some(4), false);
        assert!(
            text.contains("The scene's own cap, 16, is more than enough"),
            "{text}"
        );
    }

    #[test]
    fn adaptive_octree_and_precision_conclusions() {
        let pts = vec![
            pt("4", 4.0, 11.5, 1400, 0.00263, 0.9996),
            pt("0.3", 0.3, 2.84, 293, 0.00543, 0.9969),
            pt("0.1", 0.1, 3.02, 322, 0.00273, 0.9994),
            pt("1", 1.0, 1.0, 85, 0.0138, 0.989),
            pt("2", 2.0, 3.01, 341, 0.00636, 0.9973),
        ];
        let text = adaptive_conclusion(&independent(pts.clone(), 0.0009), 1..3, 3..5);
        assert!(
            text.contains("use threshold 0.1 rather than full multisampling"),
            "{text}"
        );
        assert!(
            text.contains("gets no further than multisample 2 (3.01×, RMSE 0.00636)"),
            "{text}"
        );
        let text = adaptive_conclusion(&independent(pts[..2].to_vec(), 0.0), 1..2, 2..2);
        assert!(
            text.contains("no threshold matched full multisample 4"),
            "{text}"
        );

        let times = vec![("depth 8".to_string(), 0.88), ("leaf 8".to_string(), 1.0)];
        assert!(
            octree_conclusion(&times, Some(0.15)).contains("within the noise: keep the default")
        );
        assert!(octree_conclusion(&times, Some(0.05)).contains("more than the noise"));
        let unsure = octree_conclusion(&times, None);
        assert!(
            unsure.contains("no estimate of its timing noise"),
            "{unsure}"
        );
        assert!(
            unsure.contains("cannot tell from noise: keep the default"),
            "{unsure}"
        );
        let slower = vec![("depth 4".to_string(), 1.12), ("leaf 8".to_string(), 1.0)];
        assert!(octree_conclusion(&slower, None).contains("no setting beat the default"));

        let wire = WireBytes {
            width: 240,
            lines: 180,
            image16: 263_000,
            image8: 133_000,
        };
        let mut sw = independent(
            vec![
                pt("16 bit", 16.0, 1.0, 85, 0.0138, 0.98937),
                pt("8 bit", 8.0, 1.0, 85, 0.01385, 0.98888),
            ],
            0.0009,
        );
        sw.dist[0][1] = 0.0011;
        sw.dist[1][0] = 0.0011;
        let text = precision_conclusion(&sw, 0.0011, Some(("multisample 8", 0.0011 * 5.0)), &wire);
        assert!(
            text.contains("save 49 % of the line-result bytes"),
            "{text}"
        );
        assert!(
            text.contains("by less than the reference resolves"),
            "{text}"
        );
        assert!(text.contains("5 times further"), "{text}");
        // √(0.0055² + 0.0011²) = 0.00561: +2 %.
        assert!(text.contains("only to about 0.00561 (+2 %"), "{text}");
        let text = precision_conclusion(&sw, 0.0011, Some(("multisample 8", 0.002)), &wire);
        assert!(text.contains("keep 16-bit pixels"), "{text}");
        assert!(text.contains("as rough as the baseline"), "{text}");
    }
}
