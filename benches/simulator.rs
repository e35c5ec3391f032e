//! Simulator speed: one decision (5 physics steps), one whole episode, and
//! the scene text every front end renders each turn.
//! Run: cargo bench --bench simulator

use criterion::{Criterion, criterion_group, criterion_main};
use negotiator::action::{Action, Maneuver};
use negotiator::episode::{Episode, run_episode};
use negotiator::observation::render_scene;
use negotiator::policy::PolicyKind;
use negotiator::scenario::{ScenarioKind, ScenarioSet, Tier};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let set = ScenarioSet::default();
    for kind in ScenarioKind::ALL {
        let config = set.get(kind);
        c.bench_function(&format!("{kind}/decision (5 physics steps)"), |b| {
            b.iter_batched(
                || Episode::new(config, Tier::T3, 17),
                |mut ep| {
                    ep.step(black_box(Action::new(Maneuver::Yield, 0.2)));
                    ep
                },
                criterion::BatchSize::SmallInput,
            )
        });
        c.bench_function(&format!("{kind}/scene text"), |b| {
            let mut ep = Episode::new(config, Tier::T3, 17);
            ep.step(Action::new(Maneuver::Proceed, 0.5));
            b.iter(|| black_box(render_scene(black_box(ep.observation()))))
        });
        c.bench_function(&format!("{kind}/episode (expert)"), |b| {
            let mut expert = PolicyKind::Expert.build();
            let mut seed = 0;
            b.iter(|| {
                seed += 1;
                black_box(run_episode(config, Tier::T3, seed, expert.as_mut()))
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
