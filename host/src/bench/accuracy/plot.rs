//! The SVG plot of error against time, one panel per scene, with the Pareto front marked.
//!
//! Why not the `plotters` crate: plotters could draw these marks (log axes, filled and hollow
//! points, a front), but it lays out its axes by measuring text through a font backend, its
//! `ttf` feature (font-kit, which reads the system's fonts through fontconfig) or `ab_glyph` (a
//! font file the program bundles and registers). This plot writes its text as SVG `<text>` that
//! the viewer lays out, so it needs no font at all, and it is short enough to keep here.

use super::metrics::pareto_front;
use super::Knob;
use std::fmt::Write as _;

/// One point of the plot.
#[derive(Clone, Debug)]
pub struct PlotPoint {
    /// Median time in seconds.
    pub time: f64,
    /// RMSE against the reference (0 is drawn on the strip below the axis).
    pub rmse: f64,
    /// The knob, for its colour.
    pub knob: Knob,
    /// Short label.
    pub label: String,
    /// Compared with the panel's main reference (filled, eligible for the front); hollow points
    /// have a knob-specific reference.
    pub main: bool,
}

/// One panel of the plot: a scene.
#[derive(Clone, Debug)]
pub struct PlotPanel {
    /// The scene's name.
    pub title: String,
    /// Its points.
    pub points: Vec<PlotPoint>,
}

pub(super) fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Tick values `{1, 2, 5} × 10^k` in `[lo, hi]` (only powers of ten over a range of 100× or more).
pub(super) fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return Vec::new();
    }
    let mantissas: &[f64] = if hi / lo >= 100.0 {
        &[1.0]
    } else {
        &[1.0, 2.0, 5.0]
    };
    let mut ticks = Vec::new();
    for k in (lo.log10().floor() as i32)..=(hi.log10().ceil() as i32) {
        for &m in mantissas {
            let v = m * 10f64.powi(k);
            if v >= lo * 0.999_999 && v <= hi * 1.000_001 {
                ticks.push(v);
            }
        }
    }
    ticks
}

/// A tick label: one significant digit, no exponent.
pub(super) fn tick_label(v: f64) -> String {
    let mag = v.log10().floor() as i32;
    let decimals = (-mag).max(0) as usize;
    format!("{v:.decimals$}")
}

/// Width of the picture.
const W: f64 = 820.0;
/// Height of one panel.
const PH: f64 = 440.0;
/// Left edge of the plot area.
const X0: f64 = 80.0;
/// Right edge of the plot area.
const X1: f64 = 600.0;
/// Plot area's top below the panel's top.
const TOP: f64 = 46.0;
/// Height of the plot area.
const PLOT_H: f64 = 300.0;

/// One panel's log-scaled axes: where a time and an RMSE are drawn.
struct Axes {
    /// log10 of the time at the left and right edges.
    lx0: f64,
    lx1: f64,
    /// log10 of the RMSE at the bottom and top edges.
    ly0: f64,
    ly1: f64,
    /// Top and bottom of the plot area.
    y0: f64,
    y1: f64,
    /// The strip below the axis where RMSE 0 is drawn.
    zero_y: f64,
}

impl Axes {
    /// Axes that fit `pts` (at least one), for the panel whose top is at `oy`.
    fn fit(pts: &[&PlotPoint], oy: f64) -> Self {
        let (y0, y1) = (oy + TOP, oy + TOP + PLOT_H);
        let (tmin, tmax) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
            (a.min(p.time), b.max(p.time))
        });
        let positive: Vec<f64> = pts.iter().map(|p| p.rmse).filter(|&e| e > 0.0).collect();
        let (emin, emax) = if positive.is_empty() {
            (1e-4, 1e-1)
        } else {
            positive
                .iter()
                .fold((f64::INFINITY, 0.0f64), |(a, b), &e| (a.min(e), b.max(e)))
        };
        let (lx0, lx1) = ((tmin / 1.25).log10(), (tmax * 1.25).log10());
        let (ly0, ly1) = ((emin / 1.5).log10(), (emax * 1.5).log10());
        Axes {
            lx0,
            lx1: if lx1 - lx0 < 0.3 { lx0 + 0.3 } else { lx1 },
            ly0,
            ly1: if ly1 - ly0 < 0.3 { ly0 + 0.3 } else { ly1 },
            y0,
            y1,
            zero_y: y1 + 22.0,
        }
    }

    fn x(&self, t: f64) -> f64 {
        X0 + (t.log10() - self.lx0) / (self.lx1 - self.lx0) * (X1 - X0)
    }

    fn y(&self, e: f64) -> f64 {
        if e > 0.0 {
            self.y1 - (e.log10() - self.ly0) / (self.ly1 - self.ly0) * PLOT_H
        } else {
            self.zero_y
        }
    }
}

/// The plot as an SVG document: one panel per scene, RMSE (log) against median time (log), the
/// Pareto front of the filled points connected by a line (`class="pareto"`).
pub fn svg(panels: &[PlotPanel]) -> String {
    let height = PH * panels.len().max(1) as f64 + 10.0;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{height}" viewBox="0 0 {W} {height}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(
        s,
        r#"<rect x="0" y="0" width="{W}" height="{height}" fill="white"/>"#
    );
    for (pi, panel) in panels.iter().enumerate() {
        let oy = pi as f64 * PH;
        let _ = writeln!(
            s,
            r#"<text x="{X0}" y="{}" font-size="15" font-weight="bold">{}</text>"#,
            oy + 24.0,
            xml_escape(&panel.title)
        );
        let pts: Vec<&PlotPoint> = panel
            .points
            .iter()
            .filter(|p| p.time > 0.0 && p.time.is_finite() && p.rmse.is_finite())
            .collect();
        if pts.is_empty() {
            let _ = writeln!(
                s,
                r#"<text x="{X0}" y="{}">no points</text>"#,
                oy + TOP + 20.0
            );
            continue;
        }
        let axes = Axes::fit(&pts, oy);
        frame(&mut s, &axes);
        points(&mut s, &axes, &pts);
        front(&mut s, &axes, &pts);
        legend(&mut s, axes.y0, &pts);
    }
    s.push_str("</svg>\n");
    s
}

/// Frame, grid, ticks and axis titles.
fn frame(s: &mut String, axes: &Axes) {
    let Axes { y0, y1, zero_y, .. } = *axes;
    let _ = writeln!(
        s,
        r##"<rect x="{X0}" y="{y0}" width="{}" height="{PLOT_H}" fill="none" stroke="#444"/>"##,
        X1 - X0
    );
    for t in log_ticks(10f64.powf(axes.lx0), 10f64.powf(axes.lx1)) {
        let x = axes.x(t);
        let _ = writeln!(
            s,
            r##"<line x1="{x:.1}" y1="{y0}" x2="{x:.1}" y2="{y1}" stroke="#ddd"/><text x="{x:.1}" y="{}" text-anchor="middle">{}</text>"##,
            zero_y + 20.0,
            tick_label(t)
        );
    }
    for e in log_ticks(10f64.powf(axes.ly0), 10f64.powf(axes.ly1)) {
        let y = axes.y(e);
        let _ = writeln!(
            s,
            r##"<line x1="{X0}" y1="{y:.1}" x2="{X1}" y2="{y:.1}" stroke="#ddd"/><text x="{}" y="{:.1}" text-anchor="end">{}</text>"##,
            X0 - 6.0,
            y + 4.0,
            tick_label(e)
        );
    }
    let _ = writeln!(
        s,
        r##"<line x1="{X0}" y1="{zero_y}" x2="{X1}" y2="{zero_y}" stroke="#bbb" stroke-dasharray="4 3"/><text x="{}" y="{}" text-anchor="end">0</text>"##,
        X0 - 6.0,
        zero_y + 4.0
    );
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">median render time, s (log scale)</text>"#,
        (X0 + X1) / 2.0,
        zero_y + 40.0
    );
    let _ = writeln!(
        s,
        r#"<text transform="translate({},{}) rotate(-90)" text-anchor="middle">RMSE against the reference (log scale)</text>"#,
        X0 - 58.0,
        (y0 + y1) / 2.0
    );
}

/// The points: hollow first, then filled.
fn points(s: &mut String, axes: &Axes, pts: &[&PlotPoint]) {
    for p in pts.iter().filter(|p| !p.main) {
        let _ = writeln!(
            s,
            r#"<circle cx="{:.1}" cy="{:.1}" r="4" fill="white" stroke="{}" stroke-width="1.5"><title>{}</title></circle>"#,
            axes.x(p.time),
            axes.y(p.rmse),
            p.knob.color(),
            xml_escape(&p.label)
        );
    }
    for p in pts.iter().filter(|p| p.main) {
        let _ = writeln!(
            s,
            r#"<circle cx="{:.1}" cy="{:.1}" r="4" fill="{}"><title>{}</title></circle>"#,
            axes.x(p.time),
            axes.y(p.rmse),
            p.knob.color(),
            xml_escape(&p.label)
        );
    }
}

/// The Pareto front of the filled points: a line, a ring on each, and labels where they fit.
fn front(s: &mut String, axes: &Axes, pts: &[&PlotPoint]) {
    let main: Vec<&PlotPoint> = pts.iter().copied().filter(|p| p.main).collect();
    let front = pareto_front(&main.iter().map(|p| (p.time, p.rmse)).collect::<Vec<_>>());
    if front.is_empty() {
        return;
    }
    let line: Vec<String> = front
        .iter()
        .map(|&i| format!("{:.1},{:.1}", axes.x(main[i].time), axes.y(main[i].rmse)))
        .collect();
    let _ = writeln!(
        s,
        r#"<polyline class="pareto" points="{}" fill="none" stroke="black" stroke-width="2"/>"#,
        line.join(" ")
    );
    // Labels go beside their ring where they overlap no other label; else they are left
    // out (the report lists the whole front).
    let mut placed: Vec<(f64, f64, f64, f64)> = Vec::new();
    for &i in &front {
        let (x, y) = (axes.x(main[i].time), axes.y(main[i].rmse));
        let _ = writeln!(
            s,
            r#"<circle cx="{x:.1}" cy="{y:.1}" r="7" fill="none" stroke="black" stroke-width="1.5"/>"#
        );
        let label = &main[i].label;
        if let Some((tx, ty)) = label_spot(&mut placed, x, y, label) {
            let _ = writeln!(
                s,
                r#"<text x="{tx:.1}" y="{ty:.1}" font-size="11">{}</text>"#,
                xml_escape(label)
            );
        }
    }
}

/// Where `label` of the ring at `(x, y)` goes: the first spot beside it inside the panel that
/// overlaps no label `placed` so far (and is then placed), or `None`.
fn label_spot(
    placed: &mut Vec<(f64, f64, f64, f64)>,
    x: f64,
    y: f64,
    label: &str,
) -> Option<(f64, f64)> {
    let w = 6.2 * label.chars().count() as f64;
    let h = 11.0;
    let spots = [
        (x + 8.0, y - 8.0),
        (x + 9.0, y + 16.0),
        (x - 8.0 - w, y - 8.0),
        (x - 9.0 - w, y + 16.0),
    ];
    let free = spots.into_iter().find(|&(tx, ty)| {
        let r = (tx, ty - h, tx + w, ty);
        r.0 >= X0 - 30.0
            && r.2 <= X1 + 14.0
            && !placed
                .iter()
                .any(|p| r.0 < p.2 && p.0 < r.2 && r.1 < p.3 && p.1 < r.3)
    });
    if let Some((tx, ty)) = free {
        placed.push((tx, ty - h, tx + w, ty));
    }
    free
}

/// The legend right of the plot area, from `y0` down: the knobs shown, the front, and a note
/// on hollow points where there are any.
fn legend(s: &mut String, y0: f64, pts: &[&PlotPoint]) {
    let lx = X1 + 22.0;
    let mut ly = y0 + 8.0;
    for k in Knob::ALL {
        if let Some(p) = pts.iter().find(|p| p.knob == k) {
            let fill = if p.main { k.color() } else { "white" };
            let _ = writeln!(
                s,
                r#"<circle cx="{lx}" cy="{ly}" r="4" fill="{fill}" stroke="{}" stroke-width="1.5"/><text x="{}" y="{}">{}</text>"#,
                k.color(),
                lx + 10.0,
                ly + 4.0,
                xml_escape(k.name())
            );
            ly += 18.0;
        }
    }
    let _ = writeln!(
        s,
        r#"<line x1="{}" y1="{ly}" x2="{}" y2="{ly}" stroke="black" stroke-width="2"/><text x="{}" y="{}">Pareto front</text>"#,
        lx - 6.0,
        lx + 6.0,
        lx + 10.0,
        ly + 4.0
    );
    ly += 18.0;
    if pts.iter().any(|p| !p.main) {
        for line in ["hollow: own reference", "(not on the front)"] {
            let _ = writeln!(
                s,
                r##"<text x="{}" y="{}" fill="#555">{line}</text>"##,
                lx - 6.0,
                ly + 4.0
            );
            ly += 16.0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn svg_has_the_front() {
        let p = |time, rmse, main| PlotPoint {
            time,
            rmse,
            knob: Knob::Multisample,
            label: format!("m{time}"),
            main,
        };
        let s = svg(&[PlotPanel {
            title: "a <scene>".into(),
            points: vec![
                p(1.0, 0.1, true),
                p(2.0, 0.2, true),
                p(4.0, 0.01, true),
                p(3.0, 0.0, false),
            ],
        }]);
        assert!(s.starts_with("<svg"));
        assert!(s.contains("<polyline class=\"pareto\""));
        assert!(s.contains("a &lt;scene&gt;"));
        assert!(s.trim_end().ends_with("</svg>"));
    }
}
