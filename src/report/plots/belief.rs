//! The belief probe's figures (runs made with `eval --probe belief`): the
//! reliability diagram of every model's stated beliefs, and the belief
//! over time of chosen episodes next to the ideal observer's, with the
//! evidence turn marked. A report without probe runs has neither.

use super::{CEILING_COLOR, GRID, INK, Plot, PlotInput, Series, Svg, rate_axis_x, rate_axis_y};
use crate::export::f2;
use crate::report::drill::Loaded;

pub(crate) fn plots(input: &PlotInput) -> Vec<Plot> {
    let mut out = Vec::new();
    out.extend(reliability(input));
    out.extend(over_time(input));
    out
}

/// The series of the models that have belief metrics, with their pooled
/// summaries.
fn probed(input: &PlotInput) -> Vec<(Series, crate::belief::BeliefSummary)> {
    input
        .series()
        .into_iter()
        .filter_map(|s| {
            let model = input.data.models.iter().find(|m| m.label == s.label)?;
            Some((s, crate::report::probe_rows::pooled::<crate::metrics::BeliefProbe>(model)?))
        })
        .collect()
}

fn reliability(input: &PlotInput) -> Option<Plot> {
    let st = input.style;
    let models = probed(input);
    if models.is_empty() {
        return None;
    }
    // Lengths that hold text grow with it (paper style).
    let sp = |x: f64| st.space(x);
    let (left, top, size) = (sp(56.0), sp(40.0), 320.0);
    let legend_label =
        |m: &Series, s: &crate::belief::BeliefSummary| format!("{} (ECE {})", m.name, f2(s.calibration_error));
    // In a paper the legend is as wide as its longest label (marker, name and ECE).
    let legend_w = if st == super::Style::Paper {
        models.iter().map(|(m, s)| 17.0 + st.text_width(&legend_label(m, s), 11.0) + 10.0).fold(sp(200.0), f64::max)
    } else {
        models.iter().map(|(m, _)| st.text_width(&m.name, 11.0)).fold(170.0, f64::max) + 30.0
    };
    let mut svg = Svg::new(left + size + 30.0 + legend_w, top + size + sp(56.0), st);
    let title = "Belief calibration (reliability diagram, every turn)".to_string();
    svg.title(10.0, 20.0, &title, 14.0, 24.0);
    rate_axis_y(&mut svg, top, size, left, left + size);
    rate_axis_x(&mut svg, left, size, top, top + size);
    svg.line(left, top + size, left + size, top, INK, 1.2, Some("6 4"));
    svg.text(left + size / 2.0, top + size + sp(30.0), "stated belief (bin mean)", 11.0, "middle", "");
    let mid = top + size / 2.0;
    svg.text_up(sp(14.0), mid, "observed: the other let the ego pass", 11.0);
    let at = |b: f64, o: f64| (left + b.clamp(0.0, 1.0) * size, top + size - o.clamp(0.0, 1.0) * size);
    for (m, summary) in &models {
        let bins: Vec<_> = summary.reliability.iter().filter(|b| b.turns > 0).collect();
        let pts: Vec<(f64, f64)> = bins.iter().map(|b| at(b.mean_belief, b.observed)).collect();
        svg.polyline(&pts, m.color, 1.8, None);
        for (b, &(x, y)) in bins.iter().zip(&pts) {
            let tip = format!(
                "{}: belief {}-{} ({} turns): mean {}, observed {}",
                m.label,
                f2(b.lo),
                f2(b.hi),
                b.turns,
                f2(b.mean_belief),
                f2(b.observed)
            );
            svg.marker(m.shape, x, y, 4.0, m.color, INK, Some(&tip));
        }
    }
    let lx = left + size + 24.0;
    let mut y = top + sp(6.0);
    for (m, summary) in &models {
        svg.marker(m.shape, lx + 6.0, y - sp(4.0), 5.0, m.color, INK, None);
        svg.text_tip(lx + 17.0, y, &legend_label(m, summary), 11.0, "start", &m.label);
        y += sp(16.0);
    }
    svg.line(lx, y + sp(4.0), lx + 18.0, y + sp(4.0), INK, 1.2, Some("6 4"));
    svg.text(lx + 24.0, y + sp(8.0), "perfectly calibrated", 11.0, "start", "");
    Some(Plot {
        name: "belief_reliability".into(),
        title: title.clone(),
        caption: "Each point is a bin of 0.1 of the beliefs a model stated (P(the other road user lets the ego pass \
                  first)), pooled over every turn of its probe runs: x the mean belief in the bin, y how often the \
                  other did let the ego pass. On the diagonal a model is calibrated; a flat line at the base rate means \
                  its belief carries no information. ECE: turn-weighted mean distance from the diagonal."
            .into(),
        svg: svg.finish(&title),
    })
}

/// Episodes drawn over time: per model, up to two embedded transcripts
/// with stated beliefs and an evidence turn (the drill-down's order puts a
/// collision and a timeout first), at most [`MAX_PANELS`] in all.
const MAX_PANELS: usize = 6;

fn chosen<'a>(input: &'a PlotInput) -> Vec<&'a Loaded> {
    let mut out: Vec<&Loaded> = Vec::new();
    for (m, _) in input.data.models.iter().enumerate() {
        let of_model = input.transcripts.iter().filter(|l| {
            l.model == m && l.record.timing.evidence_turn.is_some() && l.record.turns.iter().any(|t| t.belief.is_some())
        });
        out.extend(of_model.take(2));
    }
    out.truncate(MAX_PANELS);
    out
}

fn over_time(input: &PlotInput) -> Option<Plot> {
    let st = input.style;
    let episodes = chosen(input);
    if episodes.is_empty() {
        return None;
    }
    let series = input.series();
    let sp = |x: f64| st.space(x);
    let (pw, ph, gap) = (330.0, 170.0, 24.0);
    let cols = episodes.len().min(2);
    let rows = episodes.len().div_ceil(2);
    let (top0, below) = (sp(56.0), sp(70.0));
    let mut svg = Svg::new(20.0 + cols as f64 * (pw + 60.0 + gap), top0 + rows as f64 * (ph + below) + 10.0, st);
    let title = "Belief over time: stated, ideal observer, evidence turn".to_string();
    svg.title(10.0, 20.0, &title, 14.0, 24.0);
    let mut x = 10.0;
    let ly = sp(40.0);
    x += svg.legend_item(x, ly, "#555", "stated belief (model colour)", false);
    x += svg.legend_item(x, ly, CEILING_COLOR, "ideal observer", true);
    svg.line(x, ly - 4.0, x + 18.0, ly - 4.0, "#c00", 1.5, Some("2 2"));
    svg.text(x + 22.0, ly, "evidence turn", 11.0, "start", "");
    for (k, l) in episodes.iter().enumerate() {
        let left = 60.0 + (k % 2) as f64 * (pw + 60.0 + gap);
        let top = top0 + sp(24.0) + (k / 2) as f64 * (ph + below);
        let label = &input.data.models[l.model].label;
        let color = series.iter().find(|s| &s.label == label).map_or("#555", |s| s.color);
        panel(&mut svg, l, label, color, (left, top, pw, ph));
    }
    Some(Plot {
        name: "belief_over_time".into(),
        title: title.clone(),
        caption: "Chosen episodes of probe runs: the model's stated belief that the other road user lets the ego \
                  pass first at each turn (gaps: probe parse errors), the ideal observer's (0.5 until the evidence \
                  turn, then the truth; a posterior on the noise tier) and the evidence turn, the first turn whose \
                  scene differed from the other disposition's."
            .into(),
        svg: svg.finish(&title),
    })
}

/// One episode's panel at (left, top, width, height).
fn panel(svg: &mut Svg, l: &Loaded, label: &str, color: &str, (left, top, w, h): (f64, f64, f64, f64)) {
    let r = &l.record;
    let last = r.turns.last().map_or(1, |t| t.turn).max(2);
    let at =
        |turn: u32, b: f64| (left + f64::from(turn - 1) / f64::from(last - 1) * w, top + h - b.clamp(0.0, 1.0) * h);
    let head = format!(
        "{} · {} t{} seed {} ({}, {})",
        super::display_name(label, false),
        r.scenario,
        r.tier,
        r.seed,
        r.disposition,
        r.outcome.name()
    );
    svg.text(left - 40.0, top - 8.0, &head, 11.0, "start", "");
    rate_axis_y(svg, top, h, left, left + w);
    for turn in (1..=last).filter(|t| t % 5 == 0 || *t == 1) {
        let (x, _) = at(turn, 0.0);
        svg.line(x, top, x, top + h, GRID, 1.0, None);
        svg.text(x, top + h + svg.style().space(13.0), &turn.to_string(), 10.0, "middle", "");
    }
    svg.text(left + w / 2.0, top + h + svg.style().space(28.0), "turn", 10.0, "middle", "");
    if let Some(e) = r.timing.evidence_turn.filter(|&e| e <= last) {
        let (x, _) = at(e, 0.0);
        svg.line(x, top, x, top + h, "#c00", 1.5, Some("2 2"));
    }
    let ideal: Vec<(f64, f64)> = r.turns.iter().filter_map(|t| Some(at(t.turn, t.ideal_belief?))).collect();
    svg.polyline(&ideal, CEILING_COLOR, 1.5, Some("5 3"));
    // Stated beliefs: a line through consecutive turns, broken at gaps.
    let mut run: Vec<(f64, f64)> = Vec::new();
    for t in &r.turns {
        match t.belief {
            Some(b) => {
                let (x, y) = at(t.turn, b);
                run.push((x, y));
                let tip = format!("turn {}: belief {}, ideal {}", t.turn, f2(b), t.ideal_belief.map_or("-".into(), f2));
                svg.circle(x, y, 2.5, color, "none", Some(&tip));
            }
            None => {
                svg.polyline(&run, color, 1.8, None);
                run.clear();
            }
        }
    }
    svg.polyline(&run, color, 1.8, None);
}
