//! Conversations that show the scene as a picture (`eval --observation
//! image`): `serve` finds the episode behind them without reading a pixel,
//! as the belief probe finds it behind text.
//!
//! A picture is compared only as bytes, with the picture the simulator
//! draws for a candidate episode's observation. The first picture of every
//! (scenario, tier, seed) in `--probe-seeds` is indexed by the hash of its
//! PNG (built on the first picture conversation, in parallel); a
//! conversation's candidates are replayed with the actions of its earlier
//! replies, and the one whose every picture matches is the episode. The
//! scripted policy then answers from that episode's scene texts, which are
//! what the pictures were drawn from.
//!
//! With `--image-history K` the first turns lose their picture, so the
//! episode of every answered conversation is remembered by the hash of the
//! picture its next request will show (drawn once the answer is known),
//! and a later request is found from any picture it holds. Each text's
//! picture hash is cached, so a request draws at most one new picture per
//! candidate.

use crate::episode::Episode;
use crate::hash::fnv1a64;
use crate::observation::render_scene;
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

/// Remembered pictures and texts are forgotten past this many entries.
const MAX_REMEMBERED: usize = 1 << 20;

/// One user turn of a conversation: its picture's hash, if it has one.
pub(crate) struct UserTurn {
    pub(crate) picture: Option<u64>,
}

/// The hash a picture is known by: of its PNG bytes as base64 (the data
/// URL's payload), whatever detail it was sent at.
pub(crate) fn picture_hash(data_url: &str) -> u64 {
    fnv1a64(data_url.rsplit_once(',').map_or(data_url, |(_, b64)| b64))
}

/// The prompt tokens of a request's pictures, counted as OpenAI counts a
/// 512 x 512 picture (85 at detail low, 255 otherwise), and the bytes of
/// their data URLs (which the byte estimate of the text leaves out).
pub(crate) fn picture_usage(pictures: &[(&str, Option<&str>)]) -> (u64, usize) {
    let rule = crate::rundir::ImageTokenRule::OPENAI_TILES;
    let side = crate::picture::SIZE_PX;
    pictures.iter().fold((0, 0), |(tokens, bytes), (url, detail)| {
        let detail =
            if *detail == Some("low") { crate::rundir::ImageDetail::Low } else { crate::rundir::ImageDetail::High };
        (tokens + rule.tokens(side, side, detail), bytes + url.len())
    })
}

/// The episode found behind a pictured conversation: its scene texts, the
/// last one the scene to answer, and the ideal observer's belief there.
pub(crate) struct Found {
    pub(crate) key: (ScenarioKind, Tier, u64),
    pub(crate) scenes: Vec<String>,
    pub(crate) ideal_belief: f64,
}

type Key = (ScenarioKind, Tier, u64);

pub(crate) struct PictureIndex {
    seeds: std::ops::Range<u64>,
    set: ScenarioSet,
    by_first_picture: OnceLock<HashMap<u64, Vec<Key>>>,
    /// Scene-text hash -> its picture's hash (a picture is drawn from the text's figures).
    drawn: Mutex<HashMap<u64, u64>>,
    /// (the picture a conversation's next request will show, the answer
    /// just given) -> the episodes it may be.
    answered: Mutex<HashMap<u64, Vec<Key>>>,
}

impl std::fmt::Debug for PictureIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "PictureIndex(seeds {:?})", self.seeds)
    }
}

/// The key of a picture shown after `answer`.
fn after(picture: u64, answer: &str) -> u64 {
    crate::hash::splitmix64(picture ^ fnv1a64(answer.trim()))
}

fn png_hash(episode: &Episode) -> u64 {
    use base64::Engine;
    match crate::picture::png(episode.observation()) {
        Ok(png) => fnv1a64(&base64::engine::general_purpose::STANDARD.encode(png)),
        Err(_) => 0,
    }
}

impl PictureIndex {
    pub(crate) fn new(seeds: std::ops::Range<u64>) -> PictureIndex {
        PictureIndex {
            seeds,
            set: ScenarioSet::default(),
            by_first_picture: OnceLock::new(),
            drawn: Mutex::new(HashMap::new()),
            answered: Mutex::new(HashMap::new()),
        }
    }

    fn first_pictures(&self) -> &HashMap<u64, Vec<Key>> {
        self.by_first_picture.get_or_init(|| {
            let keys: Vec<Key> = ScenarioKind::ALL
                .into_iter()
                .flat_map(|k| Tier::ALL.into_iter().flat_map(move |t| self.seeds.clone().map(move |s| (k, t, s))))
                .collect();
            crate::redact::eline!(
                "serve: indexing the first picture of {} episodes (--probe-seeds {}..{})",
                keys.len(),
                self.seeds.start,
                self.seeds.end
            );
            let hashes = crate::par::par_map(&keys, |&(k, t, s)| {
                let episode = Episode::new(self.set.get(k), t, s);
                (fnv1a64(&render_scene(episode.observation())), png_hash(&episode))
            });
            let mut drawn = self.drawn.lock().unwrap_or_else(|e| e.into_inner());
            let mut index: HashMap<u64, Vec<Key>> = HashMap::new();
            for (key, (text, picture)) in keys.into_iter().zip(hashes) {
                drawn.insert(text, picture);
                index.entry(picture).or_default().push(key);
            }
            index
        })
    }

    /// The hash of `episode`'s picture now (`text` its scene text): from
    /// the cache, or drawn once and cached.
    fn picture_hash(&self, episode: &Episode, text: &str) -> u64 {
        let text_hash = fnv1a64(text);
        if let Some(&known) = self.drawn.lock().unwrap_or_else(|e| e.into_inner()).get(&text_hash) {
            return known;
        }
        let drawn = png_hash(episode);
        let mut cache = self.drawn.lock().unwrap_or_else(|e| e.into_inner());
        if cache.len() >= MAX_REMEMBERED {
            cache.clear();
        }
        cache.insert(text_hash, drawn);
        drawn
    }

    /// Remember the episode `key` by the picture its next request will
    /// show: the one after `replies` (the conversation's, then this
    /// answer). With `--image-history 1` no earlier picture is left in that
    /// request to find it by. Drawing it here costs nothing more: the next
    /// request's check finds it in the cache.
    pub(crate) fn expect_next(&self, key: Key, replies: &[&str]) {
        let Some(&answer) = replies.last() else { return };
        let (kind, tier, seed) = key;
        let mut episode = Episode::new(self.set.get(kind), tier, seed);
        for reply in replies {
            if episode.is_done() {
                return;
            }
            episode.step(crate::action::parse_action(reply).action);
        }
        if episode.is_done() {
            return;
        }
        let picture = self.picture_hash(&episode, &render_scene(episode.observation()));
        let mut answered = self.answered.lock().unwrap_or_else(|e| e.into_inner());
        if answered.len() >= MAX_REMEMBERED {
            answered.clear();
        }
        let keys = answered.entry(after(picture, answer)).or_default();
        if !keys.contains(&key) {
            keys.push(key);
        }
    }

    /// The episodes a conversation of `users` turns with `replies` between
    /// them may be: every candidate that shows its every picture (more than
    /// one only while their pictures have been the same; they are told
    /// apart by the next picture that differs). Empty when none does.
    pub(crate) fn find(&self, users: &[UserTurn], replies: &[&str]) -> Vec<Found> {
        let mut found = Vec::new();
        let Some(last) = users.len().checked_sub(1) else { return found };
        if replies.len() < last {
            return found;
        }
        let mut candidates: Vec<Key> = Vec::new();
        if let Some(first) = users[0].picture {
            candidates.extend(self.first_pictures().get(&first).into_iter().flatten());
        }
        {
            // A picture is looked up with the answer before it: the same
            // picture in two episodes is told apart by what was answered.
            let answered = self.answered.lock().unwrap_or_else(|e| e.into_inner());
            for (i, user) in users.iter().enumerate().skip(1) {
                if let (Some(p), Some(reply)) = (user.picture, replies.get(i - 1)) {
                    candidates.extend(answered.get(&after(p, reply)).into_iter().flatten());
                }
            }
        }
        let mut seen = std::collections::HashSet::new();
        candidates.retain(|k| seen.insert(*k));
        'candidates: for (kind, tier, seed) in candidates {
            let mut episode = Episode::new(self.set.get(kind), tier, seed);
            let mut scenes = Vec::with_capacity(users.len());
            for (i, user) in users.iter().enumerate() {
                if episode.is_done() {
                    continue 'candidates;
                }
                let text = render_scene(episode.observation());
                if let Some(p) = user.picture
                    && self.picture_hash(&episode, &text) != p
                {
                    continue 'candidates;
                }
                scenes.push(text);
                if i == last {
                    found.push(Found { key: (kind, tier, seed), scenes, ideal_belief: episode.ideal_belief() });
                    continue 'candidates;
                }
                episode.step(crate::action::parse_action(replies[i]).action);
            }
        }
        found
    }
}
