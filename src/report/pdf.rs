//! A figure's PDF (paper style): the SVG parsed by `usvg` and written by
//! `svg2pdf`, the text set in the font compiled into the binary
//! (`crate::fonts`), so the PDF is the same on every machine.

use crate::fonts::database as fonts;
use svg2pdf::usvg;

#[derive(Debug, thiserror::Error)]
pub enum PdfError {
    #[error("the SVG could not be read ({0})")]
    Svg(String),
    #[error("the PDF could not be written ({0})")]
    Pdf(String),
}

/// Conversions tried for the fonts' canonical order before the last one is
/// kept (with the two bundled fonts, each try has it with probability 1/2).
const MAX_TRIES: usize = 64;

/// One page, the size of the SVG's declared width and height (a paper
/// figure's `width="7in"` gives a 504 pt wide page). The same SVG gives
/// the same bytes: svg2pdf 0.13 (no longer maintained) writes its fonts and
/// the entries of each resource dictionary in `HashMap` order, which
/// differs from one conversion to the next. The conversion is repeated
/// until the fonts come in the order of their names, and the dictionary
/// entries are then sorted in place. Only the order varies, never the
/// content.
pub fn from_svg(svg: &str) -> Result<Vec<u8>, PdfError> {
    let options = usvg::Options { fontdb: fonts(), ..usvg::Options::default() };
    let tree = usvg::Tree::from_str(svg, &options).map_err(|e| PdfError::Svg(e.to_string()))?;
    // usvg reads inches at 96 px each; at 96 dpi a px is 0.75 pt again.
    let page = svg2pdf::PageOptions { dpi: 96.0 };
    let convert = || {
        svg2pdf::to_pdf(&tree, svg2pdf::ConversionOptions::default(), page).map_err(|e| PdfError::Pdf(e.to_string()))
    };
    let mut pdf = convert()?;
    for _ in 1..MAX_TRIES {
        if fonts_in_order(&pdf) {
            break;
        }
        pdf = convert()?;
    }
    sort_resource_entries(&mut pdf);
    Ok(pdf)
}

/// Whether the embedded fonts are written in the order of their names
/// (subset names carry a tag before '+': the font's own name decides).
fn fonts_in_order(pdf: &[u8]) -> bool {
    let text = String::from_utf8_lossy(pdf);
    let mut fonts: Vec<&str> = Vec::new();
    for at in text.match_indices("/BaseFont /").map(|(i, m)| i + m.len()) {
        let name = text[at..].split(|c: char| c.is_whitespace() || c == '/').next().unwrap_or("");
        let own = name.rsplit('+').next().unwrap_or(name);
        if !fonts.contains(&own) {
            fonts.push(own);
        }
    }
    fonts.is_sorted()
}

/// Sort each run of resource-dictionary entry lines (`/gs10 17 0 R`) by
/// name and number, outside streams. A run is rewritten with the same
/// lines, so its length, and every object's offset, stays the same.
fn sort_resource_entries(pdf: &mut [u8]) {
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let (mut at, mut in_stream, mut run_start): (usize, bool, Option<usize>) = (0, false, None);
    while at < pdf.len() {
        let end = pdf[at..].iter().position(|&b| b == b'\n').map_or(pdf.len(), |i| at + i);
        let line = &pdf[at..end];
        let entry = !in_stream && std::str::from_utf8(line).ok().and_then(|l| resource_entry(l.trim())).is_some();
        match (entry, run_start) {
            (true, None) => run_start = Some(at),
            (false, Some(start)) => {
                runs.push((start, at));
                run_start = None;
            }
            _ => {}
        }
        if line == b"stream" {
            in_stream = true;
        } else if line == b"endstream" {
            in_stream = false;
        }
        at = end + 1;
    }
    for (start, end) in runs {
        let text = String::from_utf8_lossy(&pdf[start..end]).into_owned();
        let mut lines: Vec<&str> = text.split_inclusive('\n').collect();
        lines.sort_by_key(|l| resource_entry(l.trim()).map(|(p, n)| (p.to_string(), n)));
        pdf[start..end].copy_from_slice(lines.concat().as_bytes());
    }
}

/// A resource-dictionary entry line, `/fo12 7 0 R`: its name's prefix and
/// number.
fn resource_entry(line: &str) -> Option<(&str, u64)> {
    let mut parts = line.split(' ');
    let name = parts.next()?.strip_prefix('/')?;
    let (obj, generation, r) = (parts.next()?, parts.next()?, parts.next()?);
    if parts.next().is_some() || r != "R" || generation.parse::<u32>().is_err() || obj.parse::<u32>().is_err() {
        return None;
    }
    let digits = name.find(|c: char| c.is_ascii_digit())?;
    let (prefix, number) = name.split_at(digits);
    let lowercase = !prefix.is_empty() && prefix.chars().all(|c| c.is_ascii_lowercase());
    Some((prefix, number.parse().ok()?)).filter(|_| lowercase)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The page size from the MediaBox, in points.
    fn media_box(pdf: &[u8]) -> Vec<f64> {
        let text = String::from_utf8_lossy(pdf);
        let at = text.find("/MediaBox [").expect("a MediaBox") + "/MediaBox [".len();
        text[at..text[at..].find(']').unwrap() + at].split_whitespace().map(|v| v.parse().unwrap()).collect()
    }

    #[test]
    fn the_page_is_the_declared_print_size_and_the_text_is_set_in_the_bundled_font() {
        let svg = "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 700 350\" width=\"7in\" height=\"3.5in\" \
                   font-family=\"Helvetica, Arial, sans-serif\"><text x=\"10\" y=\"20\" font-size=\"15\">tier ladder \
                   \u{2026} \u{2020}</text><text x=\"10\" y=\"40\" font-size=\"15\" font-weight=\"bold\">bold</text></svg>";
        let pdf = from_svg(svg).unwrap();
        assert!(pdf.starts_with(b"%PDF-"));
        let mb = media_box(&pdf);
        assert!((mb[2] - mb[0] - 504.0).abs() < 0.5 && (mb[3] - mb[1] - 252.0).abs() < 0.5, "{mb:?}");
        // Both weights embedded (subset font names carry a six-letter tag before the name).
        let text = String::from_utf8_lossy(&pdf);
        assert!(text.contains("FigureSans-Regular") && text.contains("FigureSans-Bold"), "fonts not embedded");
        // Without any font the text would be dropped: the PDF would hold no font at all.
        let bare =
            usvg::Options { fontdb: std::sync::Arc::new(usvg::fontdb::Database::new()), ..usvg::Options::default() };
        let tree = usvg::Tree::from_str(svg, &bare).unwrap();
        let empty =
            svg2pdf::to_pdf(&tree, svg2pdf::ConversionOptions::default(), svg2pdf::PageOptions { dpi: 96.0 }).unwrap();
        assert!(!String::from_utf8_lossy(&empty).contains("/FontFile"), "text without a font");
    }

    /// svg2pdf alone orders fonts and resource entries differently from
    /// one conversion to the next; `from_svg` does not.
    #[test]
    fn the_same_svg_gives_the_same_bytes() {
        // Two fonts and a dozen graphics states (one per opacity).
        let rects: String = (1..=12)
            .map(|i| format!("<rect x=\"{}\" y=\"50\" width=\"8\" height=\"8\" fill-opacity=\"0.{i:02}\"/>", 10 * i))
            .collect();
        let svg = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 300 80\" width=\"3.3in\" height=\"0.88in\" \
             font-family=\"Helvetica, Arial, sans-serif\"><text x=\"10\" y=\"20\" font-size=\"15\">regular</text>\
             <text x=\"10\" y=\"40\" font-size=\"15\" font-weight=\"bold\">bold</text>{rects}</svg>"
        );
        let svg = svg.as_str();
        let first = from_svg(svg).unwrap();
        assert!(fonts_in_order(&first));
        for _ in 0..12 {
            assert!(from_svg(svg).unwrap() == first, "a conversion gave other bytes");
        }
    }

    #[test]
    fn resource_entries_are_sorted_in_place() {
        assert_eq!(resource_entry("/fo12 7 0 R"), Some(("fo", 12)));
        assert_eq!(resource_entry("/Font <<"), None);
        assert_eq!(resource_entry("/Parent 4 0 R"), None);
        assert_eq!(resource_entry("/cs0 [/ICCBased 7 0 R]"), None);
        let mut pdf = b"<<\n  /ExtGState <<\n    /gs10 17 0 R\n    /gs2 9 0 R\n    /gs0 7 0 R\n  >>\n  /Font <<\n    /fo1 2 0 R\n    /fo0 1 0 R\n  >>\n>>\nstream\n/gs9 1 0 R\n/gs1 2 0 R\nendstream\n".to_vec();
        let len = pdf.len();
        sort_resource_entries(&mut pdf);
        assert_eq!(pdf.len(), len);
        assert_eq!(
            String::from_utf8(pdf).unwrap(),
            "<<\n  /ExtGState <<\n    /gs0 7 0 R\n    /gs2 9 0 R\n    /gs10 17 0 R\n  >>\n  /Font <<\n    /fo0 1 0 R\n    /fo1 2 0 R\n  >>\n>>\nstream\n/gs9 1 0 R\n/gs1 2 0 R\nendstream\n",
            "entries sorted by number, streams untouched"
        );
        assert!(!fonts_in_order(b"/BaseFont /AAAAAA+Sans-Regular\n/BaseFont /BBBBBB+Sans-Bold"));
        assert!(fonts_in_order(b"/BaseFont /BBBBBB+Sans-Bold\n/BaseFont /AAAAAA+Sans-Regular"));
    }

    #[test]
    fn characters_outside_the_bundled_subset_do_not_fail_the_pdf() {
        // A model name in another script: its glyphs are missing from the PDF (not from the SVG), the rest is set.
        let svg = "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 300 40\" width=\"3.3in\" height=\"0.44in\" \
                   font-family=\"Helvetica, Arial, sans-serif\"><text x=\"10\" y=\"20\" font-size=\"15\">\u{6a21}\u{578b}-7b \
                   \u{2192} ok</text></svg>";
        let pdf = from_svg(svg).unwrap();
        assert!(pdf.starts_with(b"%PDF-") && String::from_utf8_lossy(&pdf).contains("FigureSans-Regular"));
    }
}
