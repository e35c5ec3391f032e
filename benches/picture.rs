//! The scene picture's speed: one decision's picture drawn as SVG, then
//! rasterised and encoded as PNG, beside the scene text of the same
//! decision (what a text run renders instead).
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
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
