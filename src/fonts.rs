//! The font every drawn text is set in, compiled into the binary: the
//! figures' PDFs and the scene pictures come out the same on every
//! machine, whatever fonts it has (with none installed, `usvg` would drop
//! every text).
//!
//! The font is a subset of Liberation Sans 2.1.5 (SIL Open Font License;
//! metric-compatible with Arial and Helvetica, which the figures name and
//! lay out for), renamed "Figure Sans" as the license asks of modified
//! fonts: `assets/fonts/`, about 24 KB per weight.

use std::sync::{Arc, OnceLock};
use svg2pdf::usvg;

pub(crate) const REGULAR: &[u8] = include_bytes!("../assets/fonts/FigureSans-Regular.ttf");
pub(crate) const BOLD: &[u8] = include_bytes!("../assets/fonts/FigureSans-Bold.ttf");
/// The bundled font's family name; every sans-serif text resolves to it.
pub(crate) const FAMILY: &str = "Figure Sans";

/// The bundled fonts and nothing else.
pub(crate) fn database() -> Arc<usvg::fontdb::Database> {
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
