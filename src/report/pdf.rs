//! A figure's PDF (paper style): the SVG parsed by `usvg` and written by
//! `svg2pdf`, the text set in a font compiled into the binary, so the PDF
//! is the same on every machine and never depends on the fonts installed
//! (with none installed, `usvg` would drop every text).
//!
//! The font is a subset of Liberation Sans 2.1.5 (SIL Open Font License;
//! metric-compatible with Arial and Helvetica, which the figures name and
//! lay out for), renamed "Figure Sans" as the license asks of modified
//! fonts: `assets/fonts/`, about 24 KB per weight.

use std::sync::{Arc, OnceLock};
use svg2pdf::usvg;

const REGULAR: &[u8] = include_bytes!("../../assets/fonts/FigureSans-Regular.ttf");
const BOLD: &[u8] = include_bytes!("../../assets/fonts/FigureSans-Bold.ttf");
/// The bundled font's family name; every sans-serif text resolves to it.
pub(crate) const FAMILY: &str = "Figure Sans";

/// The fonts the PDFs are set in: the bundled ones and nothing else.
fn fonts() -> Arc<usvg::fontdb::Database> {
    static DB: OnceLock<Arc<usvg::fontdb::Database>> = OnceLock::new();
    DB.get_or_init(|| {
        let mut db = usvg::fontdb::Database::new();
        db.load_font_data(REGULAR.to_vec());
        db.load_font_data(BOLD.to_vec());
        // "Helvetica, Arial, sans-serif": the first two are not in the
        // database, so the generic family decides.
        db.set_sans_serif_family(FAMILY);
        Arc::new(db)
    })
    .clone()
}

#[derive(Debug, thiserror::Error)]
pub enum PdfError {
    #[error("the SVG could not be read ({0})")]
    Svg(String),
    #[error("the PDF could not be written ({0})")]
    Pdf(String),
}

/// One page, the size of the SVG's declared width and height (a paper
/// figure's `width="7in"` gives a 504 pt wide page).
pub fn from_svg(svg: &str) -> Result<Vec<u8>, PdfError> {
    let options = usvg::Options { fontdb: fonts(), ..usvg::Options::default() };
    let tree = usvg::Tree::from_str(svg, &options).map_err(|e| PdfError::Svg(e.to_string()))?;
    // usvg reads inches at 96 px each; at 96 dpi a px is 0.75 pt again.
    let page = svg2pdf::PageOptions { dpi: 96.0 };
    svg2pdf::to_pdf(&tree, svg2pdf::ConversionOptions::default(), page).map_err(|e| PdfError::Pdf(e.to_string()))
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
        let bare = usvg::Options { fontdb: Arc::new(usvg::fontdb::Database::new()), ..usvg::Options::default() };
        let tree = usvg::Tree::from_str(svg, &bare).unwrap();
        let empty =
            svg2pdf::to_pdf(&tree, svg2pdf::ConversionOptions::default(), svg2pdf::PageOptions { dpi: 96.0 }).unwrap();
        assert!(!String::from_utf8_lossy(&empty).contains("/FontFile"), "text without a font");
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
