//! The picture's text, drawn glyph by glyph from the bundled font's own
//! outlines (no shaping: the legend is plain ASCII, set with each glyph's
//! advance). Laying text out through `usvg` took about 2.5 ms of a 4 ms
//! picture; this takes a few microseconds a line.

use resvg::tiny_skia::{FillRule, Paint, PathBuilder, Pixmap, Transform};
use std::sync::OnceLock;

/// A line of text: its start (pixels, on the baseline), its size (pixels)
/// and weight.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Text {
    pub x: f64,
    pub y: f64,
    pub size: f64,
    pub bold: bool,
    pub text: String,
}

/// The bundled regular and bold faces, parsed once.
fn faces() -> &'static [ttf_parser::Face<'static>; 2] {
    static FACES: OnceLock<[ttf_parser::Face<'static>; 2]> = OnceLock::new();
    FACES.get_or_init(|| {
        [crate::fonts::REGULAR, crate::fonts::BOLD]
            .map(|data| ttf_parser::Face::parse(data, 0).expect("the bundled font parses"))
    })
}

/// A glyph's outline into a path, scaled and placed (the font's y is up).
struct Outline<'a> {
    path: &'a mut PathBuilder,
    x: f32,
    y: f32,
    scale: f32,
}

impl Outline<'_> {
    fn at(&self, x: f32, y: f32) -> (f32, f32) {
        (self.x + x * self.scale, self.y - y * self.scale)
    }
}

impl ttf_parser::OutlineBuilder for Outline<'_> {
    fn move_to(&mut self, x: f32, y: f32) {
        let (x, y) = self.at(x, y);
        self.path.move_to(x, y);
    }
    fn line_to(&mut self, x: f32, y: f32) {
        let (x, y) = self.at(x, y);
        self.path.line_to(x, y);
    }
    fn quad_to(&mut self, x1: f32, y1: f32, x: f32, y: f32) {
        let ((x1, y1), (x, y)) = (self.at(x1, y1), self.at(x, y));
        self.path.quad_to(x1, y1, x, y);
    }
    fn curve_to(&mut self, x1: f32, y1: f32, x2: f32, y2: f32, x: f32, y: f32) {
        let ((x1, y1), (x2, y2), (x, y)) = (self.at(x1, y1), self.at(x2, y2), self.at(x, y));
        self.path.cubic_to(x1, y1, x2, y2, x, y);
    }
    fn close(&mut self) {
        self.path.close();
    }
}

/// Draw every text onto `pixmap`, in near-black.
pub(super) fn draw(pixmap: &mut Pixmap, texts: &[Text]) {
    let mut paint = Paint::default();
    paint.set_color_rgba8(0x11, 0x11, 0x11, 0xff);
    paint.anti_alias = true;
    for t in texts {
        let face = &faces()[usize::from(t.bold)];
        let scale = (t.size / f64::from(face.units_per_em())) as f32;
        let mut path = PathBuilder::new();
        let mut x = t.x as f32;
        for c in t.text.chars() {
            let glyph = face.glyph_index(c).unwrap_or(ttf_parser::GlyphId(0));
            let mut outline = Outline { path: &mut path, x, y: t.y as f32, scale };
            face.outline_glyph(glyph, &mut outline);
            x += f32::from(face.glyph_hor_advance(glyph).unwrap_or(0)) * scale;
        }
        if let Some(path) = path.finish() {
            pixmap.fill_path(&path, &paint, FillRule::Winding, Transform::identity(), None);
        }
    }
}
