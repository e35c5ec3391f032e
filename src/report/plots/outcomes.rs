//! Outcome decomposition: stacked bars of success, collision and timeout
//! per model, grouped by scenario.

use super::{COLLISION_COLOR, Plot, PlotInput, SUCCESS_COLOR, Style, Svg, TIMEOUT_COLOR};
use crate::report::tables::tiers_label;
use crate::scenario::ScenarioKind;

pub(crate) fn plot(input: &PlotInput) -> Plot {
    let st = input.style;
    let models = input.series();
    let scenarios: Vec<ScenarioKind> =
        ScenarioKind::ALL.into_iter().filter(|s| input.outcomes.iter().any(|r| r.scenario == *s)).collect();
    let label_w = models.iter().map(|m| st.text_width(&m.name, 11.0)).fold(60.0, f64::max) + 14.0;
    // Lengths that hold text grow with it; in a paper the bars are shorter
    // so that the figure fits a single column.
    let sp = |x: f64| st.space(x);
    let bar_w = if st == Style::Paper { 280.0 } else { 420.0 };
    let (row_h, head_h, top) = (sp(18.0), sp(24.0), sp(56.0));
    let rows = scenarios.len() as f64 * (head_h + models.len() as f64 * row_h);
    let mut svg = Svg::new(label_w + bar_w + 20.0, top + rows + sp(16.0), st);
    let title = format!("Outcome decomposition ({})", tiers_label(&input.leaderboard.tiers));
    svg.title(10.0, 20.0, &title, 14.0, sp(24.0));
    let mut lx = label_w;
    for (c, l) in [(SUCCESS_COLOR, "success"), (COLLISION_COLOR, "collision"), (TIMEOUT_COLOR, "timeout")] {
        lx += svg.legend_item(lx, sp(42.0), c, l, false);
    }
    let mut y = top;
    for s in &scenarios {
        svg.text(label_w, y + sp(16.0), &s.to_string(), 12.0, "start", " font-weight=\"bold\"");
        y += head_h;
        for m in &models {
            if let Some(r) = input.outcomes.iter().find(|r| r.model == m.label && r.scenario == *s) {
                let mut x = label_w;
                for (v, c, l) in [
                    (r.success_rate, SUCCESS_COLOR, "success"),
                    (r.collision_rate, COLLISION_COLOR, "collision"),
                    (r.timeout_rate, TIMEOUT_COLOR, "timeout"),
                ] {
                    let w = if v.is_finite() { v * bar_w } else { 0.0 };
                    let tip = format!("{} on {s}: {l} {:.0}% of {} episodes", m.label, v * 100.0, r.episodes);
                    svg.rect_tip(x, y + 2.0, w, row_h - 4.0, c, &tip);
                    if w >= sp(30.0) {
                        svg.text(
                            x + w / 2.0,
                            y + row_h - sp(5.0),
                            &format!("{:.0}%", v * 100.0),
                            10.0,
                            "middle",
                            " fill=\"#fff\"",
                        );
                    }
                    x += w;
                }
            }
            svg.text_tip(label_w - 8.0, y + row_h - sp(5.0), &m.name, 11.0, "end", &m.label);
            y += row_h;
        }
    }
    Plot {
        name: "outcomes".into(),
        title: title.clone(),
        caption: "Share of episodes ending in success, collision and timeout. Timeouts are over-caution (stalling, \
                  endless nudging); collisions are over-assertion."
            .into(),
        svg: svg.finish(&title),
    }
}
