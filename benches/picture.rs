//! The scene picture's speed: one decision's picture drawn, painted and
//! encoded as PNG, beside the scene text of the same decision (what a text
//! run renders instead), the PNG encoder alone on the same pixels, the
//! picture's SVG, and two alternatives: rasterising that SVG through
//! resvg, and encoding the pixels as a 256-colour indexed PNG.
//! Run: cargo bench --bench picture

use criterion::{Criterion, criterion_group, criterion_main};
use negotiator::action::{Action, Maneuver};
use negotiator::episode::Episode;
use negotiator::observation::render_scene;
use negotiator::picture;
use negotiator::scenario::{ScenarioKind, ScenarioSet, Tier};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let set = ScenarioSet::default();
    for kind in ScenarioKind::ALL {
        let mut ep = Episode::new(set.get(kind), Tier::T3, 17);
        for _ in 0..4 {
            ep.step(Action::new(Maneuver::Proceed, 0.5));
        }
        let obs = *ep.observation();
        c.bench_function(&format!("{kind}/scene text"), |b| b.iter(|| black_box(render_scene(black_box(&obs)))));
        c.bench_function(&format!("{kind}/picture svg"), |b| b.iter(|| black_box(picture::svg(black_box(&obs)))));
        c.bench_function(&format!("{kind}/picture png (draw, rasterise, encode)"), |b| {
            b.iter(|| black_box(picture::png(black_box(&obs)).unwrap()))
        });
        // The encoder alone, on the picture's own pixels: what any picture
        // of this size costs before a shape is drawn.
        let png = picture::png(&obs).unwrap();
        let mut reader = png::Decoder::new(std::io::Cursor::new(&png)).read_info().unwrap();
        let mut rgba = vec![0; reader.output_buffer_size()];
        reader.next_frame(&mut rgba).unwrap();
        c.bench_function(&format!("{kind}/picture png, the encoder alone"), |b| {
            b.iter(|| black_box(picture::encode(picture::SIZE_PX, picture::SIZE_PX, black_box(&rgba)).unwrap()))
        });
        // The alternative design: the same pixels as a 256-colour indexed
        // PNG (the picture's most frequent colours, every other pixel its
        // nearest), quantised outside the timing: the encoder alone.
        let (indices, palette, colours) = quantise(&rgba);
        let indexed = encode_indexed(&indices, &palette);
        eprintln!("{kind}: {colours} colours; RGBA PNG {} bytes, indexed PNG {} bytes", png.len(), indexed.len());
        c.bench_function(&format!("{kind}/alternative: 256-colour indexed png, the encoder alone"), |b| {
            b.iter(|| black_box(encode_indexed(black_box(&indices), &palette)))
        });
        // The alternative: the same picture's SVG parsed and rasterised by
        // resvg (its text through usvg's layout, without a font database:
        // the text is left out, so this is a lower bound), then encoded.
        let svg = picture::svg(&obs).unwrap();
        c.bench_function(&format!("{kind}/alternative: svg through resvg, then png"), |b| {
            b.iter(|| {
                let tree = resvg::usvg::Tree::from_str(black_box(&svg), &resvg::usvg::Options::default()).unwrap();
                let mut pixmap = resvg::tiny_skia::Pixmap::new(picture::SIZE_PX, picture::SIZE_PX).unwrap();
                resvg::render(&tree, resvg::tiny_skia::Transform::identity(), &mut pixmap.as_mut());
                black_box(pixmap.encode_png().unwrap())
            })
        });
    }
}

/// The picture's 256 most frequent colours as a palette, each pixel's
/// index (a rarer colour's nearest), and how many colours there were.
fn quantise(rgba: &[u8]) -> (Vec<u8>, Vec<u8>, usize) {
    let mut counts: std::collections::HashMap<[u8; 3], usize> = Default::default();
    for p in rgba.chunks_exact(4) {
        *counts.entry([p[0], p[1], p[2]]).or_default() += 1;
    }
    let mut colours: Vec<([u8; 3], usize)> = counts.into_iter().collect();
    colours.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let palette: Vec<[u8; 3]> = colours.iter().take(256).map(|c| c.0).collect();
    let distance = |a: &[u8; 3], b: &[u8; 3]| (0..3).map(|i| (i32::from(a[i]) - i32::from(b[i])).pow(2)).sum::<i32>();
    let index: std::collections::HashMap<[u8; 3], u8> = colours
        .iter()
        .map(|(c, _)| {
            let nearest = (0..palette.len()).min_by_key(|&i| distance(&palette[i], c)).unwrap();
            (*c, nearest as u8)
        })
        .collect();
    let indices = rgba.chunks_exact(4).map(|p| index[&[p[0], p[1], p[2]]]).collect();
    (indices, palette.concat(), colours.len())
}

/// An indexed PNG with the settings `picture::encode` uses.
fn encode_indexed(indices: &[u8], palette: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(32 * 1024);
    let mut encoder = png::Encoder::new(&mut out, picture::SIZE_PX, picture::SIZE_PX);
    encoder.set_color(png::ColorType::Indexed);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_palette(palette.to_vec());
    encoder.set_compression(png::Compression::Fast);
    encoder.set_filter(png::FilterType::Up);
    encoder.set_adaptive_filter(png::AdaptiveFilterType::NonAdaptive);
    let mut writer = encoder.write_header().unwrap();
    writer.write_image_data(indices).unwrap();
    writer.finish().unwrap();
    out
}

criterion_group!(benches, bench);
criterion_main!(benches);
