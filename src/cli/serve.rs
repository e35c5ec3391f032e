//! `negotiator serve`: a scripted policy behind an OpenAI-compatible API.
use super::usage;
use crate::policy::PolicyKind;
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
    /// The scripted model: expert, always_proceed, always_stop, cautious,
    /// random or cue_follower.
    #[arg(long)]
    pub policy: String,
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
}

fn rate(x: f64, flag: &str) -> anyhow::Result<f64> {
    if (0.0..=1.0).contains(&x) { Ok(x) } else { Err(usage(format!("{flag}: expected a fraction in [0, 1], got {x}"))) }
}

impl ServeArgs {
    pub fn run(self) -> anyhow::Result<ExitCode> {
        let policy: PolicyKind = self.policy.parse().map_err(|e| usage(format!("--policy: {e}")))?;
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
        };
        eprintln!(
            "serving policy '{policy}' (fail {} | drop {} | garbage {} | rate limit {} | latency {} ms | seed {})",
            config.fail_rate,
            config.drop_rate,
            config.garbage_rate,
            config.rate_limit.map_or("none".to_string(), |r| format!("{r}/s")),
            self.latency_ms,
            config.seed
        );
        let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
        let state = runtime
            .block_on(crate::serve::serve(&self.host, self.port, config))
            .map_err(|e| anyhow::anyhow!("serving on {}:{}: {e}", self.host, self.port))?;
        let s = &state.stats;
        eprintln!(
            "served {} requests: {} ok, {} failed, {} rate-limited, {} dropped, {} garbage, {} unreadable scenes",
            s.requests.load(Relaxed),
            s.ok.load(Relaxed),
            s.failed.load(Relaxed),
            s.rate_limited.load(Relaxed),
            s.dropped.load(Relaxed),
            s.garbage.load(Relaxed),
            s.unparseable_scenes.load(Relaxed)
        );
        Ok(ExitCode::SUCCESS)
    }
}
