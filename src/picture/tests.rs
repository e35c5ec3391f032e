//! The picture's own tests: a PNG of the asked size, the same bytes under
//! both dispositions wherever the scene text is the same, positions read
//! back from its layout, and the legend the text's lines.

use super::*;
use crate::episode::Episode;
use crate::policy::PolicyKind;
use crate::scenario::{ScenarioSet, Tier};
use resvg::tiny_skia::Pixmap;

/// The expert's episode of a cell under `disposition`, one observation per
/// decision.
fn observations(
    kind: ScenarioKind,
    tier: Tier,
    seed: u64,
    disposition: crate::scenario::Disposition,
) -> Vec<Observation> {
    let set = ScenarioSet::default();
    let mut episode = Episode::with_disposition(set.get(kind), tier, seed, disposition);
    let mut expert = PolicyKind::Expert.build();
    let mut seen = Vec::new();
    while !episode.is_done() {
        let obs = *episode.observation();
        seen.push(obs);
        episode.step(expert.act(&obs));
    }
    seen
}

fn rgb(hex: &str) -> [u8; 3] {
    let v = u32::from_str_radix(&hex[1..], 16).unwrap();
    [(v >> 16) as u8, (v >> 8) as u8, v as u8]
}

#[test]
fn every_picture_is_a_png_of_the_asked_size() {
    for kind in ScenarioKind::ALL {
        for tier in Tier::ALL {
            let [a, _] = kind.def().dispositions;
            for obs in observations(kind, tier, 1, a).iter().step_by(4) {
                let png = png(obs).unwrap();
                assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"), "{kind}");
                let pixmap = Pixmap::decode_png(&png).unwrap();
                assert_eq!((pixmap.width(), pixmap.height()), (SIZE_PX, SIZE_PX), "{kind}");
            }
        }
    }
}

/// The picture is the observation's: wherever the two dispositions' scenes
/// read the same (every decision before the motion tells them apart), the
/// pictures are the same bytes.
#[test]
fn the_picture_is_the_same_under_both_dispositions_until_the_scene_differs() {
    for kind in ScenarioKind::ALL {
        for tier in Tier::ALL {
            for seed in 0..3 {
                let [a, b] = kind.def().dispositions;
                let (first, second) = (observations(kind, tier, seed, a), observations(kind, tier, seed, b));
                let mut same = 0;
                for (x, y) in first.iter().zip(&second) {
                    if crate::observation::render_scene(x) != crate::observation::render_scene(y) {
                        break;
                    }
                    assert_eq!(png(x).unwrap(), png(y).unwrap(), "{kind}/t{tier} seed {seed} turn {}", x.turn);
                    same += 1;
                }
                assert!(same >= 1, "{kind}/t{tier} seed {seed}");
            }
        }
    }
}

/// Positions read back from the picture's own layout: each road user's
/// pixel centre maps back to its metres within half a pixel, its centre's
/// place on the plan is the scene's figure as printed, and a car's box is
/// drawn there in its colour.
#[test]
fn positions_read_back_from_the_picture_within_half_a_pixel() {
    for kind in ScenarioKind::ALL {
        let view = view(kind).unwrap();
        let [a, _] = kind.def().dispositions;
        for obs in observations(kind, Tier::T1, 2, a).iter().step_by(3) {
            let placed = layout(obs);
            assert_eq!(placed.len(), 1 + obs.scene.tracks().len(), "{kind}");
            assert_eq!(placed[0].label, "You");
            let pixmap = Pixmap::decode_png(&png(obs).unwrap()).unwrap();
            for p in &placed {
                let back = view.to_m(p.centre_px);
                let off = ((back.0 - p.centre_m.0).hypot(back.1 - p.centre_m.1)) * view.px_per_m;
                assert!(off <= 0.5, "{kind}: {} {off} px", p.label);
                // Its box is drawn there in its colour: a third of the pixels
                // inside it (an arrow or another's trail may cross some),
                // where it is wholly in the road area and apart.
                let (hw, hl) = (0.5 * crate::sim::CAR_WIDTH - 0.3, 0.5 * crate::sim::CAR_LENGTH - 0.3);
                let (ax, ay) = (p.along.0.abs(), p.along.1.abs());
                let half = (hw * ay + hl * ax, hw * ax + hl * ay);
                let (lo, hi) = (
                    view.to_px((p.centre_m.0 - half.0, p.centre_m.1 + half.1)),
                    view.to_px((p.centre_m.0 + half.0, p.centre_m.1 - half.1)),
                );
                let inside = lo.0 > 0.0
                    && hi.0 < f64::from(SIZE_PX) - 160.0
                    && lo.1 > LEGEND_PX + 4.0
                    && hi.1 < f64::from(SIZE_PX) - 80.0;
                let alone = placed
                    .iter()
                    .filter(|q| q.label != p.label)
                    .all(|q| (q.centre_m.0 - p.centre_m.0).hypot(q.centre_m.1 - p.centre_m.1) > crate::sim::CAR_LENGTH);
                let car = p.label == "You" || kind.plan_axes().road_users[0].lateral.is_none();
                if inside && alone && car {
                    let want = rgb(p.fill);
                    let (mut matching, mut all) = (0, 0);
                    for x in lo.0.ceil() as u32..hi.0.floor() as u32 {
                        for y in lo.1.ceil() as u32..hi.1.floor() as u32 {
                            let px = pixmap.pixel(x, y).unwrap().demultiply();
                            let got = [px.red(), px.green(), px.blue()];
                            all += 1;
                            matching += usize::from(
                                got.iter().zip(want).all(|(g, w)| (i32::from(*g) - i32::from(w)).abs() <= 8),
                            );
                        }
                    }
                    assert!(
                        all > 0 && matching * 3 > all,
                        "{kind} turn {}: {} has {matching} of {all} pixels",
                        obs.turn,
                        p.label
                    );
                }
            }
        }
    }
}

#[test]
fn the_legend_lines_break_after_a_clause() {
    let lines =
        wrap("You: speed 8.7 m/s, acceleration -0.5 m/s^2, 24.1 m to the conflict zone, 47.4 m to your goal", 40);
    assert_eq!(
        lines,
        ["You: speed 8.7 m/s,", "acceleration -0.5 m/s^2,", "24.1 m to the conflict zone,", "47.4 m to your goal"]
    );
    assert_eq!(wrap("a b c", 3), ["a b", "c"]);
}

#[test]
fn the_legend_says_what_the_text_says() {
    for kind in ScenarioKind::ALL {
        let [a, _] = kind.def().dispositions;
        let obs = observations(kind, Tier::T2, 0, a)[3];
        let svg = svg(&obs).unwrap();
        let rounded = obs.rounded();
        let you = crate::observation::you_line(&rounded);
        for word in you.split(' ') {
            assert!(svg.contains(&crate::export::esc(word)), "{kind}: {word:?} not in the legend");
        }
        assert!(svg.contains(&crate::export::esc(&crate::observation::last_action_line(&rounded))), "{kind}");
        assert!(svg.contains(&format!("turn {} of {}", obs.turn, obs.turn_budget)), "{kind}");
        for name in kind.def().dispositions.map(|d| d.name()) {
            assert!(!svg.contains(name), "{kind}: the picture names a disposition");
        }
    }
}

/// The picture is a function of the scene text: the observation parsed
/// back from the text draws the same bytes (so a record's scene text is
/// enough to show its picture again), and the one line sent in its place
/// names the turn and no figure of the scene.
#[test]
fn the_scene_text_draws_the_same_picture() {
    for kind in ScenarioKind::ALL {
        for tier in Tier::ALL {
            let [a, _] = kind.def().dispositions;
            for obs in observations(kind, tier, 2, a).iter().step_by(3) {
                let text = crate::observation::render_scene(obs);
                let parsed = crate::observation::parse_scene(&text).unwrap();
                assert_eq!(png(&parsed).unwrap(), png(obs).unwrap(), "{kind}/t{tier} turn {}", obs.turn);
                let line = user_line(obs);
                assert!(line.starts_with(&format!("Turn {} of {}: ", obs.turn, obs.turn_budget)), "{line}");
                assert_eq!(line.contains("Readings: "), obs.reading_noise.is_some(), "{line}");
                assert!(!line.contains(" m/s,") && !line.contains("You:"), "{line}");
            }
        }
    }
}

/// The system prompt's paragraph: the scale of the scenario's own view,
/// and, without the text, the scene's name and situation, which the text
/// would have said.
#[test]
fn the_prompt_paragraph_states_the_scale_and_without_text_the_situation() {
    for kind in ScenarioKind::ALL {
        let alone = prompt_paragraph(kind, false);
        let beside = prompt_paragraph(kind, true);
        let scale = format!("{} pixels per metre", n(view(kind).unwrap().px_per_m));
        assert!(alone.contains(&scale) && beside.contains(&scale), "{kind}: {alone}");
        assert!(alone.contains(kind.situation()) && !beside.contains(kind.situation()), "{kind}");
        assert!(alone.contains(&format!("Scene: {}", kind.scene_name())), "{kind}");
    }
}
