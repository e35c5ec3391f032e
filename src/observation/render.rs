//! The scene text a language model reads each turn. Every number it prints
//! is parsed back by `parse_scene`, so the text alone carries the public
//! observation (to the printed precision).

use super::{Observation, Track, round_to};
use crate::scenario::TrackLabel;
use std::fmt::Write;

/// Format with one decimal, never "-0.0".
pub(super) fn f1(x: f64) -> String {
    Fixed(x, 1).to_string()
}

/// `Fixed(x, N)` displays as `format!("{:.N$}", round_to(x, N))`, written
/// from the rounded integer `round(x * 10^N)` on the stack instead of
/// through the float formatter (whose exact path, flt2dec's grisu and
/// dragon, showed in `env-server`'s profile, as did one small allocation per
/// number: the scene is rendered every turn by `eval`, `serve` and
/// `env-server`). The same text: `round_to` yields the double nearest
/// `k / 10^N`, whose N-decimal rendering is `k`'s digits. Values whose `k` a
/// double cannot hold exactly (and NaN, infinities) take the formatter.
struct Fixed(f64, i32);

impl std::fmt::Display for Fixed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let Fixed(x, digits) = *self;
        let scaled = x * 10f64.powi(digits);
        if scaled.is_nan() || scaled.abs() >= 1e15 {
            return write!(f, "{:.*}", digits as usize, round_to(x, digits));
        }
        // `scaled.round()` (half away from zero) without libm's call: the
        // truncation is exact here, and so is the fraction it leaves.
        let whole = scaled as i64;
        let fraction = scaled - whole as f64;
        let k = whole + i64::from(fraction >= 0.5) - i64::from(fraction <= -0.5);
        f.write_str(fixed_point(k, digits as u32, &mut [0; 24]))
    }
}

/// `k / 10^decimals` written with exactly `decimals` decimals ("-0.05"
/// for k = -5 and two decimals), into `buffer`: what `Fixed` and
/// `env-server`'s number writer print once they hold the whole number.
pub(crate) fn fixed_point(k: i64, decimals: u32, buffer: &mut [u8; 24]) -> &str {
    // At most 19 digits, a leading zero, a point and a sign.
    let mut at = buffer.len();
    let mut push = |byte: u8| {
        at -= 1;
        buffer[at] = byte;
    };
    let mut m = k.unsigned_abs();
    for _ in 0..decimals {
        push(b'0' + (m % 10) as u8);
        m /= 10;
    }
    push(b'.');
    loop {
        push(b'0' + (m % 10) as u8);
        m /= 10;
        if m == 0 {
            break;
        }
    }
    if k < 0 {
        push(b'-');
    }
    std::str::from_utf8(&buffer[at..]).expect("ASCII digits")
}

/// The road user's two lines, keyed by its label's `now` and `history` (the
/// keys the parser reads back); `now` formats the current sample, e.g.
/// "21.0 m to the conflict zone, speed 9.4 m/s".
fn track_lines(out: &mut String, label: &TrackLabel, t: &Track, now: impl Fn(&str, &str) -> String) {
    let _ = writeln!(out, "{}: {}", label.now, now(&f1(t.now.position_m), &f1(t.now.velocity_mps)));
    let _ = write!(out, "{}: ", label.history);
    for (i, s) in t.past.iter().enumerate() {
        let separator = if i == 0 { "" } else { "; " };
        let _ = write!(out, "{separator}{} m at {} m/s", Fixed(s.position_m, 1), Fixed(s.velocity_mps, 1));
    }
    out.push('\n');
}

/// Render an observation as the scene text of one user turn.
pub fn render_scene(obs: &Observation) -> String {
    let mut out = String::with_capacity(900);
    let kind = obs.scenario();
    // The scene is named by its geometry only: a scenario name such as
    // "pedestrian_feint" would tell the model which behaviour to expect.
    let _ = writeln!(out, "Scene: {}", obs.scenario().scene_name());
    let _ = writeln!(out, "Situation: {}", kind.situation());
    if let Some(n) = obs.reading_noise {
        let _ = writeln!(
            out,
            "Readings: the other road users' positions and speeds carry random noise of {} m and {} m/s (one standard deviation, drawn afresh each turn); your own are exact.",
            Fixed(n.position_sd_m, 1),
            Fixed(n.speed_sd_mps, 1)
        );
    }
    let _ = writeln!(out, "Time: {} s", Fixed(obs.time_s, 1));
    let _ = writeln!(
        out,
        "Turn: {} of {} ({} left including this one; each action is held for 0.5 s)",
        obs.turn,
        obs.turn_budget,
        obs.turns_left()
    );
    out.push_str(&you_line(obs));
    out.push('\n');
    for (label, track) in kind.track_labels().iter().zip(obs.scene.tracks()) {
        track_lines(&mut out, label, track, |p, v| kind.track_now(p, v));
    }
    out.push_str(&last_action_line(obs));
    out.push('\n');
    out
}

/// The scene's "You:" line (without its newline): what the picture's
/// legend says too, word for word.
pub(crate) fn you_line(obs: &Observation) -> String {
    let e = &obs.ego;
    let place = obs.scene.place_text(f1);
    let mut line = format!(
        "You: speed {} m/s, acceleration {} m/s^2, {place}, {} m to your goal, speed limit {} m/s",
        Fixed(e.speed_mps, 1),
        Fixed(e.accel_mps2, 1),
        Fixed(e.to_goal_m, 1),
        Fixed(e.speed_limit_mps, 1)
    );
    if let Some(ahead) = e.speed_limit_ahead_mps {
        let _ = write!(line, " ({} m/s on the road you join)", Fixed(ahead, 1));
    }
    line
}

/// The scene's last-action line (without its newline).
pub(crate) fn last_action_line(obs: &Observation) -> String {
    match obs.last_action {
        Some(a) => {
            format!("Your last action: {}, acceleration {}", a.maneuver, Fixed(a.acceleration.clamp(-1.0, 1.0), 2))
        }
        None => "Your last action: none (first turn)".to_string(),
    }
}

#[cfg(test)]
mod fixed_tests {
    use super::*;
    use proptest::prelude::*;

    fn fixed(x: f64, digits: i32) -> String {
        Fixed(x, digits).to_string()
    }

    fn formatter(x: f64, digits: i32) -> String {
        format!("{:.*}", digits as usize, round_to(x, digits))
    }

    #[test]
    fn fixed_matches_the_formatter_at_the_edges() {
        for x in [
            0.0,
            -0.0,
            0.05,
            -0.05,
            0.25,
            -0.25,
            0.15,
            1.45,
            -1.45,
            2.675,
            1e14,
            -1e14,
            1e300,
            f64::NAN,
            f64::INFINITY,
            -f64::INFINITY,
            123456.789,
        ] {
            for d in [1, 2] {
                assert_eq!(fixed(x, d), formatter(x, d), "{x} {d}");
            }
        }
    }

    proptest! {
        #[test]
        fn fixed_matches_the_formatter(x in -1.0e6f64..1.0e6, d in 1i32..=2) {
            prop_assert_eq!(fixed(x, d), formatter(x, d));
        }

        #[test]
        fn fixed_matches_the_formatter_on_any_double(bits in any::<u64>(), d in 1i32..=2) {
            let x = f64::from_bits(bits);
            prop_assert_eq!(fixed(x, d), formatter(x, d));
        }
    }
}
