//! One episode played against the endpoint, turn by turn, and its record
//! (the line of `rollouts.jsonl`).

use super::prompt::{History, SceneMessage};
use super::{AtomicU32, Ctx, now_rfc3339, prompt};
use crate::action::{parse_action, parse_belief};
use crate::belief::{BeliefMetrics, BeliefTurn};
use crate::episode::{Episode, EpisodeRecord, ForecastTruth};
use crate::forecast::{ForecastMetrics, ForecastTurn};
use crate::llm::{ChatRequest, Completion, LlmError};
use crate::rundir::record::{EpisodeKey, EpisodeScalars, ProbeScores, Provenance, RolloutRecord, TurnRecord};
use std::sync::atomic::Ordering::Relaxed;
use std::time::Instant;
/// A finished episode's summary scalars and its line, or why it did not finish.
pub(super) type EpisodeResult = Result<(EpisodeScalars, String), EpisodeError>;

/// Why an episode did not finish.
pub(super) enum EpisodeError {
    /// Retries ran out: recorded, excluded, re-run next time.
    Infra { turn: u32, message: String },
    /// The endpoint refuses the run: stop everything.
    Fatal(LlmError),
    /// The conversation outgrew the model's context at `turn`: recorded in
    /// errors.jsonl, missing from the scores; no new episode is started,
    /// the ones in flight finish.
    ContextOverflow { turn: u32, error: LlmError },
}

/// The action of a reply, with the transport's verdicts added: a reply cut
/// at the size cap, or not valid UTF-8, is the model's bad output and
/// drives as the conservative stop, like any other parse error.
pub(super) fn parse_reply(completion: &Completion, max_reply_bytes: usize) -> crate::action::ParsedAction {
    let mut parsed = parse_action(completion.content.as_deref().unwrap_or(""));
    let mut flagged = Vec::new();
    if completion.capped {
        flagged.push(crate::action::ActionParseError::Oversized { limit: max_reply_bytes });
    }
    if completion.invalid_utf8 {
        flagged.push(crate::action::ActionParseError::InvalidUtf8);
    }
    if !flagged.is_empty() {
        parsed.action = crate::action::Action::CONSERVATIVE;
        parsed.errors.splice(0..0, flagged);
    }
    parsed
}

/// Play one episode to its end; return its summary scalars and its line.
pub(super) async fn play(ctx: &Ctx, key: EpisodeKey) -> EpisodeResult {
    let opts = &ctx.options;
    let started = Instant::now();
    let config = opts.scenario_set.get(key.scenario);
    let mut episode = Episode::new(config, key.tier, key.seed);
    if opts.trajectories {
        episode.record_trajectory();
    }
    if opts.config.probe.forecast {
        episode.record_forecast_truth(config);
    }
    // The constant-velocity forecast of every turn (the forecast's floor),
    // from the observation the model saw.
    let mut constant_velocity = Vec::new();
    let mut history = History::default();
    let mut turns: Vec<TurnRecord> = Vec::new();
    let mut times: Vec<f64> = Vec::new();
    let retries = AtomicU32::new(0);
    // Priced per turn, so turns without usage are priced at their estimate.
    let mut cost: Option<f64> = opts.pricing.as_ref().map(|_| 0.0);
    while !episode.is_done() {
        let turn = episode.observation().turn;
        let scene = match SceneMessage::new(episode.observation(), opts.config.pictures) {
            Ok(s) => s,
            Err(e) => return Err(EpisodeError::Infra { turn, message: e.to_string() }),
        };
        let image_history = opts.config.pictures.and_then(|p| p.history);
        let messages = history.messages(ctx.system(key.scenario), opts.config.history, image_history, &scene.message);
        let pictures = messages.iter().filter(|m| m.image.is_some()).count() as u32;
        let image_tokens = u64::from(pictures) * opts.tokens_per_picture();
        let request =
            ChatRequest { model: &opts.config.model, messages: &messages, params: &opts.config.request_params };
        let on_retry = |message: &str| {
            retries.fetch_add(1, Relaxed);
            ctx.counters.retries.fetch_add(1, Relaxed);
            ctx.counters.record_error(message);
        };
        let answer = match ctx.take_first_turn(key) {
            Some(pre) => {
                // Retries of the preflight belong to this episode.
                let extra = pre.as_ref().map_or(opts.client.retry.max_retries, |c| c.attempts.saturating_sub(1));
                retries.fetch_add(extra, Relaxed);
                pre
            }
            None => ctx.client.chat(&request, on_retry).await,
        };
        let completion = match answer {
            Ok(c) => c,
            Err(e @ LlmError::Exhausted { .. }) => {
                return Err(EpisodeError::Infra { turn, message: e.to_string() });
            }
            Err(e @ LlmError::ContextOverflow { .. }) => return Err(EpisodeError::ContextOverflow { turn, error: e }),
            Err(e) => return Err(EpisodeError::Fatal(e)),
        };
        // Without usage, tokens are estimated from the text's bytes plus the pictures' rule.
        let sent_bytes: usize = messages.iter().map(|m| m.content.len()).sum::<usize>() + 4 * image_tokens as usize;
        drop(messages);
        let parsed = parse_reply(&completion, ctx.options.client.max_reply_bytes);
        let (tokens, estimated) = turn_tokens(&completion, sent_bytes);
        if let (Some(total), Some(pricing)) = (cost.as_mut(), opts.pricing.as_ref()) {
            let (prompt, cached, output) = billed_tokens(&completion, sent_bytes);
            let usd = pricing.cost(prompt, cached, output);
            *total += usd;
            ctx.counters.add_cost(usd);
        }
        ctx.counters.tokens.fetch_add(tokens, Relaxed);
        ctx.counters.turns.fetch_add(1, Relaxed);
        let ideal_belief = episode.ideal_belief();
        let probed = ProbeAnswers::read(opts.config.probe, completion.content.as_deref().unwrap_or(""), &episode);
        let time_s = episode.observation().time_s;
        episode.step(parsed.action);
        let answer = prompt::history_answer(&completion.answer);
        let truncated = completion.finish_reason.as_deref() == Some("length");
        turns.push(TurnRecord {
            turn,
            scene: scene.scene.clone(),
            reply: completion.content,
            reasoning: completion.reasoning,
            finish_reason: completion.finish_reason,
            action: parsed.action,
            action_reasoning: parsed.reasoning,
            parse_errors: parsed.errors,
            truncated,
            reasoning_tokens: completion.usage.map_or(0, |u| u.reasoning()),
            cached_tokens: completion.usage.map_or(0, |u| u.cached()),
            usage: completion.usage,
            tokens,
            tokens_estimated: estimated,
            reply_capped: completion.capped,
            pictures,
            image_tokens,
            latency_ms: completion.latency.as_millis() as u64,
            attempts: completion.attempts,
            after_resolution: false,
            ideal_belief: Some(ideal_belief),
            belief: probed.belief,
            belief_error: probed.belief_error,
            forecast: probed.forecast,
            forecast_error: probed.forecast_error,
        });
        times.push(time_s);
        constant_velocity.extend(probed.constant_velocity);
        history.push(scene, answer);
    }
    let forecast_truth = episode.forecast_truth().to_vec();
    let graded = episode.finish();
    let forecast = opts
        .config
        .probe
        .forecast
        .then(|| forecast_metrics(&graded, &turns, &times, constant_velocity, &forecast_truth));
    let forecast = (forecast, forecast_truth);
    let record = rollout_record(ctx, key, graded, turns, forecast, (retries.load(Relaxed), cost), started);
    let line = serde_json::to_string(&record).expect("a rollout record serialises");
    Ok((EpisodeScalars::from(&record), line))
}

/// What one reply says for the run's probes, each read apart from the
/// action (a missing or malformed field is that probe's parse error).
struct ProbeAnswers {
    belief: Option<f64>,
    belief_error: Option<crate::action::BeliefParseError>,
    forecast: Option<crate::forecast::Forecast>,
    forecast_error: Option<crate::action::ForecastParseError>,
    /// The constant-velocity forecast from the observation the reply
    /// answered (the forecast's floor), when the run probes forecasts.
    constant_velocity: Option<Vec<crate::forecast::AtHorizons>>,
}

impl ProbeAnswers {
    fn read(probe: crate::probe::Probe, reply: &str, episode: &Episode) -> ProbeAnswers {
        let (belief, belief_error) = match probe.belief.then(|| parse_belief(reply)) {
            Some(Ok(b)) => (Some(b), None),
            Some(Err(e)) => (None, Some(e)),
            None => (None, None),
        };
        let kind = episode.spec().scenario;
        let (forecast, forecast_error) = match probe.forecast.then(|| crate::forecast::parse_answer(reply, kind)) {
            Some(Ok(f)) => (Some(f), None),
            Some(Err(e)) => (None, Some(e)),
            None => (None, None),
        };
        let constant_velocity = probe.forecast.then(|| crate::forecast::constant_velocity(episode.observation()));
        ProbeAnswers { belief, belief_error, forecast, forecast_error, constant_velocity }
    }
}

/// The forecast metrics of a finished episode: each turn's stated forecast
/// (at the time of its observation) against where the road users were.
fn forecast_metrics(
    graded: &EpisodeRecord,
    turns: &[TurnRecord],
    times: &[f64],
    constant_velocity: Vec<Vec<crate::forecast::AtHorizons>>,
    truth: &[ForecastTruth],
) -> ForecastMetrics {
    let stated: Vec<ForecastTurn> = turns
        .iter()
        .zip(times)
        .zip(constant_velocity)
        .map(|((t, &time_s), cv)| ForecastTurn {
            turn: t.turn,
            time_s,
            forecast: t.forecast.clone(),
            constant_velocity: cv,
        })
        .collect();
    let lets_you_go = graded.disposition.ego_should_go();
    ForecastMetrics::compute(graded.spec.scenario, &stated, truth, lets_you_go, graded.timing.evidence_turn)
}

/// Tokens of one turn: the reported total, or (no usage reported) an
/// estimate of ~4 bytes per token over the request and the reply, so
/// budgets and tokens/episode stay meaningful. The flag says which.
pub(super) fn turn_tokens(completion: &Completion, sent_bytes: usize) -> (u64, bool) {
    match completion.usage.and_then(|u| u.total()) {
        Some(t) => (t, false),
        None => (((sent_bytes + completion.content.as_ref().map_or(0, String::len)) / 4) as u64, true),
    }
}

/// The tokens a turn is billed for: (prompt, of which cached, output with
/// hidden reasoning), as reported, or (no usage reported) estimated like
/// [`turn_tokens`] at ~4 bytes per token, none of them cached.
pub(super) fn billed_tokens(completion: &Completion, sent_bytes: usize) -> (u64, u64, u64) {
    match completion.usage {
        Some(u) if u.prompt_tokens.is_some() || u.completion_tokens.is_some() => {
            (u.prompt_tokens.unwrap_or(0), u.cached(), u.billed_output())
        }
        _ => ((sent_bytes / 4) as u64, 0, (completion.content.as_ref().map_or(0, String::len) / 4) as u64),
    }
}

/// The line of a finished episode: its grades and its transcript, with the
/// per-episode sums of the turns ([`RolloutRecord::assemble`]).
pub(super) fn rollout_record(
    ctx: &Ctx,
    key: EpisodeKey,
    graded: EpisodeRecord,
    turns: Vec<TurnRecord>,
    (forecast, forecast_truth): (Option<ForecastMetrics>, Vec<ForecastTruth>),
    (retries, cost_usd): (u32, Option<f64>),
    started: Instant,
) -> RolloutRecord {
    let belief = ctx.options.config.probe.belief.then(|| {
        let turns: Vec<BeliefTurn> = turns
            .iter()
            .zip(&graded.decisions)
            .map(|(t, d)| BeliefTurn {
                turn: t.turn,
                stated: t.belief,
                ideal: t.ideal_belief.unwrap_or(0.5),
                maneuver: t.parse_errors.is_empty().then_some(t.action.maneuver),
                open: !d.after_resolution,
            })
            .collect();
        BeliefMetrics::compute(&turns, graded.disposition.ego_should_go(), graded.timing.evidence_turn)
    });
    let from = Provenance {
        model: ctx.options.config.model.clone(),
        config_hash: ctx.hash.clone(),
        retries,
        cost_usd,
        wall_ms: started.elapsed().as_millis() as u64,
        finished_at: now_rfc3339(),
    };
    RolloutRecord::assemble(key, graded, turns, ProbeScores { belief, forecast, forecast_truth }, from)
}
