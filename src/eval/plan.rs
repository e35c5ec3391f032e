//! `eval --dry-run`: what a run would send and cost, with nothing sent.
//!
//! A model's episode lengths are unknown before it plays, but the expert's
//! are a known quantity: each selected (scenario, tier, seed) is played by
//! the expert exactly as `negotiator serve --policy expert` answers it, and
//! every request of it is built as `eval` would build it (system prompt,
//! history window, scene text, the same serialiser). So the plan measures
//! real prompts, history growth included, rather than guessing a length.
//!
//! Tokens are estimated from bytes: one token per 4 bytes of the request
//! body (JSON included) and of the reply, rounded up per request, the
//! estimate `serve` reports and `eval` falls back on when an endpoint
//! reports no usage. Against `serve --policy expert` the plan's token
//! counts are therefore exact; against a real tokenizer they are a rough
//! guide (English prose runs about 4 characters per token; numbers-heavy
//! scene text somewhat fewer). The prompt tokens a provider could serve
//! from its prefix cache are those of the bytes a request shares with the
//! previous request of its episode.

use super::EvalOptions;
use super::prompt::{History, SceneMessage, history_answer};
use crate::action::parse_action;
use crate::episode::Episode;
use crate::export::{Cell, Column, Exporter, Field, MarkdownExporter, Style, Table};
use crate::llm::client::request_body;
use crate::llm::{ChatMessage, ChatRequest, Role};
use crate::policy::PolicyKind;
use crate::rundir::record::EpisodeKey;
use crate::rundir::{HistoryWindow, RunConfig};
use crate::scenario::{ScenarioKind, Tier};
use serde::Serialize;
use std::collections::{BTreeMap, BinaryHeap, HashSet};

/// Bytes per token of the estimate (see the module documentation).
pub const BYTES_PER_TOKEN: usize = 4;
/// Assumed seconds per turn for a model that does not think, when
/// `--assume-latency` is not given: a short JSON answer from a hosted model
/// under load.
pub const BASE_TURN_LATENCY_S: f64 = 1.0;
/// Assumed thinking speed (tokens per second) added to the turn latency of
/// a model whose profile expects reasoning tokens.
pub const THINKING_TOKENS_PER_S: f64 = 100.0;

/// The system prompt the run sends for `kind`.
fn system_prompt(config: &RunConfig, kind: ScenarioKind) -> String {
    super::prompt::system_prompt(config.probe, kind, config.observation())
}

fn tokens(bytes: usize) -> u64 {
    bytes.div_ceil(BYTES_PER_TOKEN) as u64
}

/// One (scenario, tier) of the plan; token figures are totals over the
/// cell's episodes still to run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CellPlan {
    pub scenario: ScenarioKind,
    pub tier: Tier,
    pub episodes: u64,
    /// Mean decision turns of the expert's episodes.
    pub turns_per_episode: f64,
    /// The scenario's turn budget at this tier: the most an episode can take.
    pub turn_budget: u32,
    pub turns: u64,
    pub prompt_tokens: u64,
    /// Of the prompt tokens, the pictures' (`--observation image|both`).
    pub image_tokens: u64,
    /// Prompt tokens shared with the previous request of the episode.
    pub cacheable_tokens: u64,
    /// The answers' tokens, without reasoning.
    pub answer_tokens: u64,
}

/// The whole plan.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Plan {
    pub selected: usize,
    /// Episodes of the selection already in the run directory.
    pub finished: usize,
    pub cells: Vec<CellPlan>,
    pub episodes: u64,
    pub turns: u64,
    pub prompt_tokens: u64,
    /// Of the prompt tokens, the pictures', and the rule that counted them.
    pub image_tokens: u64,
    pub image_rule: Option<String>,
    pub cacheable_tokens: u64,
    /// Answer tokens plus the profile's expected reasoning per turn.
    pub completion_tokens: u64,
    pub reasoning_tokens: u64,
    pub reasoning_per_turn: u64,
    /// USD with no cache hit, and with every shareable prefix cached;
    /// `None` when the price is unknown.
    pub cost_no_cache: Option<f64>,
    pub cost_all_cached: Option<f64>,
    pub latency_s: f64,
    /// Whether the latency came from `--assume-latency`.
    pub latency_given: bool,
    pub concurrency: usize,
    /// Wall time of the longest-first schedule of the episodes over
    /// `concurrency` slots at `latency_s` per turn.
    pub wall_s: f64,
}

/// What the expert's play of one seed measures.
#[derive(Debug, Clone, Copy, Default)]
struct Measured {
    turns: u32,
    prompt_tokens: u64,
    /// Of the prompt tokens, the pictures' (by the prices file's rule).
    image_tokens: u64,
    cacheable_tokens: u64,
    answer_tokens: u64,
}

/// Play `key`'s episode with the expert as `serve` answers, building each
/// request exactly as `eval` does, and measure it.
fn measure(options: &EvalOptions, key: (ScenarioKind, Tier, u64)) -> Measured {
    let (scenario, tier, seed) = key;
    let mut episode = Episode::new(options.scenario_set.get(scenario), tier, seed);
    let system = ChatMessage::new(Role::System, system_prompt(&options.config, scenario));
    let mut history = History::default();
    let mut previous: Vec<u8> = Vec::new();
    let mut m = Measured::default();
    let per_picture = options.tokens_per_picture();
    let image_history = options.config.pictures.and_then(|p| p.history);
    // Pictures a provider could serve from its prefix cache: every earlier
    // one, when each request extends the previous one (a full history with
    // every picture kept); none once old turns change or drop out.
    let prefix_keeps_pictures = options.config.history == HistoryWindow::Full && image_history.is_none();
    while !episode.is_done() {
        let scene = SceneMessage::for_counting(episode.observation(), options.config.pictures);
        let (body, pictures) = {
            let messages = history.messages(&system, options.config.history, image_history, &scene.message);
            let pictures = messages.iter().filter(|msg| msg.image.is_some()).count() as u64;
            let request = ChatRequest {
                model: &options.config.model,
                messages: &messages,
                params: &options.config.request_params,
            };
            (request_body(&request), pictures)
        };
        let shared = previous.iter().zip(&body).take_while(|(a, b)| a == b).count();
        let answer = crate::policy::reply::answer(PolicyKind::Expert, 0, &scene.scene);
        let content = crate::policy::reply::action_content(&answer.action, &answer.reasoning);
        m.turns += 1;
        m.prompt_tokens += tokens(body.len()) + pictures * per_picture;
        m.image_tokens += pictures * per_picture;
        if prefix_keeps_pictures {
            m.cacheable_tokens += pictures.saturating_sub(1) * per_picture;
        }
        m.cacheable_tokens += (shared / BYTES_PER_TOKEN) as u64;
        m.answer_tokens += tokens(content.len());
        // The action eval would execute: the reply as its parser reads it.
        episode.step(parse_action(&content).action);
        history.push(scene, history_answer(&content));
        previous = body;
    }
    m
}

/// The plan of the episodes of `options.selection` not in `finished`.
pub fn plan(options: &EvalOptions, finished: &HashSet<EpisodeKey>, latency_s: Option<f64>) -> Plan {
    let selection = options.selection.keys();
    let todo: Vec<EpisodeKey> = selection.iter().copied().filter(|k| !finished.contains(k)).collect();
    // Rollouts of one seed play the same expert episode: measure it once.
    let mut seeds: Vec<(ScenarioKind, Tier, u64)> = todo.iter().map(|k| (k.scenario, k.tier, k.seed)).collect();
    seeds.dedup();
    let measured: BTreeMap<(ScenarioKind, Tier, u64), Measured> =
        seeds.iter().copied().zip(crate::par::par_map(&seeds, |k| measure(options, *k))).collect();

    let mut cells: Vec<CellPlan> = Vec::new();
    let mut lengths: Vec<u64> = Vec::with_capacity(todo.len());
    for key in &todo {
        let m = measured[&(key.scenario, key.tier, key.seed)];
        lengths.push(u64::from(m.turns));
        if cells.last().is_none_or(|c| (c.scenario, c.tier) != (key.scenario, key.tier)) {
            cells.push(CellPlan {
                scenario: key.scenario,
                tier: key.tier,
                episodes: 0,
                turns_per_episode: 0.0,
                turn_budget: Episode::new(options.scenario_set.get(key.scenario), key.tier, key.seed)
                    .observation()
                    .turn_budget,
                turns: 0,
                prompt_tokens: 0,
                image_tokens: 0,
                cacheable_tokens: 0,
                answer_tokens: 0,
            });
        }
        let c = cells.last_mut().expect("pushed above");
        c.episodes += 1;
        c.turns += u64::from(m.turns);
        c.prompt_tokens += m.prompt_tokens;
        c.image_tokens += m.image_tokens;
        c.cacheable_tokens += m.cacheable_tokens;
        c.answer_tokens += m.answer_tokens;
    }
    for c in &mut cells {
        c.turns_per_episode = c.turns as f64 / c.episodes.max(1) as f64;
    }
    let sum = |f: fn(&CellPlan) -> u64| cells.iter().map(f).sum::<u64>();
    let turns = sum(|c| c.turns);
    let reasoning_per_turn = options.profile.expected_reasoning_tokens;
    let reasoning_tokens = turns * reasoning_per_turn;
    let (prompt_tokens, cacheable_tokens) = (sum(|c| c.prompt_tokens), sum(|c| c.cacheable_tokens));
    let completion_tokens = sum(|c| c.answer_tokens) + reasoning_tokens;
    let latency = latency_s.unwrap_or(BASE_TURN_LATENCY_S + reasoning_per_turn as f64 / THINKING_TOKENS_PER_S);
    let concurrency = options.concurrency.max(1);
    Plan {
        selected: selection.len(),
        finished: selection.len() - todo.len(),
        episodes: todo.len() as u64,
        turns,
        prompt_tokens,
        image_tokens: sum(|c| c.image_tokens),
        image_rule: options.config.pictures.map(|p| {
            let rule = options.pricing.as_ref().and_then(|p| p.image_tokens);
            format!(
                "{} per {}x{} picture at detail {} ({})",
                options.tokens_per_picture(),
                crate::picture::SIZE_PX,
                crate::picture::SIZE_PX,
                p.detail.name(),
                match rule {
                    Some(r) => format!(
                        "the prices file's rule for this model: {}",
                        serde_json::to_string(&r).unwrap_or_default()
                    ),
                    None => "no rule for this model in the prices file: OpenAI's tiles".to_string(),
                }
            )
        }),
        cacheable_tokens,
        completion_tokens,
        reasoning_tokens,
        reasoning_per_turn,
        cost_no_cache: options.pricing.as_ref().map(|p| p.cost(prompt_tokens, 0, completion_tokens)),
        cost_all_cached: options.pricing.as_ref().map(|p| p.cost(prompt_tokens, cacheable_tokens, completion_tokens)),
        latency_s: latency,
        latency_given: latency_s.is_some(),
        concurrency,
        wall_s: schedule_turns(&mut lengths, concurrency) as f64 * latency,
        cells,
    }
}

/// Turns until the last episode ends when episodes (lengths in turns) are
/// started longest first, each on the slot that frees up first, with
/// `slots` in flight: what `eval`'s scheduler approaches (it learns the
/// long cells as it goes).
fn schedule_turns(lengths: &mut [u64], slots: usize) -> u64 {
    lengths.sort_unstable_by(|a, b| b.cmp(a));
    let mut free_at: BinaryHeap<std::cmp::Reverse<u64>> =
        (0..slots.min(lengths.len())).map(|_| std::cmp::Reverse(0)).collect();
    let mut end = 0;
    for &len in lengths.iter() {
        let std::cmp::Reverse(start) = free_at.pop().expect("at least one slot");
        end = end.max(start + len);
        free_at.push(std::cmp::Reverse(start + len));
    }
    end
}

/// The per-cell table of the plan.
pub(crate) fn table(plan: &Plan) -> Table {
    type C = CellPlan;
    let per_ep = |x: u64, c: &C| x as f64 / c.episodes.max(1) as f64;
    let mut fields: Vec<Field<C>> = vec![
        Field::new(Column::new("scenario", "scenario"), |c: &C| Cell::text(c.scenario.to_string())),
        Field::new(Column::new("tier", "tier"), |c: &C| Cell::Int(c.tier.number().into())),
        Field::new(Column::new("episodes", "episodes"), |c: &C| Cell::Int(c.episodes)),
        Field::new(Column::new("turns/ep (expert)", "turns_per_episode"), |c: &C| Cell::Float(c.turns_per_episode)),
        Field::new(Column::new("turn budget", "turn_budget"), |c: &C| Cell::Int(c.turn_budget.into())),
        Field::new(Column::new("prompt tokens/ep", "prompt_tokens_per_episode").style(Style::Whole), move |c: &C| {
            Cell::Float(per_ep(c.prompt_tokens, c))
        }),
        Field::new(Column::new("cacheable", "cacheable_share"), |c: &C| {
            Cell::Percent(100.0 * c.cacheable_tokens as f64 / c.prompt_tokens.max(1) as f64)
        }),
        Field::new(Column::new("answer tokens/ep", "answer_tokens_per_episode").style(Style::Whole), move |c: &C| {
            Cell::Float(per_ep(c.answer_tokens, c))
        }),
    ];
    // Pictures' tokens: a column of picture runs only.
    if plan.image_rule.is_some() {
        let images = Column::new("image tokens/ep", "image_tokens_per_episode").style(Style::Whole);
        fields.insert(6, Field::new(images, move |c: &C| Cell::Float(per_ep(c.image_tokens, c))));
    }
    Table::of("dry_run", "", &fields, &plan.cells)
}

fn duration(s: f64) -> String {
    let s = s.round() as u64;
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {} s", s / 60, s % 60),
        _ => format!("{} h {} min", s / 3600, s % 3600 / 60),
    }
}

/// The plan as printed: the selection, the per-cell table, the totals, the
/// cost, the time, and how they were estimated.
pub fn render(plan: &Plan, options: &EvalOptions) -> String {
    let mut out = String::new();
    out.push_str(&format!(
        "dry run: nothing was sent. model {} at {} (request profile '{}'), run directory {}\n",
        options.config.model,
        crate::redact::url_without_userinfo(&options.client.base_url),
        options.profile_name,
        options.run_dir.display()
    ));
    out.push_str(&format!(
        "{} episodes selected, {} already finished, {} to run\n\n",
        plan.selected, plan.finished, plan.episodes
    ));
    out.push_str(&MarkdownExporter { heading_level: 2 }.render(&table(plan)));
    out.push_str(&format!(
        "\nexpected: {} turns; {} prompt tokens ({:.0}% a prefix of the episode's previous request, cacheable), \
         {} completion tokens ({} answers + {} reasoning: {} per turn, request profile '{}')\n",
        plan.turns,
        plan.prompt_tokens,
        100.0 * plan.cacheable_tokens as f64 / plan.prompt_tokens.max(1) as f64,
        plan.completion_tokens,
        plan.completion_tokens - plan.reasoning_tokens,
        plan.reasoning_tokens,
        plan.reasoning_per_turn,
        options.profile_name
    ));
    if let Some(rule) = &plan.image_rule {
        out.push_str(&format!(
            "pictures (--observation {}): {} of the prompt tokens, {rule}\n",
            options.config.observation(),
            plan.image_tokens
        ));
    }
    let usd = crate::rundir::usd;
    match (&options.pricing, plan.cost_no_cache, plan.cost_all_cached) {
        (Some(p), Some(full), Some(cached)) => out.push_str(&format!(
            "estimated cost: {} with no cache hit, {} if every cacheable prefix hits ({} '{}' as of {}: input ${}, \
             cached ${}, output ${} per 1M tokens; an estimate)\n",
            usd(full),
            usd(cached),
            p.provider,
            p.entry,
            p.as_of,
            p.input,
            p.cached_input,
            p.output
        )),
        _ => out.push_str(
            "estimated cost: unknown (no price for this model and endpoint in the prices file: add one with --prices-file)\n",
        ),
    }
    out.push_str(&format!(
        "estimated wall time at -c {}: {} ({:.1} s per turn {}; episodes longest first)\n",
        plan.concurrency,
        duration(plan.wall_s),
        plan.latency_s,
        if plan.latency_given {
            "as given by --assume-latency".to_string()
        } else {
            format!(
                "assumed: {BASE_TURN_LATENCY_S} s plus the reasoning at {THINKING_TOKENS_PER_S} tokens/s; set it with --assume-latency SECONDS"
            )
        }
    ));
    out.push_str(&format!(
        "how: the expert plays every selected seed as `serve --policy expert` answers, each request built as eval \
         builds it; tokens = bytes / {BYTES_PER_TOKEN}, request body and reply\n"
    ));
    out
}

/// The first request the run would send (its preflight), exactly: the
/// request line, the headers and the body. The caller prints it through
/// the redaction choke point, which masks the key and header values.
pub fn first_request(options: &EvalOptions, finished: &HashSet<EpisodeKey>) -> Option<String> {
    let key = options.selection.keys().into_iter().find(|k| !finished.contains(k))?;
    let episode = Episode::new(options.scenario_set.get(key.scenario), key.tier, key.seed);
    let system = ChatMessage::new(Role::System, system_prompt(&options.config, key.scenario));
    let scene = SceneMessage::new(episode.observation(), options.config.pictures).ok()?;
    let history = History::default();
    let messages = history.messages(&system, options.config.history, None, &scene.message);
    let request =
        ChatRequest { model: &options.config.model, messages: &messages, params: &options.config.request_params };
    let body = shorten_pictures(&String::from_utf8_lossy(&request_body(&request)));
    let mut out = format!("POST {}/chat/completions\n", options.client.base_url.trim_end_matches('/'));
    match (&options.client.api_key, &options.api_key_var) {
        (Some(k), _) => out.push_str(&format!("Authorization: Bearer {k}\n")),
        (None, Some(var)) => out.push_str(&format!(
            "Authorization: (the key from ${var}, which is not set: the real run would stop here)\n"
        )),
        (None, None) => {}
    }
    for (name, value) in &options.client.headers {
        out.push_str(&format!("{name}: {}\n", value.to_str().unwrap_or("(not text)")));
    }
    out.push_str("Content-Type: application/json\n\n");
    out.push_str(&body);
    out.push('\n');
    Some(out)
}

/// The body with each picture's base64 replaced by its length: a picture
/// is tens of kilobytes that say nothing to a reader of the plan.
fn shorten_pictures(body: &str) -> String {
    const PREFIX: &str = "data:image/png;base64,";
    let mut out = String::with_capacity(body.len().min(1 << 16));
    let mut rest = body;
    while let Some(at) = rest.find(PREFIX) {
        let start = at + PREFIX.len();
        let len = rest[start..].find('"').unwrap_or(rest.len() - start);
        out.push_str(&rest[..start]);
        out.push_str(&format!("...({len} base64 characters)..."));
        rest = &rest[start + len..];
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn longest_first_schedule() {
        assert_eq!(schedule_turns(&mut [10, 10, 10, 10], 2), 20);
        assert_eq!(schedule_turns(&mut [30, 5, 5, 5, 5], 2), 30, "one long episode bounds the run");
        assert_eq!(schedule_turns(&mut [4, 4, 4], 8), 4);
        assert_eq!(schedule_turns(&mut [], 4), 0);
        // Longest first is a heuristic: 7 here, where 3+3 | 2+2+2 would take 6.
        assert_eq!(schedule_turns(&mut [3, 3, 2, 2, 2], 2), 7);
    }

    #[test]
    fn durations_read_naturally() {
        assert_eq!(duration(42.4), "42 s");
        assert_eq!(duration(125.0), "2 min 5 s");
        assert_eq!(duration(7322.0), "2 h 2 min");
    }
}
