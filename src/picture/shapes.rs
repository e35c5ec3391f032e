//! The picture's shapes, recorded once and then either written as SVG
//! (`picture::svg`) or painted straight onto the pixmap with tiny-skia
//! (`picture::png`): the same geometry, to the hundredth of a pixel, with
//! no SVG to parse on the way to a PNG. Parsing the SVG back through
//! `usvg` took most of a 2.5 ms picture.

use resvg::tiny_skia::{
    Color, FillRule, LineCap, Paint, PathBuilder, Pixmap, Rect, Stroke as SkStroke, StrokeDash, Transform,
};
use std::fmt::Write;

/// A shape's outline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Outline {
    pub colour: &'static str,
    pub opacity: f64,
    pub width: f64,
}

/// One shape, in pixels.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Shape {
    /// A rectangle, corners rounded by `rx`.
    Rect { x: f64, y: f64, w: f64, h: f64, rx: f64, fill: &'static str, opacity: f64, outline: Option<Outline> },
    /// A straight line, dashed as "on off" pixels when asked.
    Line { a: (f64, f64), b: (f64, f64), colour: &'static str, width: f64, dash: Option<(f64, f64)> },
    /// A filled polygon.
    Polygon { points: Vec<(f64, f64)>, fill: &'static str },
    /// A filled disc.
    Circle { c: (f64, f64), r: f64, fill: &'static str, opacity: f64, outline: Option<Outline> },
}

/// A coordinate as both forms use it: to the hundredth of a pixel.
pub(super) fn r2(x: f64) -> f64 {
    if x.is_finite() { (x * 100.0).round() / 100.0 } else { 0.0 }
}

/// A number as the SVG writes it (`12.5`, `0`).
pub(super) fn n(x: f64) -> String {
    let x = r2(x);
    if x == 0.0 { "0".into() } else { format!("{x}") }
}

impl Shape {
    /// The shape as an SVG element.
    pub(super) fn write_svg(&self, out: &mut String) {
        let outline = |o: &Option<Outline>| match o {
            Some(o) => {
                format!(r#" stroke="{}" stroke-opacity="{}" stroke-width="{}""#, o.colour, n(o.opacity), n(o.width))
            }
            None => String::new(),
        };
        let opacity = |o: f64| if o < 1.0 { format!(r#" fill-opacity="{}""#, n(o)) } else { String::new() };
        let _ = match self {
            Shape::Rect { x, y, w, h, rx, fill, opacity: o, outline: line } => {
                let rx = if *rx > 0.0 { format!(r#" rx="{}""#, n(*rx)) } else { String::new() };
                write!(
                    out,
                    r#"<rect x="{}" y="{}" width="{}" height="{}"{rx} fill="{fill}"{}{}/>"#,
                    n(*x),
                    n(*y),
                    n(*w),
                    n(*h),
                    opacity(*o),
                    outline(line)
                )
            }
            Shape::Line { a, b, colour, width, dash } => {
                let dash = dash.map(|(on, off)| format!(r#" stroke-dasharray="{} {}""#, n(on), n(off)));
                write!(
                    out,
                    r#"<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="{colour}" stroke-width="{}"{}/>"#,
                    n(a.0),
                    n(a.1),
                    n(b.0),
                    n(b.1),
                    n(*width),
                    dash.unwrap_or_default()
                )
            }
            Shape::Polygon { points, fill } => {
                let d: Vec<String> = points.iter().map(|p| format!("{} {}", n(p.0), n(p.1))).collect();
                write!(out, r#"<path d="M{}Z" fill="{fill}"/>"#, d.join("L"))
            }
            Shape::Circle { c, r, fill, opacity: o, outline: line } => write!(
                out,
                r#"<circle cx="{}" cy="{}" r="{}" fill="{fill}"{}{}/>"#,
                n(c.0),
                n(c.1),
                n(*r),
                opacity(*o),
                outline(line)
            ),
        };
    }

    /// The shape painted onto `pixmap`, anti-aliased, as SVG would draw it
    /// (fill, then the outline centred on the edge).
    pub(super) fn paint(&self, pixmap: &mut Pixmap) {
        let f = |x: f64| r2(x) as f32;
        match self {
            Shape::Rect { x, y, w, h, rx: 0.0, fill, opacity, outline: None } => {
                fill_box(pixmap, (f(*x), f(*y), f(*x) + f(*w), f(*y) + f(*h)), fill, *opacity);
            }
            Shape::Rect { x, y, w, h, rx, fill, opacity, outline } => {
                let path = if *rx > 0.0 {
                    rounded_rect(f(*x), f(*y), f(*w), f(*h), f(*rx))
                } else {
                    Rect::from_xywh(f(*x), f(*y), f(*w), f(*h)).map(PathBuilder::from_rect)
                };
                if let Some(path) = path {
                    pixmap.fill_path(&path, &paint(fill, *opacity), FillRule::Winding, Transform::identity(), None);
                    if let Some(o) = outline {
                        stroke(pixmap, &path, o.colour, o.opacity, o.width, None);
                    }
                }
            }
            // A line along an axis is a row of boxes (its dashes), butt-ended.
            Shape::Line { a, b, colour, width, dash } if f(a.0) == f(b.0) || f(a.1) == f(b.1) => {
                let (a, b) = ((f(a.0), f(a.1)), (f(b.0), f(b.1)));
                let half = (*width / 2.0) as f32;
                let along_x = a.1 == b.1;
                let (from, to) = if along_x { (a.0, b.0) } else { (a.1, b.1) };
                let (lo, hi) = (from.min(to), from.max(to));
                let (on, off) = dash.map_or((hi - lo, 0.0), |(on, off)| (on as f32, off as f32));
                // Dashes start at `from`, as SVG lays them along the line.
                let mut start = 0.0_f32;
                while start < hi - lo {
                    let end = (start + on).min(hi - lo);
                    let (s0, s1) = if from <= to { (from + start, from + end) } else { (from - end, from - start) };
                    let dash_box =
                        if along_x { (s0, a.1 - half, s1, a.1 + half) } else { (a.0 - half, s0, a.0 + half, s1) };
                    fill_box(pixmap, dash_box, colour, 1.0);
                    start = end + off;
                    if on + off <= 0.0 {
                        break;
                    }
                }
            }
            Shape::Line { a, b, colour, width, dash } => {
                // Clipped to the picture (with a margin of its width), the
                // dashes kept in phase with the line's start.
                let margin = *width + 2.0;
                let bounds =
                    (-margin, -margin, f64::from(pixmap.width()) + margin, f64::from(pixmap.height()) + margin);
                let Some((t0, t1)) = clip((f(a.0).into(), f(a.1).into()), (f(b.0).into(), f(b.1).into()), bounds)
                else {
                    return;
                };
                let (a, b) = ((f(a.0) as f64, f(a.1) as f64), (f(b.0) as f64, f(b.1) as f64));
                let at = |t: f64| ((a.0 + t * (b.0 - a.0)) as f32, (a.1 + t * (b.1 - a.1)) as f32);
                let ((x0, y0), (x1, y1)) = (at(t0), at(t1));
                let mut p = PathBuilder::new();
                p.move_to(x0, y0);
                p.line_to(x1, y1);
                let skipped = t0 * (b.0 - a.0).hypot(b.1 - a.1);
                if let Some(path) = p.finish() {
                    let dash = dash.map(|(on, off)| (on, off, skipped));
                    stroke(pixmap, &path, colour, 1.0, *width, dash);
                }
            }
            Shape::Polygon { points, fill } => {
                let mut p = PathBuilder::new();
                for (i, q) in points.iter().enumerate() {
                    if i == 0 { p.move_to(f(q.0), f(q.1)) } else { p.line_to(f(q.0), f(q.1)) }
                }
                p.close();
                if let Some(path) = p.finish() {
                    pixmap.fill_path(&path, &paint(fill, 1.0), FillRule::Winding, Transform::identity(), None);
                }
            }
            Shape::Circle { c, r, fill, opacity, outline } => {
                if let Some(path) = PathBuilder::from_circle(f(c.0), f(c.1), f(*r)) {
                    pixmap.fill_path(&path, &paint(fill, *opacity), FillRule::Winding, Transform::identity(), None);
                    if let Some(o) = outline {
                        stroke(pixmap, &path, o.colour, o.opacity, o.width, None);
                    }
                }
            }
        }
    }
}

/// An axis-aligned box `(left, top, right, bottom)` in pixels, clipped to
/// the picture (a road runs far past its edges), written into the pixels
/// directly: whole pixels copied, the fractional edges blended by the share
/// of each pixel the box covers (exact area coverage, integer blending: the
/// same bytes everywhere). tiny-skia's anti-aliased fill took 35 us for a
/// road's edge.
fn fill_box(pixmap: &mut Pixmap, (left, top, right, bottom): (f32, f32, f32, f32), hex: &str, opacity: f64) {
    let (side_w, side_h) = (pixmap.width() as i32, pixmap.height() as i32);
    let (left, top) = (left.max(0.0), top.max(0.0));
    let (right, bottom) = (right.min(side_w as f32), bottom.min(side_h as f32));
    if left >= right || top >= bottom {
        return;
    }
    let c = colour(hex, 1.0).to_color_u8();
    let ink = [c.red(), c.green(), c.blue(), 255];
    let opacity = opacity.clamp(0.0, 1.0) as f32;
    // The share of pixel [k, k + 1) inside [lo, hi).
    let share = |k: i32, lo: f32, hi: f32| (hi.min(k as f32 + 1.0) - lo.max(k as f32)).clamp(0.0, 1.0);
    let (x0, x1) = (left.floor() as i32, (right.ceil() as i32).min(side_w));
    let (y0, y1) = (top.floor() as i32, (bottom.ceil() as i32).min(side_h));
    let data = pixmap.data_mut();
    let solid_row: Vec<u8> = ink.iter().copied().cycle().take(4 * (x1 - x0) as usize).collect();
    for y in y0..y1 {
        let cy = share(y, top, bottom) * opacity;
        let row = 4 * (y * side_w) as usize;
        for x in x0..x1 {
            let coverage = share(x, left, right) * cy;
            let i = row + 4 * x as usize;
            if coverage >= 1.0 {
                // The rest of the row's whole pixels at once.
                let whole_end = if share(x1 - 1, left, right) >= 1.0 { x1 } else { x1 - 1 };
                if x < whole_end {
                    let n = 4 * (whole_end - x) as usize;
                    data[i..i + n].copy_from_slice(&solid_row[..n]);
                    if whole_end == x1 {
                        break;
                    }
                    // The last, partial pixel is blended by the loop.
                    let last = row + 4 * (x1 - 1) as usize;
                    let a = (share(x1 - 1, left, right) * cy * 255.0).round() as u32;
                    blend(&mut data[last..last + 4], ink, a);
                    break;
                }
            }
            let a = (coverage * 255.0).round() as u32;
            blend(&mut data[i..i + 4], ink, a);
        }
    }
}

/// `ink` (opaque) over a premultiplied pixel by `a` of 255.
fn blend(pixel: &mut [u8], ink: [u8; 4], a: u32) {
    if a == 0 {
        return;
    }
    for (p, i) in pixel.iter_mut().zip(ink) {
        *p = ((u32::from(i) * a + u32::from(*p) * (255 - a) + 127) / 255) as u8;
    }
}

/// `#rrggbb` at `opacity`.
pub(super) fn colour(hex: &str, opacity: f64) -> Color {
    let v = u32::from_str_radix(hex.trim_start_matches('#'), 16).unwrap_or(0);
    let channel = |shift: u32| ((v >> shift) & 0xff) as u8;
    let alpha = (opacity.clamp(0.0, 1.0) * 255.0).round() as u8;
    Color::from_rgba8(channel(16), channel(8), channel(0), alpha)
}

fn paint(hex: &str, opacity: f64) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color(colour(hex, opacity));
    p.anti_alias = true;
    p
}

/// `path` stroked `width` wide; dashed `(on, off)` from `phase` pixels
/// into the pattern when asked.
fn stroke(
    pixmap: &mut Pixmap,
    path: &resvg::tiny_skia::Path,
    hex: &str,
    opacity: f64,
    width: f64,
    dash: Option<(f64, f64, f64)>,
) {
    let mut s = SkStroke { width: width as f32, line_cap: LineCap::Butt, ..SkStroke::default() };
    s.dash = dash
        .and_then(|(on, off, phase)| StrokeDash::new(vec![on as f32, off as f32], (phase.rem_euclid(on + off)) as f32));
    pixmap.stroke_path(path, &paint(hex, opacity), &s, Transform::identity(), None);
}

/// The part of the segment a-b inside `(left, top, right, bottom)`, as the
/// segment's parameters (Liang-Barsky); None when it is all outside.
fn clip(a: (f64, f64), b: (f64, f64), (left, top, right, bottom): (f64, f64, f64, f64)) -> Option<(f64, f64)> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0_f64, 1.0_f64);
    for (p, q) in [(-dx, a.0 - left), (dx, right - a.0), (-dy, a.1 - top), (dy, bottom - a.1)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    (t0 < t1).then_some((t0, t1))
}

/// A rectangle with corners of radius `r` (quarter circles as cubic
/// curves, as SVG's `rx` draws them).
fn rounded_rect(x: f32, y: f32, w: f32, h: f32, r: f32) -> Option<resvg::tiny_skia::Path> {
    let (w, h) = (w.abs(), h.abs());
    let r = r.min(w / 2.0).min(h / 2.0);
    // The control-point distance of a quarter circle drawn as one cubic.
    let k = 0.552_284_8 * r;
    let mut p = PathBuilder::new();
    p.move_to(x + r, y);
    p.line_to(x + w - r, y);
    p.cubic_to(x + w - r + k, y, x + w, y + r - k, x + w, y + r);
    p.line_to(x + w, y + h - r);
    p.cubic_to(x + w, y + h - r + k, x + w - r + k, y + h, x + w - r, y + h);
    p.line_to(x + r, y + h);
    p.cubic_to(x + r - k, y + h, x, y + h - r + k, x, y + h - r);
    p.line_to(x, y + r);
    p.cubic_to(x, y + r - k, x + r - k, y, x + r, y);
    p.close();
    p.finish()
}
