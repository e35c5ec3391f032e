//! Evidence timing figures: per scenario, each model's guess rate (Wilson
//! whiskers) and evidence-to-commitment lag, the expert's as a grey dashed
//! reference line; and success against guess rate (which models win by
//! luck), the expert's points hollow grey.

use super::{FLOOR_COLOR, GRID, INK, Plot, PlotInput, Series, Svg, rate_axis_x, rate_axis_y};
use crate::export::f2;
use crate::report::reference::CEILING;
use crate::report::tables::tiers_label;
use crate::report::timing::TimingRow;
use crate::scenario::ScenarioKind;

/// The references' colour here: grey, never a model's hue.
const REFERENCE: &str = FLOOR_COLOR;

pub(crate) fn plots(input: &PlotInput) -> Vec<Plot> {
    if input.timing.is_empty() {
        return Vec::new();
    }
    vec![panels(input), success_vs_guess(input)]
}

fn scenarios(rows: &[TimingRow]) -> Vec<ScenarioKind> {
    ScenarioKind::ALL.into_iter().filter(|s| rows.iter().any(|r| r.scenario == *s)).collect()
}

/// A tidy axis maximum for lags: the next multiple of 2 turns above every
/// value (at least 2).
fn lag_axis_max(rows: &[TimingRow]) -> f64 {
    let most = rows
        .iter()
        .flat_map(|r| [r.evidence_lag, r.expert_evidence_lag.unwrap_or(0.0)])
        .filter(|x| x.is_finite())
        .fold(0.0, f64::max);
    ((most / 2.0).floor() + 1.0) * 2.0
}

/// Two rows of panels (guess rate, then lag), one column per scenario,
/// one line per model; the expert's value is a dashed grey line.
fn panels(input: &PlotInput) -> Plot {
    let st = input.style;
    let rows = input.timing;
    let models = input.series();
    let scen = scenarios(rows);
    let label_w = models.iter().map(|m| st.text_width(&m.name, 11.0)).fold(60.0, f64::max) + 12.0;
    // Lengths that hold text grow with it (paper style).
    let sp = |x: f64| st.space(x);
    let (pw, gap, row_h) = (200.0, sp(26.0), sp(20.0));
    let block = models.len() as f64 * row_h;
    let (top1, top2) = (sp(62.0), sp(62.0) + block + sp(70.0));
    // Too many scenarios for a paper's width wrap onto another band of both rows.
    let per_row = super::panels_per_row(st, scen.len(), label_w, pw, gap);
    let bands = scen.len().max(1).div_ceil(per_row);
    let band = top2 + block + sp(40.0) - sp(20.0);
    let width = label_w + per_row as f64 * (pw + gap) + 10.0;
    let height = top2 + block + sp(40.0) + (bands - 1) as f64 * band;
    let mut svg = Svg::new(width.max(label_w + sp(420.0)), height, st);
    let title = format!("Evidence timing by scenario ({})", tiers_label(&input.leaderboard.tiers));
    svg.title(10.0, 18.0, &title, 14.0, sp(24.0));
    let lag_max = lag_axis_max(rows);
    for (p, s) in scen.iter().enumerate() {
        let x0 = label_w + (p % per_row) as f64 * (pw + gap);
        let shift = (p / per_row) as f64 * band;
        let (top1, top2) = (top1 + shift, top2 + shift);
        svg.text(x0 + pw / 2.0, shift + sp(36.0), &s.to_string(), 12.0, "middle", " font-weight=\"bold\"");
        let cell = |m: &Series| rows.iter().find(|r| r.model == m.label && r.scenario == *s);
        // Guess rate, [0, 1].
        rate_axis_x(&mut svg, x0, pw, top1 - 6.0, top1 + block);
        let expert = rows.iter().find(|r| r.scenario == *s).and_then(|r| r.expert_guess_rate);
        reference_line(&mut svg, expert.map(|v| x0 + v.clamp(0.0, 1.0) * pw), top1, block);
        for (i, m) in models.iter().enumerate() {
            let Some(r) = cell(m).filter(|r| r.committed > 0) else { continue };
            let y = top1 + (i as f64 + 0.5) * row_h;
            let x = |v: f64| x0 + v.clamp(0.0, 1.0) * pw;
            let g = r.guess_rate;
            if g.lo.is_finite() && g.hi.is_finite() {
                svg.line(x(g.lo), y, x(g.hi), y, m.color, 2.0, None);
            }
            let tip =
                format!("{}: guess rate {} ({} of {} committed)", m.label, f2(g.estimate), r.guesses, r.committed);
            svg.marker(m.shape, x(g.estimate), y, 4.5, m.color, INK, Some(&tip));
        }
        // Lag, [0, lag_max] turns.
        for k in 0..=4 {
            let v = lag_max * f64::from(k) / 4.0;
            let x = x0 + f64::from(k) / 4.0 * pw;
            svg.line(x, top2 - 6.0, x, top2 + block, GRID, 1.0, None);
            svg.text(x, top2 + block + sp(13.0), &format!("{}", (v * 10.0).round() / 10.0), 10.0, "middle", "");
        }
        let expert = rows.iter().find(|r| r.scenario == *s).and_then(|r| r.expert_evidence_lag);
        reference_line(&mut svg, expert.map(|v| x0 + (v / lag_max).clamp(0.0, 1.0) * pw), top2, block);
        for (i, m) in models.iter().enumerate() {
            let Some(r) = cell(m).filter(|r| r.evidence_lag.is_finite()) else { continue };
            let y = top2 + (i as f64 + 0.5) * row_h;
            let x = x0 + (r.evidence_lag / lag_max).clamp(0.0, 1.0) * pw;
            svg.line(x0, y, x, y, m.color, 2.0, None);
            let tip = format!("{}: lag {} turns", m.label, f2(r.evidence_lag));
            svg.marker(m.shape, x, y, 4.5, m.color, INK, Some(&tip));
        }
    }
    for shift in (0..bands).map(|b| b as f64 * band) {
        let (top1, top2) = (top1 + shift, top2 + shift);
        for (i, m) in models.iter().enumerate() {
            for top in [top1, top2] {
                svg.text_tip(label_w - 8.0, top + (i as f64 + 0.5) * row_h + sp(4.0), &m.name, 11.0, "end", &m.label);
            }
        }
        svg.text(
            label_w,
            top1 + block + sp(30.0),
            "guess rate (committed before the evidence; whisker: 95% Wilson)",
            10.0,
            "start",
            "",
        );
        svg.text(label_w, top2 + block + sp(30.0), "evidence-to-commitment lag (turns)", 10.0, "start", "");
    }
    svg.line(label_w + sp(300.0), sp(50.0), label_w + sp(300.0) + 18.0, sp(50.0), REFERENCE, 1.6, Some("5 3"));
    svg.text(
        label_w + sp(300.0) + 22.0,
        sp(54.0),
        "expert (reference)",
        10.0,
        "start",
        &format!(" fill=\"{REFERENCE}\""),
    );
    Plot {
        name: "evidence_timing".into(),
        title: title.clone(),
        caption: "Top: share of the committed episodes whose commitment came before the evidence turn (a guess), with \
                  95% Wilson whiskers. Bottom: mean turns from the evidence to the commitment over the other episodes. \
                  Dashed grey: the expert (reference, from the baseline table)."
            .into(),
        svg: svg.finish(&title),
    }
}

fn reference_line(svg: &mut Svg, x: Option<f64>, top: f64, block: f64) {
    if let Some(x) = x {
        svg.line(x, top - 6.0, x, top + block, REFERENCE, 1.6, Some("5 3"));
    }
}

/// Success against guess rate, one point per (model, scenario): points
/// high and right won by guessing.
fn success_vs_guess(input: &PlotInput) -> Plot {
    let st = input.style;
    let rows = input.timing;
    let models = input.series();
    let scen = scenarios(rows);
    let sp = |x: f64| st.space(x);
    let (left, top, size) = (sp(56.0), sp(40.0), 300.0);
    let legend_w = models.iter().map(|m| st.text_width(&m.name, 11.0)).fold(sp(140.0), f64::max) + sp(40.0);
    let mut svg = Svg::new(left + size + 30.0 + legend_w, top + size + sp(60.0), st);
    let title = format!("Success vs guess rate ({})", tiers_label(&input.leaderboard.tiers));
    svg.title(10.0, 20.0, &title, 14.0, sp(24.0));
    rate_axis_y(&mut svg, top, size, left, left + size);
    rate_axis_x(&mut svg, left, size, top, top + size);
    svg.text(left + size / 2.0, top + size + sp(32.0), "guess rate", 11.0, "middle", "");
    let mid = top + size / 2.0;
    svg.text_up(sp(14.0), mid, "success", 11.0);
    let at = |g: f64, s: f64| (left + g.clamp(0.0, 1.0) * size, top + size - s.clamp(0.0, 1.0) * size);
    let shape_of = |k: usize, m: &Series| if models.iter().all(|m| m.shape == 0) { k } else { m.shape };
    for (k, s) in scen.iter().enumerate() {
        let tiers = &input.leaderboard.tiers;
        if let (Some(g), Some(sr)) = (input.refs.guess_rate(CEILING, *s, tiers), input.refs.success(CEILING, *s, tiers))
        {
            let (x, y) = at(g, sr);
            let tip = format!("expert on {s}: success {}, guess rate {}", f2(sr), f2(g));
            svg.marker(k, x, y, 5.0, "none", REFERENCE, Some(&tip));
        }
    }
    svg.open_group("fill-opacity=\"0.7\"");
    for r in rows.iter().filter(|r| r.committed > 0) {
        let (Some(m), Some(k)) =
            (models.iter().find(|m| m.label == r.model), scen.iter().position(|s| *s == r.scenario))
        else {
            continue;
        };
        let (x, y) = at(r.guess_rate.estimate, r.success);
        let (jx, jy) = super::jitter(&format!("{}/{}", r.model, r.scenario), 3.0);
        let tip = format!(
            "{} on {}: success {}, guess rate {}",
            m.label,
            r.scenario,
            f2(r.success),
            f2(r.guess_rate.estimate)
        );
        svg.marker(shape_of(k, m), x + jx, y + jy, 5.0, m.color, INK, Some(&tip));
    }
    svg.close_group();
    let (lx, mut y) = (left + size + 24.0, top + sp(6.0));
    for m in &models {
        svg.marker(m.shape, lx + 6.0, y - sp(4.0), 5.0, m.color, INK, None);
        svg.text_tip(lx + 17.0, y, &m.name, 11.0, "start", &m.label);
        y += sp(16.0);
    }
    y += sp(8.0);
    if models.iter().all(|m| m.shape == 0) {
        for (k, s) in scen.iter().enumerate() {
            svg.marker(k, lx + 6.0, y - sp(4.0), 5.0, "#777", INK, None);
            svg.text(lx + 17.0, y, &s.to_string(), 11.0, "start", "");
            y += sp(16.0);
        }
    }
    svg.circle(lx + 6.0, y + sp(4.0), 5.0, "none", REFERENCE, None);
    svg.text(lx + 17.0, y + sp(8.0), "expert (reference, hollow)", 11.0, "start", "");
    Plot {
        name: "success_vs_guess_rate".into(),
        title: title.clone(),
        caption:
            "Each point is a model on a scenario: x the share of its committed episodes that committed before the \
                  evidence, y its success. High and right: wins by guessing (luck); the expert (hollow grey) commits \
                  after the evidence."
                .into(),
        svg: svg.finish(&title),
    }
}
