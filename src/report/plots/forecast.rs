//! The forecast probe's figure (runs made with `eval --probe forecast`):
//! each model's 1 s forecast error by decision from the evidence turn,
//! under the true intent (solid) and the other (dashed), pooled over its
//! cells, with the reference forecasters' true-intent errors on the same
//! cells in grey. A report without probe runs has none.

use super::{FLOOR_COLOR, GRID, INK, Plot, PlotInput, Series, Svg};
use crate::export::f2;
use crate::forecast::metrics::{OFFSETS, OffsetBin};
use crate::report::forecast::ForecastRow;

/// The references drawn, as their rows name them, and how.
const REFERENCES: [(&str, Option<&str>); 2] = [("rules*", None), ("constant_velocity*", Some("2 3"))];

pub(crate) fn plots(input: &PlotInput) -> Vec<Plot> {
    by_turn(input).into_iter().collect()
}

/// The bins of `rows`, pooled offset by offset.
fn pooled<'a>(rows: impl Iterator<Item = &'a ForecastRow> + Clone) -> Vec<OffsetBin> {
    OFFSETS.map(|o| OffsetBin::pool(o, rows.clone().flat_map(|r| r.summary.by_offset.iter()))).collect()
}

fn by_turn(input: &PlotInput) -> Option<Plot> {
    let st = input.style;
    let rows = input.forecast;
    let models: Vec<(Series, Vec<OffsetBin>)> = input
        .series()
        .into_iter()
        .filter_map(|s| {
            let mine = rows.iter().filter(|r| r.model == s.label);
            mine.clone().next()?;
            let bins = pooled(mine);
            Some((s, bins))
        })
        .collect();
    if models.is_empty() {
        return None;
    }
    let references: Vec<(&str, Option<&str>, Vec<OffsetBin>)> =
        REFERENCES.iter().map(|&(name, dash)| (name, dash, pooled(rows.iter().filter(|r| r.model == name)))).collect();
    let sp = |x: f64| st.space(x);
    let (left, top, w, h, gap) = (sp(56.0), sp(62.0), 300.0, 220.0, sp(70.0));
    let legend_w = models.iter().map(|m| st.text_width(&m.0.name, 11.0)).fold(sp(190.0), f64::max) + sp(40.0);
    let mut svg = Svg::new(left + 2.0 * w + gap + 30.0 + legend_w, top + h + sp(60.0), st);
    let title = "Forecast error by decision from the evidence (1 s ahead)".to_string();
    svg.title(10.0, 20.0, &title, 14.0, 24.0);
    // Left: the true intent, models against the references; right: the
    // other intent (after the evidence, a counterfactual), models only.
    let true_max = models
        .iter()
        .flat_map(|(_, b)| b.iter().map(|b| b.error_true_m))
        .chain(references.iter().flat_map(|(_, _, b)| b.iter().map(|b| b.error_true_m)));
    let other_max = models.iter().flat_map(|(_, b)| b.iter().map(|b| b.error_other_m));
    let panels: [(&str, f64, f64); 2] = [
        ("true intent (the episode)", left, nice_max(finite_max(true_max))),
        ("other intent (the twin)", left + w + gap, nice_max(finite_max(other_max))),
    ];
    for (p, &(label, x0, y_max)) in panels.iter().enumerate() {
        let frame = Frame { x0, top, w, h, y_max };
        frame.axes(&mut svg, label);
        if p == 0 {
            for (_, dash, bins) in &references {
                frame.line(&mut svg, bins, |b| b.error_true_m, FLOOR_COLOR, *dash);
            }
        }
        let value: fn(&OffsetBin) -> f64 = if p == 0 { |b| b.error_true_m } else { |b| b.error_other_m };
        for (m, bins) in &models {
            frame.line(&mut svg, bins, value, m.color, None);
            for b in bins.iter().filter(|b| value(b).is_finite()) {
                let tip = format!(
                    "{}: {} decisions from the evidence, {} forecasts: {} m",
                    m.label,
                    b.offset,
                    b.points,
                    f2(value(b))
                );
                svg.marker(m.shape, frame.x(b.offset), frame.y(value(b)), 3.5, m.color, INK, Some(&tip));
            }
        }
    }
    let mid = top + h / 2.0;
    svg.text_up(sp(14.0), mid, "mean absolute error (m)", 11.0);
    let lx = left + 2.0 * w + gap + 30.0;
    let mut ly = top + sp(6.0);
    for (m, _) in &models {
        svg.marker(m.shape, lx + 6.0, ly - 4.0, 4.0, m.color, INK, None);
        svg.text_tip(lx + 16.0, ly, &m.name, 11.0, "start", &m.label);
        ly += sp(18.0);
    }
    ly += sp(6.0);
    for (label, dash) in [("rules* (reference)", None), ("constant velocity* (reference)", Some("2 3"))] {
        svg.line(lx, ly - 4.0, lx + 18.0, ly - 4.0, FLOOR_COLOR, 1.8, dash);
        svg.text(lx + 24.0, ly, label, 11.0, "start", "");
        ly += sp(18.0);
    }
    Some(Plot {
        name: "forecast_by_turn".into(),
        title: title.clone(),
        caption: "Mean absolute error (m) of the 1 s forecasts made each decision from the evidence turn (the ends \
                  gather every earlier and later one), pooled over each model's cells. Left: under the true intent, \
                  against the episode's true positions; grey, the reference forecasters on the same cells (rules, and \
                  constant velocity dashed; along the expert's episodes, seeds 0-199). Right: under the other intent, \
                  against the twin world under the other disposition (after the evidence, a counterfactual)."
            .into(),
        svg: svg.finish(&title),
    })
}

/// One panel's plotting area: offsets across, errors (m) up from 0.
struct Frame {
    x0: f64,
    top: f64,
    w: f64,
    h: f64,
    y_max: f64,
}

impl Frame {
    fn x(&self, offset: i32) -> f64 {
        let (lo, hi) = (f64::from(*OFFSETS.start()), f64::from(*OFFSETS.end()));
        self.x0 + (f64::from(offset) - lo) / (hi - lo) * self.w
    }

    fn y(&self, v: f64) -> f64 {
        self.top + self.h - (v / self.y_max).clamp(0.0, 1.0) * self.h
    }

    fn axes(&self, svg: &mut Svg, label: &str) {
        let style = svg.style();
        let sp = |x: f64| style.space(x);
        let (below, half_cap, above) = (sp(14.0), sp(3.5), sp(10.0));
        svg.text(self.x0 + self.w / 2.0, self.top - sp(14.0), label, 12.0, "middle", " font-weight=\"bold\"");
        for k in 0..=4 {
            let v = self.y_max * f64::from(k) / 4.0;
            svg.line(self.x0, self.y(v), self.x0 + self.w, self.y(v), GRID, 1.0, None);
            svg.text(self.x0 - 4.0, self.y(v) + half_cap, &tick(v), 10.0, "end", "");
        }
        for o in OFFSETS {
            let label = match o {
                o if o == *OFFSETS.start() => format!("<={o}"),
                o if o == *OFFSETS.end() => format!(">=+{o}"),
                o if o > 0 => format!("+{o}"),
                o => o.to_string(),
            };
            svg.text(self.x(o), self.top + self.h + below, &label, 10.0, "middle", "");
        }
        svg.line(self.x(0), self.top, self.x(0), self.top + self.h, INK, 1.0, Some("2 3"));
        svg.text(self.x(0) + 4.0, self.top + above, "evidence", 10.0, "start", "");
        let axis_label_y = self.top + self.h + sp(34.0);
        svg.text(self.x0 + self.w / 2.0, axis_label_y, "decisions from the evidence turn", 11.0, "middle", "");
    }

    fn line(&self, svg: &mut Svg, bins: &[OffsetBin], value: fn(&OffsetBin) -> f64, color: &str, dash: Option<&str>) {
        let pts: Vec<(f64, f64)> =
            bins.iter().filter(|b| value(b).is_finite()).map(|b| (self.x(b.offset), self.y(value(b)))).collect();
        svg.polyline(&pts, color, 1.8, dash);
    }
}

/// The largest finite value (0 without one).
fn finite_max(values: impl Iterator<Item = f64>) -> f64 {
    values.filter(|x| x.is_finite()).fold(0.0, f64::max)
}

/// A tidy axis maximum: 1, 2 or 5 times a power of ten at or above `v`.
fn nice_max(v: f64) -> f64 {
    if v.is_nan() || v <= 0.0 {
        return 1.0;
    }
    let p = 10f64.powf(v.log10().floor());
    [1.0, 2.0, 5.0, 10.0].into_iter().map(|k| k * p).find(|m| *m >= v).unwrap_or(10.0 * p)
}

fn tick(v: f64) -> String {
    let s = format!("{v:.2}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

#[cfg(test)]
mod tests {
    #[test]
    fn axis_maxima_are_tidy() {
        assert_eq!(super::nice_max(0.0), 1.0);
        assert_eq!(super::nice_max(0.37), 0.5);
        assert_eq!(super::nice_max(7.0), 10.0);
        assert_eq!(super::nice_max(12.0), 20.0);
        assert_eq!(super::tick(2.5), "2.5");
    }
}
