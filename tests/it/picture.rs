//! The scene picture's goldens: one picture per scenario (the expert's
//! seventh decision of seed 3, tier 1), byte for byte, in
//! `docs/pictures/<scenario>.png`, which docs/vision.md shows. The same
//! bytes on every machine: the picture is drawn in pure Rust with the
//! bundled font. With `NEGOTIATOR_REGEN_DOCS=1` (`scripts/regen_docs.sh`)
//! they are rewritten instead.

use negotiator::episode::Episode;
use negotiator::picture;
use negotiator::policy::PolicyKind;
use negotiator::scenario::{ScenarioKind, ScenarioSet, Tier};
use std::path::PathBuf;

fn golden(kind: ScenarioKind) -> Vec<u8> {
    let set = ScenarioSet::default();
    let mut episode = Episode::new(set.get(kind), Tier::T1, 3);
    let mut expert = PolicyKind::Expert.build();
    for _ in 0..6 {
        let action = expert.act(episode.observation());
        episode.step(action);
    }
    picture::png(episode.observation()).unwrap()
}

#[test]
fn generated_pictures_are_the_goldens_byte_for_byte() {
    let rewrite = std::env::var_os("NEGOTIATOR_REGEN_DOCS").is_some();
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("docs/pictures");
    let mut stale = Vec::new();
    for kind in ScenarioKind::ALL {
        let path = dir.join(format!("{kind}.png"));
        let png = golden(kind);
        assert_eq!(png, golden(kind), "{kind}: the same observation, another picture");
        if std::fs::read(&path).ok().as_deref() == Some(png.as_slice()) {
            continue;
        }
        if rewrite {
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(&path, png).unwrap();
        } else {
            stale.push(path.display().to_string());
        }
    }
    assert!(stale.is_empty(), "pictures differ from their goldens (run scripts/regen_docs.sh):\n{}", stale.join("\n"));
}
