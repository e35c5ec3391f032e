//! The scene picture's speed: one decision's picture drawn, painted and
//! encoded as PNG, beside the scene text of the same decision (what a text
//! run renders instead), the picture's SVG, and the alternative of
//! rasterising that SVG through resvg.
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

criterion_group!(benches, bench);
criterion_main!(benches);
