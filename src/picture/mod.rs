//! The scene as a picture: a bird's-eye view of one decision, for a
//! vision-language model (docs/vision.md), drawn from the public
//! observation only, as the text is, and from the figures as the
//! text prints them: nothing it shows depends on the hidden disposition
//! before the motion shows it.
//!
//! A picture is 512 x 512 pixels: a legend band on top (the text's turn,
//! "You:" and last-action lines, word for word) and the road below, to
//! scale, with a scale bar. Every road user is drawn to scale (cars as
//! 1.9 x 4.8 m boxes, pedestrians as 0.6 m discs), with its last 2 s as a
//! fading trail at the very instants the text's history gives, and its
//! velocity as an arrow of one second's travel. Each scenario draws its
//! own road and places its road users in its own file (`picture/<name>.rs`,
//! this layer's part of the scenario registry).
//!
//! The picture is recorded as shapes (`shapes.rs`), painted straight onto a
//! pixmap by tiny-skia (pure Rust, the text from the bundled font's
//! outlines) and encoded as PNG: the same bytes on every machine. The same
//! shapes are written as SVG by [`svg`].

/// The pictures' part of the scenario registry: a drawing per scenario,
/// in the registry's order.
macro_rules! drawings {
    ($($name:ident),+) => {
        $(mod $name;)+

        /// Every scenario's drawing, in the order of `ScenarioKind::ALL`.
        const DRAWINGS: [&Drawing; ScenarioKind::ALL.len()] = [$(&$name::DRAWING),+];
    };
}
crate::scenario::registry!(drawings);

mod glyphs;
mod shapes;

use crate::observation::{Observation, Track};
use crate::scenario::ScenarioKind;
use shapes::{Outline, Shape, n};
use std::fmt::Write;

/// The picture's side, in pixels.
pub const SIZE_PX: u32 = 512;
/// The legend band's height at the top (pixels); the road is drawn below.
pub const LEGEND_PX: f64 = 92.0;
/// Colours: the ego, the road user the question is about (the first
/// track), every other road user.
pub(crate) const EGO_FILL: &str = "#1f5fbf";
pub(crate) const FIRST_FILL: &str = "#e0620d";
pub(crate) const OTHER_FILL: &str = "#8c3fb0";
const ROAD: &str = "#c8c8c8";
const GROUND: &str = "#eef3e6";
const MARKING: &str = "#ffffff";
const ZONE: &str = "#f2b8b0";
const WHITE: &str = "#ffffff";

/// One scenario's drawing: where its view is, and how its road and its
/// road users are drawn from a (rounded) observation.
pub(crate) struct Drawing {
    /// The metres at the centre of the road area, and the scale.
    pub view: View,
    pub draw: fn(&Observation, &mut Canvas),
}

/// A scenario's view: the point (m) at the centre of the road area, and
/// pixels per metre. The plan's y grows up the picture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    pub centre_m: (f64, f64),
    pub px_per_m: f64,
}

impl View {
    /// Pixels of a plan point (m): x right, y down the picture.
    pub fn to_px(&self, (x, y): (f64, f64)) -> (f64, f64) {
        let middle = LEGEND_PX + (f64::from(SIZE_PX) - LEGEND_PX) / 2.0;
        (
            f64::from(SIZE_PX) / 2.0 + (x - self.centre_m.0) * self.px_per_m,
            middle - (y - self.centre_m.1) * self.px_per_m,
        )
    }

    /// The plan point (m) of a pixel: the inverse of [`View::to_px`].
    pub fn to_m(&self, (px, py): (f64, f64)) -> (f64, f64) {
        let middle = LEGEND_PX + (f64::from(SIZE_PX) - LEGEND_PX) / 2.0;
        (
            self.centre_m.0 + (px - f64::from(SIZE_PX) / 2.0) / self.px_per_m,
            self.centre_m.1 - (py - middle) / self.px_per_m,
        )
    }
}

/// Which way a car's nose points on the picture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Heading {
    Up,
    Right,
}

impl Heading {
    fn unit(self) -> (f64, f64) {
        match self {
            Heading::Up => (0.0, 1.0),
            Heading::Right => (1.0, 0.0),
        }
    }
}

/// A road user where the picture draws it: its label (the text's), its
/// centre in metres and in pixels, and its fill.
#[derive(Debug, Clone, PartialEq)]
pub struct Placed {
    pub label: String,
    pub centre_m: (f64, f64),
    pub centre_px: (f64, f64),
    /// The plan direction a positive velocity moves it.
    pub along: (f64, f64),
    pub fill: &'static str,
}

/// The picture being drawn, in the view's metres, as shapes in layers:
/// the road, then every trail, every road user, every arrow (so no trail
/// covers a road user and no road user an arrow).
pub(crate) struct Canvas {
    pub view: View,
    body: Vec<Shape>,
    trails: Vec<Shape>,
    bodies: Vec<Shape>,
    arrows: Vec<Shape>,
    texts: Vec<glyphs::Text>,
    placed: Vec<Placed>,
}

/// Where a shape goes.
#[derive(Clone, Copy)]
enum Layer {
    Trail,
    Body,
}

/// The outline every road user's shape has (its opacity its fill's).
fn road_user_outline(opacity: f64) -> Option<Outline> {
    Some(Outline { colour: "#222222", opacity, width: 1.0 })
}

impl Canvas {
    fn new(view: View) -> Canvas {
        Canvas {
            view,
            body: Vec::with_capacity(32),
            trails: Vec::new(),
            bodies: Vec::new(),
            arrows: Vec::new(),
            texts: Vec::new(),
            placed: Vec::new(),
        }
    }

    /// A filled rectangle between two plan corners (m).
    pub fn rect(&mut self, a: (f64, f64), b: (f64, f64), fill: &'static str) {
        let (pa, pb) = (self.view.to_px(a), self.view.to_px(b));
        let (x, y) = (pa.0.min(pb.0), pa.1.min(pb.1));
        let (w, h) = ((pa.0 - pb.0).abs(), (pa.1 - pb.1).abs());
        self.body.push(Shape::Rect { x, y, w, h, rx: 0.0, fill, opacity: 1.0, outline: None });
    }

    /// A line between two plan points (m), `width` pixels wide, dashed
    /// `(on, off)` pixels when asked.
    pub fn line(&mut self, a: (f64, f64), b: (f64, f64), colour: &'static str, width: f64, dash: Option<(f64, f64)>) {
        let (a, b) = (self.view.to_px(a), self.view.to_px(b));
        self.body.push(Shape::Line { a, b, colour, width, dash });
    }

    /// A filled polygon through pixel points.
    pub fn polygon(&mut self, points: &[(f64, f64)], fill: &'static str) {
        self.body.push(Shape::Polygon { points: points.to_vec(), fill });
    }

    /// A car's box (1.9 x 4.8 m) centred at `c` (m), nose along `heading`;
    /// `opacity` below 1 for a trail.
    fn car_box(&mut self, layer: Layer, c: (f64, f64), heading: Heading, fill: &'static str, opacity: f64) {
        let (hw, hl) = (0.5 * crate::sim::CAR_WIDTH, 0.5 * crate::sim::CAR_LENGTH);
        let (dx, dy) = match heading {
            Heading::Up => (hw, hl),
            Heading::Right => (hl, hw),
        };
        let (pa, pb) = (self.view.to_px((c.0 - dx, c.1 + dy)), self.view.to_px((c.0 + dx, c.1 - dy)));
        let (x, y, w, h) = (pa.0, pa.1, pb.0 - pa.0, pb.1 - pa.1);
        let shape = Shape::Rect { x, y, w, h, rx: 2.0, fill, opacity, outline: road_user_outline(opacity) };
        self.layer(layer).push(shape);
    }

    /// A pedestrian's disc (0.6 m across) centred at `c` (m).
    fn disc(&mut self, layer: Layer, c: (f64, f64), fill: &'static str, opacity: f64) {
        let c = self.view.to_px(c);
        let r = 0.5 * crate::sim::PEDESTRIAN_SIZE * self.view.px_per_m;
        self.layer(layer).push(Shape::Circle { c, r, fill, opacity, outline: road_user_outline(opacity) });
    }

    /// A velocity arrow from `c` (m): one second's travel at `v` (m/s)
    /// along `unit` (the direction a positive velocity moves it).
    fn arrow(&mut self, c: (f64, f64), unit: (f64, f64), v: f64) {
        if v.abs() < 0.05 {
            return;
        }
        let tip = (c.0 + unit.0 * v, c.1 + unit.1 * v);
        let (pc, pt) = (self.view.to_px(c), self.view.to_px(tip));
        self.arrows.push(Shape::Line { a: pc, b: pt, colour: "#111111", width: 2.0, dash: None });
        let (ux, uy) = ((pt.0 - pc.0) / (v.abs() * self.view.px_per_m), (pt.1 - pc.1) / (v.abs() * self.view.px_per_m));
        // The head is never longer than half the arrow (a slow road user's
        // arrow stays ahead of its centre).
        let l = (0.5 * v.abs() * self.view.px_per_m).min(7.0);
        let w = 0.55 * l;
        let back = (pt.0 - ux * l, pt.1 - uy * l);
        let head = vec![pt, (back.0 - uy * w, back.1 + ux * w), (back.0 + uy * w, back.1 - ux * w)];
        self.arrows.push(Shape::Polygon { points: head, fill: "#111111" });
    }

    /// The ego's car, centred at `c` (m), with its velocity arrow.
    pub fn ego(&mut self, c: (f64, f64), heading: Heading, speed: f64) {
        self.car_box(Layer::Body, c, heading, EGO_FILL, 1.0);
        self.arrow(c, heading.unit(), speed);
        let centre_px = self.view.to_px(c);
        self.placed.push(Placed { label: "You".into(), centre_m: c, centre_px, along: heading.unit(), fill: EGO_FILL });
    }

    /// A road user (a car along `heading`, or a pedestrian with `None`)
    /// from its track: its trail at the history's instants (the oldest
    /// faintest), then itself and its velocity arrow. `at` places a
    /// position of the track (the scene's frame) on the plan, and `unit`
    /// is the plan direction a positive velocity moves it.
    pub fn road_user(
        &mut self,
        k: usize,
        label: &str,
        track: &Track,
        heading: Option<Heading>,
        at: impl Fn(f64) -> (f64, f64),
        unit: (f64, f64),
    ) {
        let fill = if k == 0 { FIRST_FILL } else { OTHER_FILL };
        for (i, s) in track.past.iter().enumerate() {
            let opacity = 0.12 + 0.08 * i as f64;
            match heading {
                Some(h) => self.car_box(Layer::Trail, at(s.position_m), h, fill, opacity),
                None => self.disc(Layer::Trail, at(s.position_m), fill, opacity),
            }
        }
        let c = at(track.now.position_m);
        match heading {
            Some(h) => self.car_box(Layer::Body, c, h, fill, 1.0),
            None => self.disc(Layer::Body, c, fill, 1.0),
        }
        self.arrow(c, unit, track.now.velocity_mps);
        self.placed.push(Placed { label: label.into(), centre_m: c, centre_px: self.view.to_px(c), along: unit, fill });
    }

    fn layer(&mut self, layer: Layer) -> &mut Vec<Shape> {
        match layer {
            Layer::Trail => &mut self.trails,
            Layer::Body => &mut self.bodies,
        }
    }

    /// Every layer, in drawing order.
    fn flatten(&mut self) {
        for layer in
            [std::mem::take(&mut self.trails), std::mem::take(&mut self.bodies), std::mem::take(&mut self.arrows)]
        {
            self.body.extend(layer);
        }
    }

    /// A line of text from (x, y) (pixels, its baseline's start).
    fn text(&mut self, x: f64, y: f64, s: &str, size: f64, bold: bool) {
        self.texts.push(glyphs::Text { x, y, size, bold, text: s.to_string() });
    }

    /// A rectangle in pixels (the legend's and the key's).
    fn rect_px(
        &mut self,
        (x, y, w, h): (f64, f64, f64, f64),
        fill: &'static str,
        opacity: f64,
        outline: Option<Outline>,
    ) {
        self.body.push(Shape::Rect { x, y, w, h, rx: 0.0, fill, opacity, outline });
    }

    /// A line in pixels.
    fn line_px(&mut self, a: (f64, f64), b: (f64, f64), colour: &'static str, width: f64) {
        self.body.push(Shape::Line { a, b, colour, width, dash: None });
    }
}

/// `s` in lines of at most `width` characters, broken after a comma where
/// one fits (a clause of the text's line stays whole), else between words.
fn wrap(s: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    let clauses: Vec<String> = s.split(", ").map(str::to_string).collect();
    let last = clauses.len() - 1;
    for (i, clause) in clauses.into_iter().enumerate() {
        let piece = if i < last { format!("{clause},") } else { clause };
        match lines.last_mut() {
            Some(line) if line.len() + 1 + piece.len() <= width => {
                line.push(' ');
                line.push_str(&piece);
            }
            _ if piece.len() <= width => lines.push(piece),
            _ => {
                for word in piece.split(' ') {
                    match lines.last_mut() {
                        Some(line) if line.len() + 1 + word.len() <= width => {
                            line.push(' ');
                            line.push_str(word);
                        }
                        _ => lines.push(word.to_string()),
                    }
                }
            }
        }
    }
    lines
}

fn drawing(kind: ScenarioKind) -> Option<&'static Drawing> {
    kind.index().map(|i| DRAWINGS[i])
}

/// The picture of `obs` as shapes and text (512 x 512), and where it
/// placed each road user; `None` for a scene of a scenario outside the
/// registry.
fn draw(obs: &Observation) -> Option<Drawn> {
    let drawing = drawing(obs.scenario())?;
    // The figures as the text prints them, so the picture shows no digit
    // the text does not.
    let obs = obs.rounded();
    let size = f64::from(SIZE_PX);
    let mut c = Canvas::new(drawing.view);
    c.rect_px((0.0, 0.0, size, size), GROUND, 1.0, None);
    (drawing.draw)(&obs, &mut c);
    c.flatten();
    // The legend band: the text's own lines.
    c.rect_px((0.0, 0.0, size, LEGEND_PX), WHITE, 1.0, None);
    c.line_px((0.0, LEGEND_PX), (size, LEGEND_PX), "#888888", 1.0);
    let header = format!(
        "{} - turn {} of {} ({} left), time {:.1} s",
        obs.scenario().scene_name(),
        obs.turn,
        obs.turn_budget,
        obs.turns_left(),
        obs.time_s
    );
    c.text(8.0, 16.0, &header, 13.0, true);
    let mut y = 32.0;
    for line in wrap(&crate::observation::you_line(&obs), 78)
        .into_iter()
        .chain(std::iter::once(crate::observation::last_action_line(&obs)))
    {
        c.text(8.0, y, &line, 12.0, false);
        y += 15.0;
    }
    // The scale bar (10 m) and the key, at the bottom.
    let px = drawing.view.px_per_m;
    let base = size - 12.0;
    c.rect_px((8.0, base - 14.0, 10.0 * px + 40.0, 20.0), WHITE, 1.0, None);
    c.line_px((12.0, base), (12.0 + 10.0 * px, base), "#111111", 3.0);
    c.text(16.0 + 10.0 * px, base + 4.0, "10 m", 12.0, false);
    let labels = obs.scenario().track_labels();
    let key: Vec<(&str, &'static str)> = std::iter::once(("You", EGO_FILL))
        .chain(labels.iter().enumerate().map(|(k, l)| (l.now, if k == 0 { FIRST_FILL } else { OTHER_FILL })))
        .collect();
    let mut ky = size - 12.0 - 16.0 * (key.len() as f64 - 1.0);
    c.rect_px((size - 158.0, ky - 13.0, 150.0, 16.0 * key.len() as f64 + 2.0), WHITE, 1.0, None);
    for (label, fill) in key {
        c.rect_px((size - 152.0, ky - 9.0, 12.0, 10.0), fill, 1.0, road_user_outline(1.0));
        c.text(size - 134.0, ky, label, 12.0, false);
        ky += 16.0;
    }
    Some(Drawn { shapes: c.body, texts: c.texts, placed: c.placed })
}

/// A picture drawn: its shapes, its text, its road users.
struct Drawn {
    shapes: Vec<Shape>,
    texts: Vec<glyphs::Text>,
    placed: Vec<Placed>,
}

fn svg_of(shapes: &str) -> String {
    format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{SIZE_PX}" height="{SIZE_PX}" viewBox="0 0 {SIZE_PX} {SIZE_PX}" font-family="Helvetica, Arial, sans-serif">{shapes}</svg>"#
    )
}

/// The picture of `obs` as SVG (its text as SVG text); `None` for a
/// scenario outside the registry.
pub fn svg(obs: &Observation) -> Option<String> {
    let drawn = draw(obs)?;
    let mut shapes = String::with_capacity(8192);
    for shape in &drawn.shapes {
        shape.write_svg(&mut shapes);
    }
    for t in &drawn.texts {
        let _ = write!(
            shapes,
            r##"<text x="{}" y="{}" font-size="{}" font-weight="{}" fill="#111">{}</text>"##,
            n(t.x),
            n(t.y),
            n(t.size),
            if t.bold { "bold" } else { "normal" },
            crate::export::esc(&t.text)
        );
    }
    Some(svg_of(&shapes))
}

/// Where the picture of `obs` places each road user (the ego first).
pub fn layout(obs: &Observation) -> Vec<Placed> {
    draw(obs).map(|d| d.placed).unwrap_or_default()
}

/// The view of `kind`'s pictures (None outside the registry).
pub fn view(kind: ScenarioKind) -> Option<View> {
    drawing(kind).map(|d| d.view)
}

/// The system prompt's paragraph for a run shown pictures: what the
/// picture shows and its scale, for `kind`'s view. With `with_text` the
/// scene text comes beside it; without, the picture replaces it and the
/// paragraph carries what the text's first lines say once per episode
/// (the scene and its situation).
pub fn prompt_paragraph(kind: ScenarioKind, with_text: bool) -> String {
    let Some(view) = view(kind) else { return String::new() };
    let labels = kind.track_labels();
    let mut others: Vec<String> = Vec::with_capacity(labels.len());
    for (k, l) in labels.iter().enumerate() {
        others.push(format!("{} in {}", l.now, if k == 0 { "orange" } else { "purple" }));
    }
    let mut p = format!(
        "\n\nEach turn shows the scene as a {SIZE_PX} x {SIZE_PX} bird's-eye picture, to scale at {} pixels per metre \
         (the scale bar is 10 m). Top band: the turn and time, then your \"You:\" line and your last action, as words. \
         Below, the road seen from above: you are the blue box (cars are 1.9 x 4.8 m), {}; pedestrians are 0.6 m discs. \
         Each road user's last 2 s are fading copies of it at the history's instants (the faintest the oldest), and \
         its arrow is where its current speed takes it in one second.",
        n(view.px_per_m),
        others.join(", ")
    );
    if with_text {
        p.push_str(" The same scene is also given as text, which the picture agrees with.");
    } else {
        let _ = write!(
            p,
            " No scene text is sent: the user message says only the turn.\nScene: {}\nSituation: {}",
            kind.scene_name(),
            kind.situation()
        );
    }
    p
}

/// The one line sent with a picture in place of the scene text: the turn,
/// and (on tiers with noisy readings) the text's readings sentence, which
/// the picture cannot show.
pub fn user_line(obs: &Observation) -> String {
    let mut line = if obs.turn <= 1 {
        format!("Turn {} of {}: answer as the instructions say.", obs.turn, obs.turn_budget)
    } else {
        format!("Turn {} of {}: answer as before.", obs.turn, obs.turn_budget)
    };
    if obs.reading_noise.is_some() {
        let text = crate::observation::render_scene(obs);
        if let Some(readings) = text.lines().find(|l| l.starts_with("Readings:")) {
            line.push('\n');
            line.push_str(readings);
        }
    }
    line
}

/// Why a picture could not be made.
#[derive(Debug, thiserror::Error)]
pub enum PictureError {
    #[error("no drawing for scenario '{0}'")]
    NoDrawing(String),
    #[error("the picture could not be drawn ({0})")]
    Draw(String),
}

/// The picture of `obs` as a 512 x 512 PNG: its shapes painted with
/// tiny-skia, its text drawn from the font's outlines, then encoded.
pub fn png(obs: &Observation) -> Result<Vec<u8>, PictureError> {
    let drawn = draw(obs).ok_or_else(|| PictureError::NoDrawing(obs.scenario().to_string()))?;
    let mut pixmap = resvg::tiny_skia::Pixmap::new(SIZE_PX, SIZE_PX).ok_or(PictureError::Draw("no pixmap".into()))?;
    for shape in &drawn.shapes {
        shape.paint(&mut pixmap);
    }
    glyphs::draw(&mut pixmap, &drawn.texts);
    encode(pixmap.width(), pixmap.height(), pixmap.data())
}

/// Opaque RGBA pixels as a PNG, as [`png()`] encodes a picture: the encoder
/// alone (`cargo bench --bench picture` times it apart, the floor of any
/// picture this size). The picture is opaque (its ground is painted
/// first), so its premultiplied pixels are its colours; flat colour rows
/// compress well with the Up filter and the fast deflate (about 0.25 ms and
/// 50 KB; converting to RGB first cost more than it saved).
pub fn encode(width: u32, height: u32, rgba: &[u8]) -> Result<Vec<u8>, PictureError> {
    encode_png(width, height, rgba).map_err(|e| PictureError::Draw(e.to_string()))
}

fn encode_png(width: u32, height: u32, rgba: &[u8]) -> Result<Vec<u8>, png::EncodingError> {
    let mut out = Vec::with_capacity(64 * 1024);
    let mut encoder = png::Encoder::new(&mut out, width, height);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_compression(png::Compression::Fast);
    encoder.set_filter(png::FilterType::Up);
    encoder.set_adaptive_filter(png::AdaptiveFilterType::NonAdaptive);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(rgba)?;
    writer.finish()?;
    Ok(out)
}

#[cfg(test)]
mod tests;
