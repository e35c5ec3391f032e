//! `negotiator serve`: a scripted policy behind an OpenAI-compatible API.
use super::usage;
use crate::policy::PolicyKind;
use crate::probe::Probe;
use crate::serve::ServeConfig;
use std::process::ExitCode;
use std::sync::atomic::Ordering::Relaxed;
use std::time::Duration;

#[derive(Debug, clap::Args)]
pub struct ServeArgs {
    /// Address to bind.
    #[arg(long, default_value = "127.0.0.1")]
    pub host: String,
    /// Port to bind; 0 picks a free port. The address is printed on stdout
    /// as `listening on http://HOST:PORT/v1`.
    #[arg(long, default_value_t = 8765)]
    pub port: u16,
    /// The scripted model. expert_late is the expert reading the scene one
    /// decision late (from the conversation's earlier scenes);
    /// expert_cautious and expert_hedge drive the expert's rules with
    /// caution while unsure; the hedging readers brake gently from the
    /// first decision for 2.5 s, then read on time, a decision late, or a
    /// decision late with a first go that holds speed.
    #[arg(long, value_parser = policy_parser())]
    pub policy: PolicyKind,
    /// Delay added to every answered request (ms).
    #[arg(long, default_value_t = 0)]
    pub latency_ms: u64,
    /// Fraction of requests answered with a server error (500, 503, or a 200
    /// carrying an error object).
    #[arg(long, default_value_t = 0.0)]
    pub fail_rate: f64,
    /// Requests per second allowed; beyond it, 429 with Retry-After.
    #[arg(long)]
    pub rate_limit: Option<f64>,
    /// Fraction of requests whose connection is closed mid-reply.
    #[arg(long, default_value_t = 0.0)]
    pub drop_rate: f64,
    /// Fraction of requests answered with a malformed (unparseable) reply.
    #[arg(long, default_value_t = 0.0)]
    pub garbage_rate: f64,
    /// Seed of the fault injection and of the random policy.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Add the policy's belief (`belief`), the rules forecaster's forecast
    /// (`forecast`), or both (`belief,forecast`) to every answer, as for
    /// `eval --probe`. The expert states the ideal observer's belief, which
    /// needs the episode: see --probe-seeds; the forecast reads only the
    /// scene text.
    #[arg(long, default_value = "none", value_parser = parse_probe)]
    pub probe: Probe,
    /// Seeds A..B (B excluded) whose episodes the belief probe, and every
    /// conversation of pictures (`eval --observation image`), can be found
    /// among (built-in scenario parameters, every scenario and tier). A
    /// conversation outside them is counted as unidentified: the expert
    /// states the belief 0.5, and a picture-only scene gets the
    /// conservative stop. Pictures are found by their bytes, never read.
    #[arg(long, default_value = "0..1000", value_parser = parse_seed_range)]
    pub probe_seeds: std::ops::Range<u64>,
    /// Who answers `--probe forecast`: the rules forecaster, or constant
    /// velocity from the scene as printed (which scores a skill of exactly
    /// 0, the reference's own figure).
    #[arg(long, default_value = "rules", value_parser = forecaster_parser())]
    pub forecaster: crate::forecast::ForecasterKind,
}

/// `--forecaster`: the reference forecasters by name.
fn forecaster_parser() -> impl clap::builder::TypedValueParser<Value = crate::forecast::ForecasterKind> {
    use crate::forecast::ForecasterKind;
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(ForecasterKind::ALL.map(ForecasterKind::name)).map(|name| {
        *ForecasterKind::ALL.iter().find(|k| k.name() == name).expect("a listed forecaster name is a forecaster")
    })
}

/// `--policy`: clap lists the built-in policies in `--help` and refuses
/// any other name with its own error.
fn policy_parser() -> impl clap::builder::TypedValueParser<Value = PolicyKind> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(PolicyKind::ALL.map(PolicyKind::name))
        .map(|name| name.parse::<PolicyKind>().expect("a listed policy name parses"))
}

fn parse_probe(s: &str) -> Result<Probe, String> {
    s.parse()
}

fn parse_seed_range(s: &str) -> Result<std::ops::Range<u64>, String> {
    let bad = || format!("'{s}' is not A..B with A < B (whole numbers, B - A at most 1000000)");
    let (a, b) = s.trim().split_once("..").ok_or_else(bad)?;
    let (a, b): (u64, u64) = (a.trim().parse().map_err(|_| bad())?, b.trim().parse().map_err(|_| bad())?);
    if a >= b || b - a > 1_000_000 {
        return Err(bad());
    }
    Ok(a..b)
}

fn rate(x: f64, flag: &str) -> anyhow::Result<f64> {
    if (0.0..=1.0).contains(&x) { Ok(x) } else { Err(usage(format!("{flag}: expected a fraction in [0, 1], got {x}"))) }
}

impl ServeArgs {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        let policy = self.policy;
        if let Some(r) = self.rate_limit
            && !(r.is_finite() && r > 0.0)
        {
            return Err(usage(format!("--rate-limit: expected a positive number of requests per second, got {r}")));
        }
        let config = ServeConfig {
            policy,
            seed: self.seed,
            latency: Duration::from_millis(self.latency_ms),
            fail_rate: rate(self.fail_rate, "--fail-rate")?,
            rate_limit: self.rate_limit,
            drop_rate: rate(self.drop_rate, "--drop-rate")?,
            garbage_rate: rate(self.garbage_rate, "--garbage-rate")?,
            belief: self
                .probe
                .belief
                .then(|| std::sync::Arc::new(crate::serve::EpisodeIndex::build(self.probe_seeds.clone()))),
            forecast: self.probe.forecast.then_some(self.forecaster),
            probe_seeds: self.probe_seeds.clone(),
        };
        crate::redact::eline!(
            "serving policy '{policy}' (fail {} | drop {} | garbage {} | rate limit {} | latency {} ms | seed {})",
            config.fail_rate,
            config.drop_rate,
            config.garbage_rate,
            config.rate_limit.map_or("none".to_string(), |r| format!("{r}/s")),
            self.latency_ms,
            config.seed
        );
        let state = super::serve_on(&self.host, self.port, "/v1", |listener| crate::serve::serve(listener, config))?;
        let s = &state.stats;
        crate::redact::eline!(
            "served {} requests: {} ok, {} failed, {} rate-limited, {} dropped, {} garbage, {} unreadable scenes, {} \
             unidentified episodes",
            s.requests.load(Relaxed),
            s.ok.load(Relaxed),
            s.failed.load(Relaxed),
            s.rate_limited.load(Relaxed),
            s.dropped.load(Relaxed),
            s.garbage.load(Relaxed),
            s.unparseable_scenes.load(Relaxed),
            s.unidentified_episodes.load(Relaxed)
        );
        Ok(ExitCode::SUCCESS)
    }
}
