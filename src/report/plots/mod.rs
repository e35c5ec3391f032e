//! Self-contained SVG plots, written by hand: no plotting crate, no fonts,
//! no external references (the standalone files carry only the SVG
//! namespace; the copies inlined in report.html not even that). Every text
//! is escaped. Text sizes come from the [`Style`] (see [`style`]).

mod belief;
mod correctness;
mod forecast;
mod outcomes;
mod radar;
mod scenario_success;
pub mod style;
mod tier_ladder;
mod timeline;
mod timing;
mod trajectory;

use super::drill::Loaded;
use super::load::Dataset;
use super::reference::References;
use super::tables::{Leaderboard, OutcomeRow, TierRow};
use crate::export::esc;
use serde::Serialize;
use std::fmt::Write;
pub use style::Style;

/// One figure.
#[derive(Debug, Clone, Serialize)]
pub struct Plot {
    /// File stem under `plots/`.
    pub name: String,
    pub title: String,
    pub caption: String,
    /// The `<svg>` element without a namespace (for inlining in HTML).
    #[serde(skip)]
    pub svg: String,
}

impl Plot {
    /// The standalone file's text (with the SVG namespace).
    pub(crate) fn file_text(&self) -> String {
        format!("{}\n", self.svg.replacen("<svg ", "<svg xmlns=\"http://www.w3.org/2000/svg\" ", 1))
    }
}

/// What the plots are drawn from.
pub struct PlotInput<'a> {
    pub leaderboard: &'a Leaderboard,
    pub tiers: &'a [TierRow],
    pub outcomes: &'a [OutcomeRow],
    pub timing: &'a [super::timing::TimingRow],
    /// Forecast-probe rows (models, then the references); empty without.
    pub forecast: &'a [super::forecast::ForecastRow],
    /// Text against picture rows; empty without a model under two observations.
    pub observations: &'a [super::observations::ObservationRow],
    pub refs: &'a References,
    pub data: &'a Dataset,
    pub transcripts: &'a [Loaded],
    /// The episodes drawn as trajectories (see [`super::pick`]).
    pub trajectories: &'a [Loaded],
    /// The maneuver timelines across models (see [`super::pick`]).
    pub timelines: &'a [super::pick::Timeline],
    /// How the figures are drawn (text sizes, titles, print width).
    pub style: Style,
}

impl PlotInput<'_> {
    /// Model labels in leaderboard order.
    pub(crate) fn models(&self) -> Vec<&str> {
        self.leaderboard.rows.iter().map(|r| r.model.as_str()).collect()
    }

    /// How each model is drawn, in leaderboard order.
    pub(crate) fn series(&self) -> Vec<Series> {
        let labels = self.models();
        let styles = assign_styles(&labels);
        self.leaderboard
            .rows
            .iter()
            .zip(styles)
            .map(|(r, (color, shape))| Series {
                label: r.model.clone(),
                name: display_name(&r.model, r.incomplete.is_some()),
                color,
                shape,
            })
            .collect()
    }
}

/// How one model is drawn in every figure.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Series {
    /// The full label (tooltips, lookups).
    pub label: String,
    /// As printed in a figure: shortened in the middle, `†` when incomplete.
    pub name: String,
    pub color: &'static str,
    /// Marker: 0 circle, 1 square, 2 triangle, 3 diamond.
    pub shape: usize,
}

/// Longest model name printed in a figure, in characters; longer names are
/// shortened in the middle (the full name is in the tooltip).
pub(crate) const NAME_CHARS: usize = 24;

/// `name` shortened to [`NAME_CHARS`] with an ellipsis in the middle (the
/// start and the end of a model id both tell models apart), then the
/// incomplete mark.
pub(crate) fn display_name(name: &str, incomplete: bool) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut s = if chars.len() <= NAME_CHARS {
        name.to_string()
    } else {
        let head = (NAME_CHARS - 1).div_ceil(2);
        let tail = NAME_CHARS - 1 - head;
        format!(
            "{}\u{2026}{}",
            chars[..head].iter().collect::<String>(),
            chars[chars.len() - tail..].iter().collect::<String>()
        )
    };
    if incomplete {
        s.push(' ');
        s.push_str(crate::export::INCOMPLETE_MARK);
    }
    s
}

/// Okabe-Ito colours (colour-blind safe; Okabe & Ito 2008) without black,
/// which the references use.
pub(crate) const OKABE_ITO: [&str; 7] = ["#E69F00", "#56B4E9", "#009E73", "#0072B2", "#D55E00", "#CC79A7", "#F0E442"];

/// (colour, marker shape) per label, stable per model name: a label's
/// preferred colour is a hash of its name, so the same model keeps its
/// colour across reports and `--tiers` choices; labels are placed in name
/// order and a label whose colour is taken moves to the next free
/// (colour, shape) slot, so up to 7 models differ in colour and up to 28 in
/// colour or shape (beyond 7 models, shapes vary too).
pub(crate) fn assign_styles(labels: &[&str]) -> Vec<(&'static str, usize)> {
    let slots = OKABE_ITO.len() * 4;
    let mut order: Vec<usize> = (0..labels.len()).collect();
    order.sort_by_key(|&i| labels[i]);
    let mut taken = vec![false; slots];
    let mut out = vec![(OKABE_ITO[0], 0); labels.len()];
    for (placed, &i) in order.iter().enumerate() {
        if placed % slots == 0 {
            taken.iter_mut().for_each(|t| *t = false);
        }
        let preferred = (crate::hash::fnv1a64(labels[i]) % OKABE_ITO.len() as u64) as usize;
        let slot = (0..slots).map(|k| (preferred + k) % slots).find(|&k| !taken[k]).unwrap_or(preferred);
        taken[slot] = true;
        out[i] = (OKABE_ITO[slot % OKABE_ITO.len()], slot / OKABE_ITO.len());
    }
    out
}

pub(crate) fn all(input: &PlotInput) -> Vec<Plot> {
    let mut plots = vec![scenario_success::by_scenario(input), scenario_success::ranked_mean(input)];
    plots.extend(scenario_success::text_against_picture(input));
    plots.push(correctness::plot(input));
    plots.push(tier_ladder::plot(input));
    plots.push(outcomes::plot(input));
    plots.extend(timing::plots(input));
    plots.extend(radar::plot(input));
    plots.extend(trajectory::plots(input));
    plots.extend(timeline::plots(input));
    plots.extend(belief::plots(input));
    plots.extend(forecast::plots(input));
    plots
}

/// References are neutral, never a model's hue: the expert ceiling black,
/// the `always_proceed` floor grey (both dashed).
pub(crate) const CEILING_COLOR: &str = "#000000";
pub(crate) const FLOOR_COLOR: &str = "#8c8c8c";
pub(crate) const SUCCESS_COLOR: &str = "#59a14f";
pub(crate) const COLLISION_COLOR: &str = "#e15759";
pub(crate) const TIMEOUT_COLOR: &str = "#9e9e9e";
pub(crate) const GRID: &str = "#e3e3e3";
pub(crate) const INK: &str = "#222";

/// A small deterministic offset in pixels (each coordinate in
/// [-`amount`, `amount`]) from `key`: overplotted points separate, and the
/// same report draws them at the same places every time.
pub(crate) fn jitter(key: &str, amount: f64) -> (f64, f64) {
    let h = crate::hash::fnv1a64(key);
    let unit = |bits: u64| (bits & 0xffff) as f64 / f64::from(0xffff_u32) * 2.0 - 1.0;
    (unit(h) * amount, unit(h >> 16) * amount)
}

/// Overplotted groups: points (in pixels, before jitter) whose distance to
/// a group's first point is within `radius` join that group. Returns each
/// group's first point and its size, in order of first appearance.
pub(crate) fn overlaps(points: &[(f64, f64)], radius: f64) -> Vec<((f64, f64), usize)> {
    let mut groups: Vec<((f64, f64), usize)> = Vec::new();
    for &(x, y) in points {
        match groups.iter_mut().find(|((gx, gy), _)| (gx - x).hypot(gy - y) <= radius) {
            Some(g) => g.1 += 1,
            None => groups.push(((x, y), 1)),
        }
    }
    groups
}

/// A number for an SVG attribute: one decimal, no "-0.0".
pub(crate) fn n(x: f64) -> String {
    let x = if x.is_finite() { (x * 10.0).round() / 10.0 } else { 0.0 };
    if x == 0.0 { "0".into() } else { format!("{x}") }
}

/// How many of `n` panels, each `panel_w` wide with `gap` after it, a row
/// of a figure holds after `left`: every one in the default style; in
/// paper style as many as keep the figure within [`Style::max_width`] (at
/// least one), so that a figure of any number of scenarios still prints
/// its text at 8 pt, wrapping its panels onto more rows.
pub(crate) fn panels_per_row(style: Style, n: usize, left: f64, panel_w: f64, gap: f64) -> usize {
    let n = n.max(1);
    match style.max_width() {
        None => n,
        Some(max) => (((max - left - 10.0) / (panel_w + gap)).floor().max(1.0) as usize).min(n),
    }
}

/// Approximate width of a text in pixels at `size`.
pub(crate) fn text_width(s: &str, size: f64) -> f64 {
    s.chars().count() as f64 * size * 0.58
}

/// An SVG document being written. Text sizes are given as the default
/// style's pixels and drawn at the style's size ([`Style::font`]).
pub struct Svg {
    w: f64,
    h: f64,
    body: String,
    style: Style,
    /// The smallest text drawn (pixels), for the paper print width.
    min_font: f64,
    /// Height of the title band cut off the top when there is no title.
    untitled_crop: f64,
}

impl Svg {
    pub(crate) fn new(w: f64, h: f64, style: Style) -> Svg {
        Svg { w, h, body: String::new(), style, min_font: f64::INFINITY, untitled_crop: 0.0 }
    }

    pub(crate) fn style(&self) -> Style {
        self.style
    }

    /// The figure's title, bold, at (x, y); in a style without titles
    /// nothing is drawn and the band above `band` (where only the title
    /// is) is cut off the figure.
    pub(crate) fn title(&mut self, x: f64, y: f64, s: &str, size: f64, band: f64) {
        if self.style.titled() {
            self.text(x, y, s, size, "start", " font-weight=\"bold\"");
        } else {
            self.untitled_crop = band;
        }
    }

    /// The style's size for `base` pixels, recorded as drawn.
    fn font_px(&mut self, base: f64) -> f64 {
        let px = self.style.font(base);
        self.min_font = self.min_font.min(px);
        px
    }

    pub(crate) fn rect(&mut self, x: f64, y: f64, w: f64, h: f64, fill: &str, extra: &str) {
        let _ = write!(
            self.body,
            "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"{fill}\"{extra}/>",
            n(x),
            n(y),
            n(w.max(0.0)),
            n(h.max(0.0))
        );
    }

    /// A rectangle with a hover tooltip.
    pub(crate) fn rect_tip(&mut self, x: f64, y: f64, w: f64, h: f64, fill: &str, tip: &str) {
        let _ = write!(
            self.body,
            "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"{fill}\"",
            n(x),
            n(y),
            n(w.max(0.0)),
            n(h.max(0.0))
        );
        self.close_with_tip(Some(tip), "rect");
    }

    #[allow(clippy::too_many_arguments)] // the coordinates and style of one primitive
    pub(crate) fn line(&mut self, x1: f64, y1: f64, x2: f64, y2: f64, stroke: &str, width: f64, dash: Option<&str>) {
        let dash = dash.map_or(String::new(), |d| format!(" stroke-dasharray=\"{d}\""));
        let _ = write!(
            self.body,
            "<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"{stroke}\" stroke-width=\"{}\"{dash}/>",
            n(x1),
            n(y1),
            n(x2),
            n(y2),
            n(width)
        );
    }

    /// A circle with an optional hover tooltip.
    pub(crate) fn circle(&mut self, cx: f64, cy: f64, r: f64, fill: &str, stroke: &str, tip: Option<&str>) {
        let _ = write!(
            self.body,
            "<circle cx=\"{}\" cy=\"{}\" r=\"{}\" fill=\"{fill}\" stroke=\"{stroke}\"",
            n(cx),
            n(cy),
            n(r)
        );
        self.close_with_tip(tip, "circle");
    }

    /// A marker: 0 circle, 1 square, 2 triangle, 3 diamond.
    #[allow(clippy::too_many_arguments)] // the coordinates and style of one primitive
    pub(crate) fn marker(
        &mut self,
        shape: usize,
        cx: f64,
        cy: f64,
        r: f64,
        fill: &str,
        stroke: &str,
        tip: Option<&str>,
    ) {
        match shape % 4 {
            0 => self.circle(cx, cy, r, fill, stroke, tip),
            1 => {
                let _ = write!(
                    self.body,
                    "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"{fill}\" stroke=\"{stroke}\"",
                    n(cx - r),
                    n(cy - r),
                    n(2.0 * r),
                    n(2.0 * r)
                );
                self.close_with_tip(tip, "rect");
            }
            k => {
                let pts: Vec<(f64, f64)> = if k == 2 {
                    vec![(cx, cy - 1.2 * r), (cx + 1.1 * r, cy + 0.9 * r), (cx - 1.1 * r, cy + 0.9 * r)]
                } else {
                    vec![(cx, cy - 1.3 * r), (cx + 1.3 * r, cy), (cx, cy + 1.3 * r), (cx - 1.3 * r, cy)]
                };
                let _ = write!(self.body, "<polygon points=\"{}\" fill=\"{fill}\" stroke=\"{stroke}\"", points(&pts));
                self.close_with_tip(tip, "polygon");
            }
        }
    }

    /// Open a group whose attributes (e.g. `fill-opacity`) its children inherit.
    pub(crate) fn open_group(&mut self, attrs: &str) {
        let _ = write!(self.body, "<g {attrs}>");
    }

    pub(crate) fn close_group(&mut self) {
        self.body.push_str("</g>");
    }

    fn close_with_tip(&mut self, tip: Option<&str>, element: &str) {
        match tip {
            Some(t) => {
                let _ = write!(self.body, "><title>{}</title></{element}>", esc(t));
            }
            None => self.body.push_str("/>"),
        }
    }

    /// Text; `anchor` is start, middle or end; `extra` more attributes.
    /// A vertical axis title: `s` turned a quarter left, centred at (x, y).
    pub(crate) fn text_up(&mut self, x: f64, y: f64, s: &str, size: f64) {
        self.text(x, y, s, size, "middle", &format!(" transform=\"rotate(-90 {} {})\"", n(x), n(y)));
    }

    pub(crate) fn text(&mut self, x: f64, y: f64, s: &str, size: f64, anchor: &str, extra: &str) {
        let fill = if extra.contains(" fill=") { String::new() } else { format!(" fill=\"{INK}\"") };
        let size = self.font_px(size);
        let _ = write!(
            self.body,
            "<text x=\"{}\" y=\"{}\" font-size=\"{}\" text-anchor=\"{anchor}\"{fill}{extra}>{}</text>",
            n(x),
            n(y),
            n(size),
            esc(s)
        );
    }

    /// Text with a hover tooltip (a shortened name's full form).
    #[allow(clippy::too_many_arguments)] // the coordinates and style of one primitive
    pub(crate) fn text_tip(&mut self, x: f64, y: f64, s: &str, size: f64, anchor: &str, tip: &str) {
        let size = self.font_px(size);
        let _ = write!(
            self.body,
            "<text x=\"{}\" y=\"{}\" font-size=\"{}\" text-anchor=\"{anchor}\" fill=\"{INK}\"><title>{}</title>{}</text>",
            n(x),
            n(y),
            n(size),
            esc(tip),
            esc(s)
        );
    }

    pub(crate) fn polyline(&mut self, pts: &[(f64, f64)], stroke: &str, width: f64, dash: Option<&str>) {
        if pts.len() < 2 {
            return;
        }
        let dash = dash.map_or(String::new(), |d| format!(" stroke-dasharray=\"{d}\""));
        let _ = write!(
            self.body,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"{stroke}\" stroke-width=\"{}\" stroke-linejoin=\"round\"{dash}/>",
            points(pts),
            n(width)
        );
    }

    pub(crate) fn polygon(
        &mut self,
        pts: &[(f64, f64)],
        fill: &str,
        fill_opacity: f64,
        stroke: &str,
        dash: Option<&str>,
    ) {
        let dash = dash.map_or(String::new(), |d| format!(" stroke-dasharray=\"{d}\""));
        let _ = write!(
            self.body,
            "<polygon points=\"{}\" fill=\"{fill}\" fill-opacity=\"{}\" stroke=\"{stroke}\" stroke-width=\"1.5\"{dash}/>",
            points(pts),
            fill_opacity
        );
    }

    /// A horizontal legend entry: a swatch and a label; returns its width.
    pub(crate) fn legend_item(&mut self, x: f64, y: f64, color: &str, label: &str, dashed: bool) -> f64 {
        if dashed {
            self.line(x, y - 4.0, x + 18.0, y - 4.0, color, 2.0, Some("5 3"));
        } else {
            self.rect(x, y - 9.0, 12.0, 10.0, color, "");
        }
        let lx = x + if dashed { 22.0 } else { 16.0 };
        self.text(lx, y, label, 11.0, "start", "");
        lx - x + self.style.text_width(label, 11.0) + 14.0
    }

    /// The `<svg>` element. Untitled (paper) figures declare their print
    /// width in inches ([`Style::print_width_in`]) over a viewBox in
    /// pixels, so a reader (and the tests) can tell the printed text size,
    /// and carry no title at all.
    pub(crate) fn finish(self, title: &str) -> String {
        if !self.style.titled() {
            let (top, h) = (self.untitled_crop, self.h - self.untitled_crop);
            let print_w = Style::print_width_in(self.w, self.min_font);
            let print_h = print_w * h / self.w;
            return format!(
                "<svg viewBox=\"0 {top} {w} {h}\" width=\"{print_w}in\" height=\"{print_h:.2}in\" data-style=\"{style}\" font-family=\"Helvetica, Arial, sans-serif\" role=\"img\"><rect y=\"{top}\" width=\"{w}\" height=\"{h}\" fill=\"#ffffff\"/>{body}</svg>",
                top = n(top),
                w = n(self.w),
                h = n(h),
                style = self.style,
                body = self.body
            );
        }
        format!(
            "<svg viewBox=\"0 0 {w} {h}\" width=\"{w}\" height=\"{h}\" font-family=\"Helvetica, Arial, sans-serif\" role=\"img\"><title>{t}</title><rect width=\"{w}\" height=\"{h}\" fill=\"#ffffff\"/>{body}</svg>",
            w = n(self.w),
            h = n(self.h),
            t = esc(title),
            body = self.body
        )
    }
}

fn points(pts: &[(f64, f64)]) -> String {
    pts.iter().map(|(x, y)| format!("{},{}", n(*x), n(*y))).collect::<Vec<_>>().join(" ")
}

/// Vertical grid lines and tick labels of a [0, 1] rate axis.
pub(crate) fn rate_axis_x(svg: &mut Svg, x0: f64, width: f64, top: f64, bottom: f64) {
    let below = svg.style().space(13.0);
    for k in 0..=4 {
        let v = f64::from(k) / 4.0;
        let x = x0 + v * width;
        svg.line(x, top, x, bottom, GRID, 1.0, None);
        svg.text(x, bottom + below, &tick(v), 10.0, "middle", "");
    }
}

/// Horizontal grid lines and tick labels of a [0, 1] rate axis.
pub(crate) fn rate_axis_y(svg: &mut Svg, y0: f64, height: f64, left: f64, right: f64) {
    for k in 0..=4 {
        let v = f64::from(k) / 4.0;
        let y = y0 + height - v * height;
        svg.line(left, y, right, y, GRID, 1.0, None);
        let half_cap = svg.style().space(3.5);
        svg.text(left - 4.0, y + half_cap, &tick(v), 10.0, "end", "");
    }
}

fn tick(v: f64) -> String {
    match v {
        0.0 => "0".into(),
        1.0 => "1".into(),
        v => format!("{v}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panels_wrap_within_the_paper_width_whatever_their_number() {
        for n in 1..=12 {
            assert_eq!(panels_per_row(Style::Default, n, 80.0, 220.0, 40.0), n);
            let per_row = panels_per_row(Style::Paper, n, 80.0, 220.0, 40.0);
            assert!((1..=n).contains(&per_row), "{n}");
            assert!(80.0 + per_row as f64 * 260.0 + 10.0 <= Style::Paper.max_width().unwrap(), "{n}: {per_row}");
            // No room left for one more in a row.
            assert!(per_row == n || 80.0 + (per_row + 1) as f64 * 260.0 + 10.0 > 945.0, "{n}: {per_row}");
        }
        assert_eq!(panels_per_row(Style::Paper, 3, 900.0, 220.0, 40.0), 1, "at least one");
    }

    #[test]
    fn overlaps_count_coincident_points_and_jitter_is_stable_and_bounded() {
        let groups = overlaps(&[(10.0, 10.0), (12.0, 11.0), (50.0, 50.0), (10.0, 10.0)], 5.0);
        assert_eq!(groups, vec![((10.0, 10.0), 3), ((50.0, 50.0), 1)]);
        let (a, b) = (jitter("m/yield_standoff", 3.0), jitter("m/merge", 3.0));
        assert_eq!(a, jitter("m/yield_standoff", 3.0));
        assert_ne!(a, b);
        assert!([a.0, a.1, b.0, b.1].iter().all(|v| v.abs() <= 3.0));
    }

    #[test]
    fn svg_text_is_escaped_and_numbers_compact() {
        let mut s = Svg::new(10.0, 10.0, Style::Default);
        s.text(1.0, 2.0, "<a&b>", 10.0, "start", "");
        s.circle(1.0, 1.0, 2.0, "red", "none", Some("x<y"));
        let out = s.finish("t\"q");
        assert!(out.contains("&lt;a&amp;b&gt;") && out.contains("<title>x&lt;y</title>"));
        assert!(out.contains("<title>t&quot;q</title>"));
        assert!(!out.contains("http"));
        assert_eq!((n(-0.01), n(2.25), n(3.0)), ("0".to_string(), "2.3".to_string(), "3".to_string()));
        assert_eq!(tick(0.25), "0.25");
    }

    #[test]
    fn long_names_are_shortened_in_the_middle_and_incomplete_ones_marked() {
        assert_eq!(display_name("gpt-4o", false), "gpt-4o");
        assert_eq!(display_name("gpt-4o", true), "gpt-4o \u{2020}");
        let long = "accounts/fireworks/models/llama-v3p1-405b-instruct";
        let short = display_name(long, false);
        assert_eq!(short.chars().count(), NAME_CHARS);
        assert_eq!(short, "accounts/fir\u{2026}5b-instruct");
    }

    #[test]
    fn colours_follow_the_name_not_the_rank_and_shapes_vary_beyond_seven() {
        let a = assign_styles(&["gpt-4o", "claude", "qwen3"]);
        // Another order and another set keep each model's colour.
        let b = assign_styles(&["qwen3", "gpt-4o"]);
        assert_eq!((a[0], a[2]), (b[1], b[0]));
        let names: Vec<String> = (0..12).map(|i| format!("model-{i}")).collect();
        let refs: Vec<&str> = names.iter().map(String::as_str).collect();
        let styles = assign_styles(&refs);
        let mut distinct = styles.clone();
        distinct.sort();
        distinct.dedup();
        assert_eq!(distinct.len(), 12, "every model has its own (colour, shape)");
        assert_eq!(styles.iter().filter(|s| s.1 == 0).count(), 7, "7 colours, then shapes");
        assert!(styles.iter().all(|(c, _)| OKABE_ITO.contains(c) && *c != CEILING_COLOR && *c != FLOOR_COLOR));
    }
}
