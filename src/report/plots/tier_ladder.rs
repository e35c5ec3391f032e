//! The tier ladder: success per tier, one line per model, one panel per
//! scenario, with the expert and `always_proceed` levels of each tier.

use super::{CEILING_COLOR, FLOOR_COLOR, INK, Plot, PlotInput, Svg, rate_axis_y};
use crate::export::with_ci;
use crate::report::reference::{CEILING, FLOOR};
use crate::scenario::{ScenarioKind, Tier};

pub(crate) fn plot(input: &PlotInput) -> Plot {
    let st = input.style;
    let models = input.series();
    let scenarios: Vec<ScenarioKind> =
        ScenarioKind::ALL.into_iter().filter(|s| input.tiers.iter().any(|r| r.scenario == *s)).collect();
    let tiers: Vec<Tier> = Tier::ALL.into_iter().filter(|t| input.tiers.iter().any(|r| r.tier == *t)).collect();
    // Lengths that hold text grow with it (paper style).
    let v = |x: f64| st.space(x);
    let (left, top, pw, ph, gap) = (v(64.0), v(46.0), 220.0, 220.0, v(40.0));
    // Panels wrap onto more rows where a paper's width would shrink their text.
    let per_row = super::panels_per_row(st, scenarios.len(), left, pw, gap);
    let panel_rows = scenarios.len().max(1).div_ceil(per_row);
    let row_step = ph + v(46.0);
    let width = left + per_row as f64 * (pw + gap);
    // Legend rows, wrapped as drawn below.
    let mut legend_rows = 1.0;
    let mut lx = 10.0;
    for m in &models {
        let w = st.text_width(&m.name, 11.0) + 30.0;
        if lx + w > width - 10.0 && lx > 10.0 {
            legend_rows += 1.0;
            lx = 10.0;
        }
        lx += w;
    }
    let below = top + (panel_rows - 1) as f64 * row_step + ph;
    let height = below + v(52.0) + legend_rows * v(18.0);
    let mut svg = Svg::new(width, height, st);
    let title = "Tier ladder: success by tier";
    svg.title(10.0, 20.0, title, 14.0, v(24.0));
    let xs = |x0: f64, t: Tier| {
        let i = tiers.iter().position(|&u| u == t).unwrap_or(0) as f64;
        let k = (tiers.len().max(2) - 1) as f64;
        x0 + 20.0 + i * (pw - 40.0) / k
    };
    let x_label = v(16.0);
    for (p, &s) in scenarios.iter().enumerate() {
        let x0 = left + (p % per_row) as f64 * (pw + gap);
        let top = top + (p / per_row) as f64 * row_step;
        let y = |v: f64| top + ph - v.clamp(0.0, 1.0) * ph;
        if p % per_row == 0 {
            svg.text_up(x_label, top + ph / 2.0, "success rate", 11.0);
        }
        svg.rect(x0, top, pw, ph, "#fafafa", "");
        rate_axis_y(&mut svg, top, ph, x0, x0 + pw);
        svg.text(x0 + pw / 2.0, top - v(8.0), &s.to_string(), 12.0, "middle", " font-weight=\"bold\"");
        for &t in &tiers {
            svg.text(xs(x0, t), top + ph + v(15.0), &format!("tier {t}"), 10.0, "middle", "");
        }
        for (policy, color) in [(CEILING, CEILING_COLOR), (FLOOR, FLOOR_COLOR)] {
            let pts: Vec<(f64, f64)> =
                tiers.iter().filter_map(|&t| input.refs.success(policy, s, &[t]).map(|v| (xs(x0, t), y(v)))).collect();
            svg.polyline(&pts, color, 1.5, Some("5 3"));
            for &(px, py) in &pts {
                svg.marker(2, px, py, 3.5, "none", color, Some(policy));
            }
        }
        // Models side by side within a tier so their whiskers do not overlap.
        let spread =
            |i: usize| (i as f64 - (models.len() as f64 - 1.0) / 2.0) * 5.0_f64.min(40.0 / models.len() as f64);
        for (i, m) in models.iter().enumerate() {
            let rows: Vec<_> = input.tiers.iter().filter(|r| r.model == m.label && r.scenario == s).collect();
            let pts: Vec<(f64, f64)> =
                rows.iter().map(|r| (xs(x0, r.tier) + spread(i), y(r.metrics.success.estimate))).collect();
            svg.polyline(&pts, m.color, 2.0, None);
            for (r, &(px, py)) in rows.iter().zip(&pts) {
                if r.metrics.success.lo.is_finite() && r.metrics.success.hi.is_finite() {
                    svg.line(px, y(r.metrics.success.lo), px, y(r.metrics.success.hi), m.color, 1.4, None);
                }
                let tip = format!("{}, {s} tier {}: {}", m.label, r.tier, with_ci(&r.metrics.success));
                svg.marker(m.shape, px, py, 3.5, m.color, INK, Some(&tip));
            }
        }
    }
    // Legend.
    let mut lx = 10.0;
    let mut ly = below + v(40.0);
    for m in &models {
        if lx + st.text_width(&m.name, 11.0) + 30.0 > width - 10.0 && lx > 10.0 {
            lx = 10.0;
            ly += v(18.0);
        }
        lx += svg.legend_item(lx, ly, m.color, &m.name, false);
    }
    ly += v(18.0);
    let mut lx = 10.0;
    lx += svg.legend_item(lx, ly, CEILING_COLOR, "expert ceiling (reference)", true);
    svg.legend_item(lx, ly, FLOOR_COLOR, "always_proceed floor (reference)", true);
    Plot {
        name: "tier_ladder".into(),
        title: title.into(),
        caption: format!(
            "Success per tier (1 plain, 2 {}, 3 {}). A model that acts on the instantaneous cue falls at tier 3 \
             where one that waits for a committed signal holds. Whiskers: 95% percentile bootstrap CIs over seeds; \
             dashed: the reference policies on each tier.",
            tier_mechanics(&scenarios, 0),
            tier_mechanics(&scenarios, 1)
        ),
        svg: svg.finish(title),
    }
}

/// What tier 2 (`tier` 0) or tier 3 (1) changes in each scenario the
/// figure draws, from their definitions: "delayed reveal / delayed
/// step-out / ...".
fn tier_mechanics(scenarios: &[ScenarioKind], tier: usize) -> String {
    scenarios.iter().map(|k| k.def().tier_mechanics[tier]).collect::<Vec<_>>().join(" / ")
}
