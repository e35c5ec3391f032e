//! What the person sees, drawn with ratatui from one [`Screen`] value (so
//! a test can draw it at 80x24 and compare). By default the screen holds
//! the scene text the model receives and nothing more: the turn counters
//! are in that text, and the person's own last action too. Only
//! `--view plan` adds a drawing (more than the model sees). No colour is
//! needed: emphasis is bold and reversed video.

use super::input::Draft;
use crate::observation::Observation;
use ratatui::Frame;
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Modifier, Style};
use ratatui::text::{Line, Span, Text};
use ratatui::widgets::canvas::Canvas;
use ratatui::widgets::{Block, Borders, Clear, Paragraph, Wrap};

/// Everything on the screen.
#[derive(Debug, Clone, Default)]
pub(crate) struct Screen {
    pub name: String,
    /// "episode 3 of 18", "untimed" or the seconds left.
    pub progress: String,
    pub clock: Option<String>,
    /// The scene of the turn waiting for an answer.
    pub scene: Option<String>,
    /// The same scene, parsed, for the plan view (`--view plan` only).
    pub plan: Option<Observation>,
    pub draft: Draft,
    /// A JSON action being typed.
    pub typing: Option<String>,
    /// A message between turns: "episode over", feedback, "time ran out".
    pub notice: Option<String>,
    /// A one-line message on the answer line ("time ran out").
    pub flash: Option<String>,
    pub help: bool,
    pub help_text: String,
    /// Lines scrolled off the top of the scene.
    pub scroll: u16,
}

const KEYS: &str = "p/n/y/s maneuver  0-9 or arrows strength  Enter send  { JSON  ? help  q quit";

pub(crate) fn draw(frame: &mut Frame, s: &Screen) {
    let [top, main, answer, keys] =
        Layout::vertical([Constraint::Length(1), Constraint::Min(3), Constraint::Length(1), Constraint::Length(1)])
            .areas(frame.area());
    let clock = s.clock.as_deref().unwrap_or("untimed");
    frame.render_widget(
        Paragraph::new(Line::from(vec![
            Span::styled(" negotiator play ", Style::default().add_modifier(Modifier::REVERSED)),
            Span::raw(format!(" {} | {} | {clock}", s.name, s.progress)),
        ])),
        top,
    );
    let (text_area, plan_area) = match s.plan {
        Some(_) => {
            let [t, p] = Layout::horizontal([Constraint::Min(40), Constraint::Length(30)]).areas(main);
            (t, Some(p))
        }
        None => (main, None),
    };
    let body = match (&s.notice, &s.scene) {
        (Some(notice), _) => Text::from(format!("{notice}\n\nPress Enter to go on.")),
        (None, Some(scene)) => Text::from(scene.as_str()),
        (None, None) => Text::from("Waiting for the next scene..."),
    };
    frame.render_widget(Paragraph::new(body).wrap(Wrap { trim: false }).scroll((s.scroll, 0)), text_area);
    if let (Some(area), Some(o)) = (plan_area, s.plan.as_ref()) {
        draw_plan(frame, area, o);
    }
    let answer_text = match (&s.typing, &s.flash) {
        (Some(t), _) => format!("> {t}_"),
        (None, Some(f)) => format!("> {} {:.2}   ({f})", s.draft.maneuver, s.draft.strength),
        (None, None) => format!("> {} {:.2}   (Enter sends)", s.draft.maneuver, s.draft.strength),
    };
    frame.render_widget(Paragraph::new(answer_text).style(Style::default().add_modifier(Modifier::BOLD)), answer);
    frame.render_widget(Paragraph::new(KEYS), keys);
    if s.help {
        let area = main.inner(ratatui::layout::Margin { horizontal: 1, vertical: 0 });
        frame.render_widget(Clear, area);
        frame.render_widget(
            Paragraph::new(s.help_text.as_str())
                .wrap(Wrap { trim: false })
                .scroll((s.scroll, 0))
                .block(Block::default().borders(Borders::ALL).title(" help: ? closes, PgUp/PgDn scroll ")),
            area,
        );
    }
}

/// A small plan view of the scene (`--view plan`): the ego `E`, the other
/// road users by their first letter, and the conflict, to scale along each
/// road. Drawn from the parsed scene text, so it shows the same numbers as
/// a picture.
fn draw_plan(frame: &mut Frame, area: Rect, o: &Observation) {
    let canvas = Canvas::default()
        .block(Block::default().borders(Borders::ALL).title(" plan "))
        .marker(ratatui::symbols::Marker::Dot)
        .x_bounds([-40.0, 40.0])
        .y_bounds([-40.0, 40.0])
        .paint(|ctx| {
            // Drawn from the scenario's plan axes, not from which scenario it is.
            let kind = o.scene.kind();
            let axes = kind.plan_axes();
            let relative = kind.def().tracks_relative_to_ego;
            let d = o.scene.ego_to_conflict_m();
            let at = |x: f64| x.clamp(-38.0, 38.0);
            let road = |ctx: &mut ratatui::widgets::canvas::Context, x1, y1, x2, y2| {
                ctx.draw(&ratatui::widgets::canvas::Line::new(x1, y1, x2, y2, ratatui::style::Color::Reset));
            };
            if relative {
                // The ego stays put; the road users and the merge point move past it.
                road(ctx, -40.0, 0.0, 40.0, 0.0);
                ctx.print(0.0, -6.0, "E");
                ctx.print(at(d), -3.0, "|");
            } else if axes.ego_along_y {
                road(ctx, -40.0, 0.0, 40.0, 0.0);
                road(ctx, 0.0, -40.0, 0.0, 0.0);
                ctx.print(0.0, at(-d), "E");
            } else {
                ctx.print(at(-d), 3.0, "E");
            }
            for (k, track) in o.scene.tracks().iter().enumerate() {
                let letter: String = axes.role(k).chars().next().map(|c| c.to_ascii_uppercase()).into_iter().collect();
                let position = track.now.position_m;
                match axes.road_users.get(k).and_then(|u| u.lateral) {
                    // Across the ego's road, two canvas units to the metre, from the kerbs.
                    Some(frame) => {
                        for (mark, _) in frame.marks {
                            road(ctx, -40.0, -2.0 + 2.0 * mark, 40.0, -2.0 + 2.0 * mark);
                        }
                        // Side by side along the crossing, the first nearest the ego.
                        ctx.print(3.0 * k as f64, at(-2.0 + 2.0 * position), letter);
                    }
                    None => ctx.print(at(position), if relative { 3.0 } else { 2.0 }, letter),
                }
            }
        });
    frame.render_widget(canvas, area);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode::Episode;
    use crate::observation::render_scene;
    use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
    use ratatui::Terminal;
    use ratatui::backend::TestBackend;

    fn screen_text(s: &Screen) -> String {
        let mut t = Terminal::new(TestBackend::new(80, 24)).unwrap();
        t.draw(|f| draw(f, s)).unwrap();
        let buffer = t.backend().buffer().clone();
        let mut out = String::new();
        for y in 0..24 {
            let line: String = (0..80).map(|x| buffer[(x, y)].symbol().to_string()).collect();
            out.push_str(line.trim_end());
            out.push('\n');
        }
        out
    }

    fn first_scene(kind: ScenarioKind) -> String {
        let set = ScenarioSet::default();
        render_scene(Episode::new(set.get(kind), Tier::T1, 0).observation())
    }

    #[test]
    fn the_screen_fits_80x24_and_shows_the_whole_scene() {
        for kind in ScenarioKind::ALL {
            let scene = first_scene(kind);
            let s = Screen {
                name: "ada".into(),
                progress: "episode 1 of 18".into(),
                scene: Some(scene.clone()),
                ..Screen::default()
            };
            let text = screen_text(&s);
            // Every word of the scene is on the screen (wrapping aside).
            let shown: String = text.split_whitespace().collect::<Vec<_>>().join(" ");
            let wanted: String = scene.split_whitespace().collect::<Vec<_>>().join(" ");
            assert!(shown.contains(&wanted), "{kind}:\n{text}");
        }
    }

    #[test]
    fn the_yield_screen_at_80x24() {
        let s = Screen {
            name: "ada".into(),
            progress: "episode 1 of 18".into(),
            scene: Some(first_scene(ScenarioKind::YieldStandoff)),
            ..Screen::default()
        };
        insta::assert_snapshot!(screen_text(&s));
    }

    /// The plan view alone, as text.
    fn plan_text(o: &Observation) -> String {
        let mut t = Terminal::new(TestBackend::new(40, 20)).unwrap();
        t.draw(|f| draw_plan(f, f.area(), o)).unwrap();
        let buffer = t.backend().buffer().clone();
        (0..20).map(|y| (0..40).map(|x| buffer[(x, y)].symbol().to_string()).collect::<String>() + "\n").collect()
    }

    #[test]
    fn the_plan_view_places_every_road_user_and_hides_the_disposition() {
        let set = ScenarioSet::default();
        for kind in ScenarioKind::ALL {
            let config = set.get(kind);
            let [a, b] = kind.dispositions();
            for seed in 0..10 {
                let first = |d| *Episode::with_disposition(config, Tier::T1, seed, d).observation();
                let text = plan_text(&first(a));
                assert_eq!(text, plan_text(&first(b)), "{kind} seed {seed}");
                let letters: Vec<String> = (0..kind.plan_axes().road_users.len())
                    .map(|k| kind.plan_axes().role(k)[..1].to_uppercase())
                    .collect();
                for letter in letters.iter().map(String::as_str).chain(["E"]) {
                    assert!(text.contains(letter), "{kind} seed {seed}: no {letter} in\n{text}");
                }
            }
        }
    }
}
