//! Figure styles: the one place that says how big the figures' text is,
//! whether a figure carries its title, and at what width it is meant to be
//! printed. Figures write every size as the default style's pixels (11 for
//! a label, 10 for a tick, ...); [`Style::font`] maps them.
//!
//! `paper`: every text is at least [`MIN_PRINT_PT`] when the figure is
//! printed at its declared width (3.3 in single column or 7 in double
//! column, the narrowest at which that holds), no title (the caption goes
//! in LaTeX), and a PDF of each figure beside its SVG.

use std::fmt;
use std::str::FromStr;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Style {
    /// For the screen and report.html (the figures as they always were).
    #[default]
    Default,
    /// For a paper: larger text, no titles, a print width, PDFs.
    Paper,
}

/// The smallest text in a printed paper-style figure, in points.
pub const MIN_PRINT_PT: f64 = 8.0;

/// Text in paper style is this much larger than in the default style ...
const PAPER_SCALE: f64 = 1.3;
/// ... and never smaller than this (pixels of the figure's viewBox): at
/// 7 in (504 pt) a figure up to 945 px wide prints it at 8 pt, at 3.3 in
/// (237.6 pt) one up to 445 px wide.
const PAPER_MIN_PX: f64 = 15.0;

/// The print widths a paper figure can declare, narrowest first: a single
/// column and a double column (inches), as in two-column conference
/// templates.
pub const PRINT_WIDTHS_IN: [f64; 2] = [3.3, 7.0];

impl Style {
    pub const NAMES: [&str; 2] = ["default", "paper"];

    /// The size in pixels of a text written at `base` pixels in the default style.
    pub fn font(self, base: f64) -> f64 {
        match self {
            Style::Default => base,
            Style::Paper => (base * PAPER_SCALE).max(PAPER_MIN_PX),
        }
    }

    /// Approximate width in pixels of `s` written at `base` (default-style pixels).
    pub fn text_width(self, s: &str, base: f64) -> f64 {
        super::text_width(s, self.font(base))
    }

    /// A length that holds text (a row, a line of a legend, a gap below a
    /// tick label) grows with the text: `base` pixels in the default style.
    pub fn space(self, base: f64) -> f64 {
        base * self.font(11.0) / 11.0
    }

    /// The widest figure (pixels) whose text still prints at
    /// [`MIN_PRINT_PT`] at the widest print width; `None`: no limit.
    pub fn max_width(self) -> Option<f64> {
        match self {
            Style::Default => None,
            Style::Paper => Some(PAPER_MIN_PX * PRINT_WIDTHS_IN[PRINT_WIDTHS_IN.len() - 1] * 72.0 / MIN_PRINT_PT),
        }
    }

    /// Does a figure carry its title?
    pub fn titled(self) -> bool {
        self == Style::Default
    }

    /// Is a PDF written beside each SVG?
    pub fn pdf(self) -> bool {
        self == Style::Paper
    }

    /// The print width (inches) a paper figure `width_px` wide whose
    /// smallest text is `min_font_px` declares: the narrowest at which that
    /// text is at least [`MIN_PRINT_PT`], else the widest (the figure is
    /// then too wide for its text, which the figure tests catch).
    pub fn print_width_in(width_px: f64, min_font_px: f64) -> f64 {
        PRINT_WIDTHS_IN
            .into_iter()
            .find(|w| min_font_px * w * 72.0 / width_px >= MIN_PRINT_PT)
            .unwrap_or(PRINT_WIDTHS_IN[PRINT_WIDTHS_IN.len() - 1])
    }
}

impl fmt::Display for Style {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Style::Default => "default",
            Style::Paper => "paper",
        })
    }
}

#[derive(Debug, thiserror::Error)]
#[error("unknown style '{0}' (expected default or paper)")]
pub struct UnknownStyle(pub String);

impl FromStr for Style {
    type Err = UnknownStyle;
    fn from_str(s: &str) -> Result<Style, UnknownStyle> {
        match s.trim() {
            "default" => Ok(Style::Default),
            "paper" => Ok(Style::Paper),
            other => Err(UnknownStyle(other.to_string())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_sizes_are_unchanged_and_paper_text_prints_at_8_pt() {
        for base in [9.0, 9.5, 10.0, 11.0, 12.0, 14.0] {
            assert_eq!(Style::Default.font(base), base);
            assert!(Style::Paper.font(base) >= PAPER_MIN_PX && Style::Paper.font(base) >= base);
        }
        // 15 px text: a 445 px figure fits a single column, a 900 px one needs two, a 1000 px one fits neither.
        assert_eq!(Style::print_width_in(445.0, 15.0), 3.3);
        assert_eq!(Style::print_width_in(446.0, 15.0), 7.0);
        assert_eq!(Style::print_width_in(945.0, 15.0), 7.0);
        // Too wide for 8 pt even at 7 in: declared 7 in, and the figure tests fail on it.
        assert_eq!(Style::print_width_in(1000.0, 15.0), 7.0);
        assert_eq!("paper".parse::<Style>().unwrap(), Style::Paper);
        assert_eq!("default".parse::<Style>().unwrap(), Style::Default);
        assert_eq!(Style::Paper.max_width(), Some(945.0));
        assert_eq!(Style::print_width_in(945.0, Style::Paper.font(9.0)), 7.0);
        assert!("Paper".parse::<Style>().unwrap_err().to_string().contains("'Paper'"));
    }
}
