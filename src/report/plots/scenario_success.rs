//! Dot-and-whisker panels: per-scenario success with 95% CI whiskers, the
//! ranked mean, and text against picture per cell; the expert ceiling and
//! the `always_proceed` floor are vertical dashed lines where they apply.

use super::{CEILING_COLOR, FLOOR_COLOR, INK, Plot, PlotInput, Series, Style, Svg, rate_axis_x};
use crate::export::{f2, with_ci};
use crate::report::tables::tiers_label;
use crate::stats::Interval;

struct Panel {
    title: String,
    ceiling: Option<f64>,
    floor: Option<f64>,
    /// One per model (leaderboard order).
    values: Vec<Option<Interval>>,
}

fn dot_whisker(st: Style, name: &str, title: &str, caption: String, models: &[Series], panels: &[Panel]) -> Plot {
    let label_w = models.iter().map(|m| st.text_width(&m.name, 11.0)).fold(60.0, f64::max) + 12.0;
    // Lengths that hold text grow with it (paper style).
    let v = |x: f64| st.space(x);
    let (gap, row_h, top) = (v(26.0), v(22.0), v(68.0));
    // Panels narrow (down to 120 px) so that long names still leave the figure printable.
    let pw =
        st.max_width().map_or(230.0, |max| ((max - label_w - 10.0) / panels.len() as f64 - gap).clamp(120.0, 230.0));
    // In a paper the caption says what the whiskers are.
    let axis_label = if st == Style::Paper {
        "success rate (whisker: 95% CI)"
    } else {
        "success rate (dot: estimate; whisker: 95% percentile bootstrap CI)"
    };
    // However narrow, too many panels for a paper's width wrap onto more rows.
    let per_row = super::panels_per_row(st, panels.len(), label_w, pw, gap);
    let panel_rows = panels.len().max(1).div_ceil(per_row);
    let band = top + models.len() as f64 * row_h + v(40.0) - v(10.0);
    // Wide enough for the axis label too (one panel alone is narrower).
    let width = (label_w + per_row as f64 * (pw + gap) + 10.0).max(label_w + st.text_width(axis_label, 10.0) + 10.0);
    let height = top + models.len() as f64 * row_h + v(40.0) + (panel_rows - 1) as f64 * band;
    let mut svg = Svg::new(width, height, st);
    svg.title(10.0, 18.0, title, 14.0, v(22.0));
    for (p, panel) in panels.iter().enumerate() {
        let x0 = label_w + (p % per_row) as f64 * (pw + gap);
        let shift = (p / per_row) as f64 * band;
        let (top, bottom) = (top + shift, top + shift + models.len() as f64 * row_h);
        let v = |x: f64| shift + v(x);
        svg.rect(x0, top - 6.0, pw, bottom - top + 6.0, "#fafafa", "");
        svg.text(x0 + pw / 2.0, v(34.0), &panel.title, 12.0, "middle", " font-weight=\"bold\"");
        rate_axis_x(&mut svg, x0, pw, top - 6.0, bottom);
        for (value, color, label, dy) in
            [(panel.ceiling, CEILING_COLOR, "expert", v(47.0)), (panel.floor, FLOOR_COLOR, "floor", v(58.0))]
        {
            if let Some(v) = value {
                let x = x0 + v.clamp(0.0, 1.0) * pw;
                svg.line(x, top - 6.0, x, bottom, color, 1.6, Some("5 3"));
                let anchor = if v > 0.85 {
                    "end"
                } else if v < 0.15 {
                    "start"
                } else {
                    "middle"
                };
                svg.text(x, dy, &format!("{label} {}", f2(v)), 9.5, anchor, &format!(" fill=\"{color}\""));
            }
        }
        for (i, v) in panel.values.iter().enumerate() {
            let Some(v) = v else { continue };
            let y = top + (i as f64 + 0.5) * row_h;
            let x = |r: f64| x0 + r.clamp(0.0, 1.0) * pw;
            let color = models[i].color;
            if v.lo.is_finite() && v.hi.is_finite() {
                svg.line(x(v.lo), y, x(v.hi), y, color, 2.0, None);
                svg.line(x(v.lo), y - 4.0, x(v.lo), y + 4.0, color, 1.5, None);
                svg.line(x(v.hi), y - 4.0, x(v.hi), y + 4.0, color, 1.5, None);
            }
            let tip = format!("{}: {}", models[i].label, with_ci(v));
            svg.marker(models[i].shape, x(v.estimate), y, 4.5, color, INK, Some(&tip));
        }
    }
    for row in 0..panel_rows {
        for (i, m) in models.iter().enumerate() {
            let y = top + row as f64 * band + (i as f64 + 0.5) * row_h + v(4.0);
            svg.text_tip(label_w - 8.0, y, &m.name, 11.0, "end", &m.label);
        }
    }
    svg.text(label_w, height - v(6.0), axis_label, 10.0, "start", "");
    Plot { name: name.into(), title: title.into(), caption, svg: svg.finish(title) }
}

pub(crate) fn by_scenario(input: &PlotInput) -> Plot {
    let lb = input.leaderboard;
    let models = input.series();
    let panels: Vec<Panel> = lb
        .scenarios
        .iter()
        .enumerate()
        .map(|(k, s)| Panel {
            title: s.to_string(),
            ceiling: lb.references.first().and_then(|r| r.scenarios[k]),
            floor: lb.references.get(1).and_then(|r| r.scenarios[k]),
            values: lb.rows.iter().map(|r| r.scenarios[k].as_ref().map(|c| c.success)).collect(),
        })
        .collect();
    dot_whisker(
        input.style,
        "success_by_scenario",
        &format!("Success by scenario ({})", tiers_label(&lb.tiers)),
        "Per-scenario success with 95% percentile bootstrap CI whiskers, models in leaderboard order; dashed lines: \
         the expert ceiling and the always_proceed floor (reference levels from separate baseline runs)."
            .into(),
        &models,
        &panels,
    )
}

pub(crate) fn ranked_mean(input: &PlotInput) -> Plot {
    let lb = input.leaderboard;
    let models = input.series();
    let panel = Panel {
        title: "average over scenarios".into(),
        ceiling: lb.references.first().and_then(|r| r.average),
        floor: lb.references.get(1).and_then(|r| r.average),
        values: lb.rows.iter().map(|r| Some(r.average)).collect(),
    };
    dot_whisker(
        input.style,
        "ranked_mean",
        &format!("Ranked mean success ({})", tiers_label(&lb.tiers)),
        "Average success over scenarios, best first; whiskers: clustered bootstrap 95% CI resampling seeds jointly \
         across scenarios. Overlapping whiskers are not a ranking: see the paired comparisons."
            .into(),
        &models,
        &[panel],
    )
}

/// One panel per (scenario, tier) cell with a model under two observations:
/// success of each observation on the shared seeds (95% Wilson whiskers),
/// the panel's title giving the McNemar p of its first pair.
pub(crate) fn text_against_picture(input: &PlotInput) -> Option<Plot> {
    let rows = input.observations;
    if rows.is_empty() {
        return None;
    }
    let mut labels: Vec<&str> = Vec::new();
    for r in rows {
        for l in [r.label_a.as_str(), r.label_b.as_str()] {
            if !labels.contains(&l) {
                labels.push(l);
            }
        }
    }
    let models: Vec<Series> = input.series().into_iter().filter(|s| labels.contains(&s.label.as_str())).collect();
    let mut cells: Vec<(crate::scenario::ScenarioKind, crate::scenario::Tier)> = Vec::new();
    for r in rows {
        if !cells.contains(&(r.scenario, r.tier)) {
            cells.push((r.scenario, r.tier));
        }
    }
    let panels: Vec<Panel> = cells
        .iter()
        .map(|&(scenario, tier)| {
            let here: Vec<_> = rows.iter().filter(|r| (r.scenario, r.tier) == (scenario, tier)).collect();
            let value = |label: &str| {
                here.iter().find_map(|r| {
                    if r.label_a == label {
                        Some(r.success_a)
                    } else if r.label_b == label {
                        Some(r.success_b)
                    } else {
                        None
                    }
                })
            };
            Panel {
                title: format!("{scenario} t{tier}: p {}", crate::export::p_value(here[0].mcnemar_p)),
                ceiling: None,
                floor: None,
                values: models.iter().map(|m| value(&m.label)).collect(),
            }
        })
        .collect();
    Some(dot_whisker(
        input.style,
        "text_against_picture",
        "Text against picture",
        "Per (scenario, tier): success of one model id under each observation (eval --observation) on the seeds both \
         runs finished, with 95% Wilson whiskers; the panel title gives the exact McNemar p of the paired seeds (the \
         table \"Text against picture\" has every pair)."
            .into(),
        &models,
        &panels,
    ))
}
